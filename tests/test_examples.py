"""The examples in examples/ run at their small size (SWIMRL_EXAMPLE_SMALL=1) and write their
figure, ``<name>.png``, into SWIMRL_EXAMPLE_OUT. The quickstart has no small size of its own
(its five lines are the paper's episode): it runs here with the public names it imports
shrunk (:data:`SMALL_QUICKSTART`)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
SCRIPTS = sorted(EXAMPLES.glob("*.py"))


def test_there_are_examples():
    assert {p.stem for p in SCRIPTS} >= {"quickstart", "env_by_hand", "shipped_policy",
                                         "dns_store", "tiny_training"}


#: The quickstart at a tiny size: the names it imports from ``swimrl`` replaced by versions
#: with a short episode, a coarse grid, 1 flow x 8 swimmers and the eager kernel.
SMALL_QUICKSTART = """
import functools, runpy, sys
import swimrl

swimrl.EnvParams = functools.partial(swimrl.EnvParams, duration=2.0)
swimrl.StochasticSpec = functools.partial(swimrl.StochasticSpec, n_grid=64, spacing=0.1)


class Runtime(swimrl.Runtime):
    @classmethod
    def from_names(cls, device, dtype, threads, kernel="auto"):
        return swimrl.runtime.Runtime.from_names(device, dtype, threads, "eager")


class SwimmerEnv(swimrl.SwimmerEnv):
    @classmethod
    def build(cls, flow, params, runtime, n_flows, n_swimmers, seed, ic_blocks=1):
        return super().build(flow, params, runtime, 1, 8, seed, ic_blocks)


swimrl.Runtime, swimrl.SwimmerEnv = Runtime, SwimmerEnv
runpy.run_path(sys.argv[1], run_name="__main__")
"""


@pytest.mark.parametrize("script", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_example_runs_and_writes_its_figure(script, tmp_path):
    env = {**os.environ, "SWIMRL_EXAMPLE_SMALL": "1", "SWIMRL_EXAMPLE_OUT": str(tmp_path),
           "MPLBACKEND": "Agg"}
    env.setdefault("OMP_NUM_THREADS", "1")
    command = [sys.executable, str(script)]
    if script.stem == "quickstart":
        command = [sys.executable, "-c", SMALL_QUICKSTART, str(script)]
    proc = subprocess.run(command, cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-4000:]
    figure = tmp_path / f"{script.stem}.png"
    assert figure.is_file() and figure.stat().st_size > 1000, proc.stdout[-2000:]
