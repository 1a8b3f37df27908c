"""The examples in examples/ run at their small size (SWIMRL_EXAMPLE_SMALL=1) and write their
figure, ``<name>.png``, into SWIMRL_EXAMPLE_OUT."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
SCRIPTS = sorted(EXAMPLES.glob("*.py"))


def test_there_are_examples():
    assert {p.stem for p in SCRIPTS} >= {"env_by_hand", "shipped_policy", "dns_store",
                                         "tiny_training"}


@pytest.mark.parametrize("script", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_example_runs_and_writes_its_figure(script, tmp_path):
    env = {**os.environ, "SWIMRL_EXAMPLE_SMALL": "1", "SWIMRL_EXAMPLE_OUT": str(tmp_path),
           "MPLBACKEND": "Agg"}
    env.setdefault("OMP_NUM_THREADS", "1")
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-4000:]
    figure = tmp_path / f"{script.stem}.png"
    assert figure.is_file() and figure.stat().st_size > 1000, proc.stdout[-2000:]
