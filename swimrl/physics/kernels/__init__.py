"""Optional fused kernels (compiled on first use with torch's C++ extension toolchain).

The build is cached by torch under ``TORCH_EXTENSIONS_DIR`` (default
``~/.cache/torch_extensions``) in a directory named after the extension. The name carries
the hash of the kernel source, the compile flags and the torch version
(``swimrl_heun_cpu_<hash8>``), so two installs (or two versions of the source) on one machine
each keep their own build instead of rebuilding each other's.
"""

from __future__ import annotations

import functools
import hashlib
import logging
from pathlib import Path

import torch

log = logging.getLogger(__name__)

SOURCE = Path(__file__).with_name("heun_cpu.cpp")
CFLAGS = ("-O3", "-fno-math-errno")


def extension_name(source: Path = SOURCE) -> str:
    """``swimrl_heun_cpu_<hash8>``: hash of the source bytes, the flags and torch's version."""
    h = hashlib.sha256(Path(source).read_bytes())
    h.update(" ".join(CFLAGS).encode())
    h.update(torch.__version__.encode())
    return f"swimrl_heun_cpu_{h.hexdigest()[:8]}"


def build_cpu_kernel(source: Path = SOURCE):
    """Build (or load the cached build of) the kernel in ``source``; the extension module."""
    from torch.utils.cpp_extension import _get_build_directory, load

    name = extension_name(source)
    built = Path(_get_build_directory(name, verbose=False))
    if not any(built.glob(f"{name}*.so")):
        log.info("building the fused kernel (once, ~30 s) in %s", built)
    return load(name=name, sources=[str(source)], extra_cflags=list(CFLAGS), verbose=False)


@functools.cache
def load_cpu_kernel():
    """The CPU kernel (:func:`build_cpu_kernel` once per process), or None if no C++
    toolchain is available."""
    try:
        return build_cpu_kernel()
    except Exception as exc:  # noqa: BLE001 - any build failure means "use the eager path"
        log.warning("fused CPU kernel unavailable (%s); using the eager torch path", exc)
        return None


__all__ = ["build_cpu_kernel", "extension_name", "load_cpu_kernel"]
