"""swimrl-table: swept keys as columns, metrics.json and comparison.json, CSV/Markdown."""

from __future__ import annotations

import csv
import io
import json

import pytest

from swimrl.analysis.table import build_rows, collect, swept_keys
from swimrl.cli.table import main


def _config(kubo, seed, signals=("n_r", "n_theta")):
    return {
        "flow": {"name": "stochastic", "kubo": kubo, "n_grid": 64},
        "signals": {"names": list(signals)},
        "seed": seed,
        "threads": seed + 1,  # runtime key: never a column
        "eval": {"progress": bool(seed)},
    }


def _metrics(path, kubo, seed, r_hat):
    path.mkdir(parents=True)
    m = {
        "strategy": "policy",
        "R_hat_mean": r_hat,
        "R_hat_sem": 0.01,
        "R_hat_std": 0.03,
        "n_flows": 9,
        "n_swimmers": 20,
        "training": {"episodes": 100.0},
        "config": _config(kubo, seed),
    }
    (path / "metrics.json").write_text(json.dumps(m))


@pytest.fixture
def sweep(tmp_path):
    root = tmp_path / "sweep"
    for i, (kubo, seed, r) in enumerate([(10, 0, 0.5), (10, 1, 0.7), (0.1, 0, 0.9), (0.1, 1, 1.1)]):
        _metrics(root / str(i), kubo, seed, r)
    (root / "0" / ".hydra").mkdir()
    return root


def test_swept_keys_are_the_columns(sweep):
    records = collect(sweep)
    assert len(records) == 4
    assert swept_keys(records) == ["flow.kubo", "seed"]
    keys, rows = build_rows(records)
    assert [(r["flow.kubo"], r["seed"]) for r in rows] == [(0.1, 0), (0.1, 1), (10, 0), (10, 1)]
    assert rows[0]["episodes"] == 100.0


def test_average_over_seeds(sweep):
    keys, rows = build_rows(collect(sweep), average=["seed"])
    assert keys == ["flow.kubo"]
    assert [(r["flow.kubo"], r["n_runs"]) for r in rows] == [(0.1, 2), (10, 2)]
    assert rows[0]["R_hat_mean"] == pytest.approx(1.0)
    assert rows[0]["R_hat_std_runs"] == pytest.approx(0.02**0.5)


def test_comparison_rows_and_cli_outputs(tmp_path, capsys):
    root = tmp_path / "cmp"
    for kubo in (1, 10):
        d = root / f"ku{kubo}"
        d.mkdir(parents=True)
        rows = [
            {
                "label": "naive(+0.98)",
                "R_hat_mean": 0.3,
                "R_hat_sem": 0.01,
                "R_hat_std": 0.02,
                "ratio_to_first": 1.0,
                "ratio_sem": 0.0,
            },
            {
                "label": "sto",
                "R_hat_mean": 0.6,
                "R_hat_sem": 0.01,
                "R_hat_std": 0.02,
                "ratio_to_first": 2.0,
                "ratio_sem": 0.1,
            },
        ]
        rec = {"rows": rows, "n_flows": 5, "n_swimmers": 7, "config": _config(kubo, 0)}
        (d / "comparison.json").write_text(json.dumps(rec))
    md, out_csv = tmp_path / "t.md", tmp_path / "t.csv"
    assert main([str(root), "--md", str(md), "--csv", str(out_csv)]) == 0
    text = md.read_text()
    assert capsys.readouterr().out == text
    assert text.splitlines()[0].startswith("| run | flow.kubo | strategy | R_hat (mean +- SEM)")
    assert "| ku10 | 10 | sto | 0.6000 +- 0.0100 | 0.0200 | 5 x 7 | 2.000 +- 0.100 |" in text
    table = list(csv.DictReader(io.StringIO(out_csv.read_text())))
    assert len(table) == 4 and {r["strategy"] for r in table} == {"naive(+0.98)", "sto"}
    assert float(table[-1]["ratio_to_first"]) == 2.0


def test_empty_dir_is_an_error(tmp_path):
    with pytest.raises(SystemExit):
        main([str(tmp_path)])
