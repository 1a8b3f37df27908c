"""The fused kernel's build is keyed by its source: two source trees on one machine keep
their own builds (no cross rebuild), and a build says so in one log line."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from swimrl.physics.kernels import SOURCE, extension_name

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


def test_two_source_trees_do_not_rebuild_each_other(tmp_path):
    env = {**os.environ, "TORCH_EXTENSIONS_DIR": str(tmp_path / "ext")}
    trees = {}
    for value in (1, 2):
        src = tmp_path / f"tree{value}" / "heun_cpu.cpp"
        src.parent.mkdir()
        src.write_text(TINY_SOURCE.format(value=value))
        trees[value] = src

    def build(value: int) -> str:
        out = subprocess.run([sys.executable, "-c", BUILD, str(trees[value])], env=env,
                             capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr[-3000:]
        assert json.loads(out.stdout.strip().splitlines()[-1]) == {"answer": value}
        return out.stderr

    def built(value: int) -> dict[str, int]:
        pattern = f"{extension_name(trees[value])}*.so"
        return {str(p): p.stat().st_mtime_ns for p in (tmp_path / "ext").rglob(pattern)}

    assert build(1).count("building the fused kernel (once, ~30 s)") == 1
    first = built(1)
    assert first
    assert "building the fused kernel" in build(2)
    # tree 1 again, after tree 2 was built: its build is loaded as it is
    assert "building the fused kernel" not in build(1)
    assert built(1) == first
    assert "building the fused kernel" not in build(2)
