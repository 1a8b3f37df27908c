"""``retain_freed_memory``: a CPU buffer below 32 MiB comes from the process's heap (glibc
``brk``), not from a fresh mapping, so allocating the same temporaries again does not fault
their pages in again (glibc only)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from swimrl.runtime import retain_freed_memory

glibc = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc mallopt")

#: A child process: whether a fresh 25.6 MB tensor lies in the ``[heap]`` mapping of
#: /proc/self/maps, then 20 rounds of the 3D mode sum's pattern (two 25.6 MB temporaries,
#: freed) and the minor page faults of those rounds.
CHILD = textwrap.dedent("""
    import resource, sys, torch
    torch.set_num_threads(1)
    from swimrl.runtime import retain_freed_memory
    applied = retain_freed_memory() if sys.argv[1] == "retain" else False
    a = torch.ones(10, 1000, 640)
    lo, hi = next([int(x, 16) for x in line.split()[0].split("-")]
                  for line in open("/proc/self/maps") if line.rstrip().endswith("[heap]"))
    in_heap = lo <= a.data_ptr() < hi
    del a
    def rounds(n):
        for _ in range(n):
            a = torch.ones(10, 1000, 640); b = a * 2.0; float(b[0, 0, 0]); del a, b
    rounds(1)
    f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    rounds(20)
    print(applied, in_heap, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
""")


def _child(mode: str) -> tuple[bool, bool, int]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    out = subprocess.run([sys.executable, "-c", CHILD, mode], capture_output=True, text=True,
                         env=env, check=True).stdout.split()
    return out[0] == "True", out[1] == "True", int(out[2])


@glibc
def test_buffers_come_from_the_heap_and_stay():
    applied, in_heap, faults = _child("retain")
    assert applied and in_heap
    # a fresh mapping of the two buffers is 2 x 6250 pages a round; retained, measured
    # 0-1600 pages a round
    assert faults < 20 * 2500, faults


@glibc
def test_glibc_default_maps_a_large_buffer():
    """Without it the first 25.6 MB buffer is a mapping of its own (the case it fixes)."""
    applied, in_heap, _ = _child("default")
    assert not applied and not in_heap


def test_user_setting_stands(monkeypatch):
    monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", "131072")
    retain_freed_memory.cache_clear()
    try:
        assert retain_freed_memory() is False
    finally:
        retain_freed_memory.cache_clear()
