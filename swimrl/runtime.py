"""Where and how a run computes: torch device, dtype, CPU threads and integration kernel."""

from __future__ import annotations

import ctypes
import functools
import os
import sys
from dataclasses import dataclass, field, fields
from pathlib import Path

import torch

from swimrl.conf_values import yaml_value
from swimrl.errors import ConfigError, one_of, require
from swimrl.physics.integrator import KERNELS

DTYPES = {"float32": torch.float32, "float64": torch.float64}


def resolve_device(device: str) -> torch.device:
    """``cpu``, ``cuda`` or ``cuda:N``; a clear error if CUDA is asked for but absent."""
    try:
        dev = torch.device(device)
    except RuntimeError:
        dev = None
    if dev is None or dev.type not in ("cpu", "cuda"):
        raise ConfigError(f"device={device!r} is invalid: allowed 'cpu', 'cuda', 'cuda:N'")
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ConfigError(f"device={device!r} is invalid: CUDA is not available on this machine")
    return dev


def available_memory(device: torch.device) -> int:
    """Bytes a new allocation can use: the GPU's free memory for ``cuda``; for the CPU the
    kernel's ``MemAvailable``, capped by the cgroup limit (``memory.max - memory.current``)
    when the process runs under one (a container, a Slurm job)."""
    if device.type == "cuda":
        return int(torch.cuda.mem_get_info(device)[0])
    avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    try:
        meminfo = Path("/proc/meminfo").read_text().split("\n")
        line = next(x for x in meminfo if x.startswith("MemAvailable:"))
        avail = int(line.split()[1]) * 1024
    except (OSError, StopIteration, ValueError):
        pass
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = int(Path("/sys/fs/cgroup/memory.current").read_text().strip())
        if limit != "max":
            avail = min(avail, int(limit) - used)
    except (OSError, ValueError):
        pass
    return int(avail)


def check_memory(need: int, device: torch.device, key: str, value, what: str) -> None:
    """One-line :class:`~swimrl.errors.ConfigError` naming ``key`` when ``need`` bytes
    (``what``: how they were counted) exceed :func:`available_memory` of ``device``."""
    have = available_memory(device)
    if need > have:
        raise ConfigError(
            f"{key}={value!r} is invalid: allowed a value whose memory fits this machine: "
            f"{what} need ~{need / 2**30:.1f} GiB, {have / 2**30:.1f} GiB available on "
            f"{device.type}; lower {key}"
        )


#: glibc's ``mallopt`` parameters (``malloc.h``) and the largest mmap threshold it accepts on
#: 64-bit (``DEFAULT_MMAP_THRESHOLD_MAX``, 32 MiB).
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD, MMAP_THRESHOLD_MAX = -1, -3, 32 * 2**20


@functools.cache
def retain_freed_memory() -> bool:
    """Keep freed CPU buffers of up to 32 MiB in the process's heap (glibc ``mallopt``:
    ``M_MMAP_THRESHOLD`` 32 MiB, ``M_TRIM_THRESHOLD`` 2 GiB) instead of handing them back to
    the kernel, which zero-fills their pages again at the next allocation.

    A step of the 3D flow allocates and frees ~64 MB of temporaries (its mode sum at 10 flows
    x 1000 swimmers); with glibc's defaults they are mapped and unmapped every call and the
    page faults took a third of the CPU time (half the rate: ``benchmarks/bench_env.py
    --flow stochastic3d --malloc default``). Nothing computed changes. Once per process; not on
    other C libraries, nor when ``MALLOC_MMAP_THRESHOLD_`` or ``MALLOC_TRIM_THRESHOLD_`` is set
    (the user's choice stands). Returns whether the setting was applied."""
    if not sys.platform.startswith("linux") or any(
        k in os.environ for k in ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_")
    ):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
        libc.gnu_get_libc_version  # noqa: B018 (glibc only)
    except (OSError, AttributeError):
        return False
    return bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_MAX)
                and libc.mallopt(M_TRIM_THRESHOLD, 2**31 - 1))


#: Field metadata of a setting that changes how fast or where a run computes, or what it
#: prints and how often it saves, but not what it computes: such a key may differ when a
#: training run is resumed (:func:`runtime_keys`; ``swimrl.rl.run.RESUME_FREE_KEYS``).
RUNTIME = {"runtime": True}


def runtime_keys(cls, prefix: str = "") -> set[str]:
    """``prefix + name`` of every field of the dataclass ``cls`` marked :data:`RUNTIME`."""
    return {prefix + f.name for f in fields(cls) if f.metadata.get("runtime")}


@dataclass(frozen=True)
class Runtime:
    """``device``, ``dtype`` (``float32`` | ``float64``), ``threads`` (None: all cores) and
    ``kernel`` (``auto`` | ``eager`` | ``fused`` | ``compiled``), checked on construction.
    The default ``kernel`` is read from the configs (:mod:`swimrl.conf_values`); ``threads``
    differs between commands (``conf/evaluate.yaml``: all cores, ``conf/train.yaml``: 1)
    and has none.

    Parameters
    ----------
    device
        Where flows, swimmers and networks live (``cpu``, ``cuda``, ``cuda:N``).
    dtype
        ``torch.float32`` (default) or ``torch.float64``.
    threads
        ``torch.set_num_threads`` (:meth:`apply`); None: all cores.
    kernel
        The decision-interval integrator (:func:`swimrl.physics.integrator.select_kernel`):
        ``auto`` (fused C++ on the CPU, compiled elsewhere), ``eager``, ``fused`` or
        ``compiled``.
    """

    device: torch.device = field(metadata=RUNTIME)
    dtype: torch.dtype
    threads: int | None = field(metadata=RUNTIME)
    kernel: str = field(default=yaml_value("evaluate", "kernel"), metadata=RUNTIME)

    @classmethod
    def from_names(
        cls, device: str, dtype: str, threads: int | None,
        kernel: str = yaml_value("evaluate", "kernel"),
    ) -> Runtime:
        """From the config's strings (``device=cpu dtype=float32 threads=1 kernel=auto``)."""
        dev = resolve_device(str(device))
        one_of("dtype", dtype, DTYPES)
        one_of("kernel", kernel, KERNELS)
        require(
            threads is None or (isinstance(threads, int) and threads >= 1),
            "threads",
            threads,
            "null or an integer >= 1",
        )
        return cls(dev, DTYPES[dtype], threads, kernel)

    def apply(self) -> None:
        """``torch.set_num_threads(threads)`` (all cores when ``threads`` is None) and, on
        the CPU, :func:`retain_freed_memory`."""
        torch.set_num_threads(int(self.threads) if self.threads else (os.cpu_count() or 1))
        if self.device.type == "cpu":
            retain_freed_memory()
