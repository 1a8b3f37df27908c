"""Optional fused kernels (compiled on first use with torch's C++ extension toolchain).

Two sources, one extension each: ``heun_cpu.cpp`` (the 2D gridded flows,
:func:`load_cpu_kernel`) and ``heun3d_cpu.cpp`` (the 3D stochastic flow,
:func:`load_cpu_kernel_3d`). The build is cached by torch under ``TORCH_EXTENSIONS_DIR``
(default ``~/.cache/torch_extensions``) in a directory named after the extension. The name
carries the source's file name and the hash of the source, the compile flags and the torch
version (``swimrl_heun_cpu_<hash8>``, ``swimrl_heun3d_cpu_<hash8>``), so two installs (or two
versions of the source) on one machine each keep their own build instead of rebuilding each
other's.

Once built, the module is imported straight from its ``.so`` (the name already pins the
source, flags and torch version), without torch's build step and its lock file: a process
killed while torch held that lock would otherwise leave every later run waiting on it
forever. A lock older than :data:`STALE_LOCK_S` in a directory with no finished build is
such a leftover; it is removed with a warning before the build.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import sys
import time
from pathlib import Path

import torch

log = logging.getLogger(__name__)

SOURCE = Path(__file__).with_name("heun_cpu.cpp")
CFLAGS = ("-O3", "-fno-math-errno")
#: The 3D kernel: its mode loop is vectorised by ``#pragma omp simd`` (no OpenMP runtime);
#: on x86-64 it carries its own versions per instruction set (``target_clones``), so the
#: flags stay machine-independent.
SOURCE_3D = Path(__file__).with_name("heun3d_cpu.cpp")
CFLAGS_3D = ("-O3", "-fno-math-errno", "-fopenmp-simd")
#: A build lock older than this (seconds) is a leftover of a killed process (a build: ~30 s).
STALE_LOCK_S = 600.0


def extension_name(source: Path = SOURCE, cflags: tuple[str, ...] = CFLAGS) -> str:
    """``swimrl_<stem>_<hash8>`` (``swimrl_heun_cpu_<hash8>`` for :data:`SOURCE`): hash of the
    source bytes, the flags and torch's version."""
    h = hashlib.sha256(Path(source).read_bytes())
    h.update(" ".join(cflags).encode())
    h.update(torch.__version__.encode())
    return f"swimrl_{Path(source).stem}_{h.hexdigest()[:8]}"


def build_cpu_kernel(source: Path = SOURCE, cflags: tuple[str, ...] = CFLAGS):
    """Build (or load the cached build of) the kernel in ``source``; the extension module."""
    from torch.utils.cpp_extension import (
        _get_build_directory,
        _import_module_from_library,
        load,
    )

    name = extension_name(source, cflags)
    built = Path(_get_build_directory(name, verbose=False))
    library = built / f"{name}.so"
    if library.is_file():  # torch's own loader for a finished build, without its build step
        return _import_module_from_library(name, str(built), True)
    remove_stale_lock(built / "lock")
    # one line on stderr, whatever the logging setup: the first call waits ~30 s for this
    print(f"swimrl: building the fused kernel (once, ~30 s) in {built}", file=sys.stderr,
          flush=True)
    return load(name=name, sources=[str(source)], extra_cflags=list(cflags), verbose=False)


def remove_stale_lock(lock: Path, max_age_s: float = STALE_LOCK_S) -> bool:
    """Delete ``lock`` if it is older than ``max_age_s`` seconds (a killed build's leftover,
    on which torch's build would wait forever); True if it was removed."""
    try:
        age = time.time() - lock.stat().st_mtime
    except FileNotFoundError:
        return False
    if age < max_age_s:
        return False
    log.warning("removing the stale build lock %s (%.0f s old, left by a killed process)",
                lock, age)
    lock.unlink(missing_ok=True)
    return True


@functools.cache
def load_cpu_kernel():
    """The CPU kernel (:func:`build_cpu_kernel` once per process), or None if no C++
    toolchain is available."""
    try:
        return build_cpu_kernel()
    except Exception as exc:  # noqa: BLE001 - any build failure means "use the eager path"
        log.warning("fused CPU kernel unavailable (%s); using the eager torch path", exc)
        return None


@functools.cache
def load_cpu_kernel_3d():
    """The 3D kernel (``heun3d_cpu.cpp``, built once per process as :func:`load_cpu_kernel`),
    or None if no C++ toolchain is available."""
    try:
        return build_cpu_kernel(SOURCE_3D, CFLAGS_3D)
    except Exception as exc:  # noqa: BLE001 - any build failure: the caller says what to use
        log.warning("fused 3D CPU kernel unavailable (%s)", exc)
        return None


__all__ = [
    "CFLAGS_3D",
    "SOURCE_3D",
    "STALE_LOCK_S",
    "build_cpu_kernel",
    "extension_name",
    "load_cpu_kernel",
    "load_cpu_kernel_3d",
    "remove_stale_lock",
]
