"""The fused kernel's build is keyed by its source: two source trees on one machine keep
their own builds (no cross rebuild), and a build says so in one line on stderr. A lock file left
by a killed process never makes a later run wait forever."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from swimrl.physics.kernels import SOURCE, extension_name, remove_stale_lock

#: A stand-in for the kernel source: as quick to compile as a C++ extension can be.
TINY_SOURCE = """#include <pybind11/pybind11.h>
int answer() {{ return {value}; }}
PYBIND11_MODULE(TORCH_EXTENSION_NAME, m) {{ m.def("answer", &answer); }}
"""

BUILD = """
import json, logging, sys
from pathlib import Path
logging.basicConfig(level=logging.INFO, stream=sys.stderr)
from swimrl.physics.kernels import build_cpu_kernel
print(json.dumps({"answer": build_cpu_kernel(Path(sys.argv[1])).answer()}))
"""


def test_name_follows_the_source_content_not_its_path(tmp_path):
    copy = tmp_path / "elsewhere" / SOURCE.name
    copy.parent.mkdir()
    copy.write_bytes(SOURCE.read_bytes())
    assert extension_name(copy) == extension_name(SOURCE)
    copy.write_bytes(SOURCE.read_bytes() + b"\n// changed\n")
    assert extension_name(copy) != extension_name(SOURCE)
    assert extension_name(SOURCE).startswith("swimrl_heun_cpu_")


@pytest.mark.slow  # two C++ extension builds in subprocesses (~20-35 s)
def test_two_source_trees_do_not_rebuild_each_other(tmp_path, monkeypatch):
    """Also: torch's build waits while ``<build dir>/lock`` exists, and a process killed
    during it leaves the file behind. An old lock before a build is removed (with a warning);
    any lock beside a finished build is ignored, since the build is imported directly. A
    hang would show as a TimeoutExpired failure."""
    from torch.utils.cpp_extension import _get_build_directory

    monkeypatch.setenv("TORCH_EXTENSIONS_DIR", str(tmp_path / "ext"))
    env = {**os.environ, "TORCH_EXTENSIONS_DIR": str(tmp_path / "ext")}
    trees = {}
    for value in (1, 2):
        src = tmp_path / f"tree{value}" / "heun_cpu.cpp"
        src.parent.mkdir()
        src.write_text(TINY_SOURCE.format(value=value))
        trees[value] = src

    def build(value: int) -> str:
        out = subprocess.run([sys.executable, "-c", BUILD, str(trees[value])], env=env,
                             capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr[-3000:]
        assert json.loads(out.stdout.strip().splitlines()[-1]) == {"answer": value}
        return out.stderr

    def built(value: int) -> dict[str, int]:
        pattern = f"{extension_name(trees[value])}*.so"
        return {str(p): p.stat().st_mtime_ns for p in (tmp_path / "ext").rglob(pattern)}

    lock = Path(_get_build_directory(extension_name(trees[1]), verbose=False)) / "lock"
    lock.touch()
    old = time.time() - 3600
    os.utime(lock, (old, old))  # left by a process killed an hour ago
    log = build(1)
    assert log.count("building the fused kernel (once, ~30 s)") == 1
    assert "removing the stale build lock" in log and not lock.exists()
    first = built(1)
    assert first
    assert "building the fused kernel" in build(2)
    # tree 1 again, after tree 2 was built: its build is loaded as it is, past a fresh lock
    # (as left by a process killed while loading), which is not ours to remove
    lock.touch()
    log = build(1)
    assert "building the fused kernel" not in log and "stale" not in log and lock.exists()
    assert built(1) == first
    assert "building the fused kernel" not in build(2)


def test_remove_stale_lock_keeps_a_young_lock(tmp_path):
    lock = tmp_path / "lock"
    assert not remove_stale_lock(lock)  # none there
    lock.touch()
    assert not remove_stale_lock(lock, max_age_s=600) and lock.exists()
    old = time.time() - 601
    os.utime(lock, (old, old))
    assert remove_stale_lock(lock, max_age_s=600) and not lock.exists()

