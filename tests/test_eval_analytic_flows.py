"""``swimrl-eval`` on every analytic flow writes its ``metrics.json``: a flow without a
statistic (a linear flow has no ``u_rms``) records it as null with the reason, it does not
turn a valid run into an error."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
ANALYTIC = ["linear", "taylor_green", "abc"]


def test_every_analytic_flow_writes_its_metrics(tmp_path):
    cases = [["swimrl.cli.eval", [f"flow={flow}", "threads=1", "eval.progress=false",
                                  "eval.n_flows=1", "eval.n_swimmers=4", "episode.duration=2",
                                  f"hydra.run.dir={tmp_path / flow}"]] for flow in ANALYTIC]
    proc = subprocess.run([sys.executable, "-m", "tests.cli_cases"], input=json.dumps(cases),
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for flow, result in zip(ANALYTIC, json.loads(proc.stdout), strict=True):
        assert result["rc"] == 0, f"flow={flow}: {result['stderr'][-2000:]}"
        metrics = json.loads((tmp_path / flow / "metrics.json").read_text())
        stats = metrics["flow_stats"]
        assert stats["tau_K"] > 0
        if flow == "linear":
            assert stats["u_rms"] is None and "u_rms" in stats["undefined"]
        else:
            assert stats["u_rms"] > 0 and "undefined" not in stats


@pytest.mark.parametrize("stats, expected", [
    ([{"u_rms": 1.0, "tau_K": 0.5}, {"u_rms": 3.0, "tau_K": 0.5}], 2.0),
    ([{"u_rms": None, "tau_K": 0.5}], None),
])
def test_mean_flow_stats_keeps_an_undefined_scale_null(stats, expected):
    from swimrl.evaluation.statistics import mean_flow_stats

    out = mean_flow_stats(stats, "test")
    assert out["u_rms"] == expected and out["tau_K"] == 0.5
    assert ("undefined" in out) == (expected is None)
