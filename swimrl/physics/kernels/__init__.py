"""Optional fused kernels (compiled on first use with torch's C++ extension toolchain)."""

from __future__ import annotations

import functools
import logging
from pathlib import Path

log = logging.getLogger(__name__)


@functools.cache
def load_cpu_kernel():
    """Build (once, cached by torch under ``TORCH_EXTENSIONS_DIR``) and import the CPU kernel.

    Returns the extension module, or None if no C++ toolchain is available.
    """
    try:
        from torch.utils.cpp_extension import load

        src = Path(__file__).with_name("heun_cpu.cpp")
        return load(
            name="swimrl_heun_cpu",
            sources=[str(src)],
            extra_cflags=["-O3", "-fno-math-errno"],
            verbose=False,
        )
    except Exception as exc:  # noqa: BLE001 - any build failure means "use the eager path"
        log.warning("fused CPU kernel unavailable (%s); using the eager torch path", exc)
        return None
