"""Smart-vs-baselines summary (Fig. smartPerformance(a)) from comparison.json records."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from swimrl.analysis.performance import load, markdown, summarise
from swimrl.cli.performance import main
from swimrl.evaluation.statistics import paired_ratio


def _row(label, per):
    per = np.asarray(per, dtype=float)
    return {"label": label, "R_hat_mean": per.mean(), "R_hat_sem": per.std(ddof=1) / math.sqrt(
        per.size), "R_hat_std": per.std(ddof=1), "per_flow": per.tolist()}


def _record(ku, sto, naive, smart):
    rows = [_row("sto", sto), _row("naive(+0.98)", naive)]
    rows += [_row(f"policy(s{i})", s) for i, s in enumerate(smart)]
    return {"rows": rows, "n_flows": len(sto), "n_swimmers": 5, "seed": 0,
            "config": {"flow": {"name": "stochastic", "kubo": ku}}}


def test_paired_ratio_is_exact_for_proportional_flows():
    b = np.array([0.4, 0.5, 0.6])
    assert paired_ratio(1.3 * b, b) == pytest.approx((1.3, 0.0), abs=1e-12)
    r, sem = paired_ratio(np.array([1.0, 2.0, 2.0]), np.array([1.0, 1.0, 2.0]))
    assert r == pytest.approx(5 / 4)
    resid = np.array([1.0, 2.0, 2.0]) - r * np.array([1.0, 1.0, 2.0])
    assert sem == pytest.approx(resid.std(ddof=1) / math.sqrt(3) / (4 / 3))


def test_summary_table_and_plot(tmp_path):
    recs = {1e7: _record(1e7, [0.4, 0.5], [0.6, 0.7], [[0.9, 1.0], [0.8, 0.9]]),
            0.1: _record(0.1, [0.9, 1.0], [0.3, 0.4], [[0.9, 1.0], [0.95, 0.95]])}
    for ku, rec in recs.items():
        d = tmp_path / f"ku{ku:g}"
        d.mkdir()
        (d / "comparison.json").write_text(json.dumps(rec))
    s = [summarise(r) for r in load([tmp_path])]
    assert [x["kubo"] for x in s] == [0.1, 1e7]  # sorted by Ku
    assert s[1]["best_baseline"] == "naive" and s[0]["best_baseline"] == "STO"
    assert s[1]["vs_best_mean"] == pytest.approx(np.mean([1.9 / 1.3, 1.7 / 1.3]))
    assert s[0]["vs_sto_mean"] == pytest.approx(np.mean([1.0, 1.9 / 1.9]))
    assert s[1]["smart_seed_std"] == pytest.approx(np.std([0.95, 0.85], ddof=1))
    table = markdown(s)
    assert "| 1e+07 |" in table and "| 0.1 |" in table and "naive |" in table
    png = tmp_path / "perf.png"
    md = tmp_path / "out" / "table.md"
    assert main([str(tmp_path), "--out", str(png), "--md", str(md)]) == 0
    assert png.stat().st_size > 1000 and md.read_text().strip() == table.strip()
    assert len(summarise(recs[0.1], exclude=("s1",))["seeds"]) == 1
    with pytest.raises(FileNotFoundError, match="no comparison.json"):
        load([tmp_path / "empty_dir_that_does_not_exist"])
