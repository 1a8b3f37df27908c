"""Record scripts under docs/results/ rerun on their committed records give their committed
summaries (so a change to a record's format cannot leave a script silently broken)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_energy_100flows_summary_is_reproduced_from_its_record():
    folder = ROOT / "docs" / "results" / "beyond" / "energy_100flows"
    out = subprocess.run([sys.executable, str(folder / "summarise.py")], capture_output=True,
                         text=True, check=True, cwd=ROOT).stdout
    assert json.loads(out) == json.loads((folder / "summary.json").read_text())


def test_signal_search_script_finds_the_signals_of_a_synthetic_policy(tmp_path):
    """referee_items/signal_search.py on a trajectories.npz whose Lambda depends on
    (n_theta, S_np) only: that pair ranks first, and the JSON groups records by Ku."""
    import numpy as np

    from swimrl.evaluation.trajectories import save_trajectories

    rng = np.random.default_rng(0)
    sig = rng.uniform(-1, 1, (4, 1, 20, 50, 5))  # (F, K, n, N, 5)
    lam = -0.98 * np.tanh(5 * sig[..., 1] * sig[..., 3])
    for s in (0, 1):
        save_trajectories({"signals": sig, "Lambda": lam}, tmp_path / f"r{s}.npz", ["policy"],
                          {"seed": s})
    script = ROOT / "docs" / "results" / "referee_items" / "signal_search.py"
    out = tmp_path / "out.json"
    subprocess.run([sys.executable, str(script), str(out), f"ku10_seed0={tmp_path / 'r0.npz'}",
                    f"ku10_seed1={tmp_path / 'r1.npz'}"], check=True, cwd=ROOT)
    rec = json.loads(out.read_text())
    ku = rec["by_ku"]["ku10"]
    assert ku["n_seeds"] == 2 and ku["ranked"]["2"][0] == "n_theta,S_np"
    assert ku["R2_mean"]["n_theta,S_np"] > 0.8 and abs(ku["R2_mean"]["n_r"]) < 0.05
    assert rec["records"]["ku10_seed0"]["n_decisions"] == 4 * 20 * 50
    # Lambda = -0.98 tanh(5 n_theta S_np): STO's sign wherever n_theta S_np != 0
    assert rec["records"]["ku10_seed0"]["sign_agreement_STO"] == 1.0


def test_optimal_escape_script_runs_at_a_tiny_size(tmp_path):
    """referee_items/optimal_escape.py (reproduction row 4) at a tiny size: one record per Ku,
    the best orientation at least the mean over orientations, fractions in [0, 1]."""
    script = ROOT / "docs" / "results" / "referee_items" / "optimal_escape.py"
    out = tmp_path / "oe.json"
    subprocess.run([sys.executable, str(script), str(out), "--kubo", "10", "--flows", "2",
                    "--starts", "2", "--orientations", "8", "--duration", "1"], check=True,
                   cwd=tmp_path)
    rec = json.loads(out.read_text())["by_ku"]["ku10"]
    for lam in ("-0.98", "+0.98"):
        assert rec["best"][lam]["1"]["mean"] >= rec["mean"][lam]["1"]["mean"] > 0
        assert 0 <= rec["vortex_fraction"][lam]["mean"] <= 1
        assert 0 <= rec["confined_fraction"][lam] <= 1
    assert 0 < rec["vortex_fraction_eulerian"] < 1
    assert (tmp_path / "oe.png").stat().st_size > 0


@pytest.mark.slow  # summarises the committed DNS-transfer records (~15 s)
def test_dns_transfer_summary_is_what_the_records_give():
    """three_seeds/dns_transfer/summarise.py on the committed records reproduces the committed
    summary.json and table.md (the numbers quoted in three_seeds/README.md)."""
    folder = ROOT / "docs" / "results" / "three_seeds" / "dns_transfer"
    script = str(folder / "summarise.py")
    out = subprocess.run([sys.executable, script], capture_output=True, text=True, check=True,
                         cwd=ROOT).stdout
    assert json.loads(out) == json.loads((folder / "summary.json").read_text())
    md = subprocess.run([sys.executable, script, "--md"], capture_output=True, text=True,
                        check=True, cwd=ROOT).stdout
    assert md == (folder / "table.md").read_text()


def test_three_seed_tables_are_what_the_records_give():
    """three_seeds/summarise.py on the committed fits, robustness and ablation (b) records prints
    tables whose every row (and per-seed noise line) is in three_seeds/README.md."""
    folder = ROOT / "docs" / "results" / "three_seeds"
    out = subprocess.run([sys.executable, str(folder / "summarise.py")], capture_output=True,
                         text=True, check=True, cwd=ROOT).stdout
    rows = [line for line in out.splitlines() if line.startswith(("|", "- seed"))]
    assert len(rows) >= 50 and not any("missing" in r for r in rows)
    page = set((folder / "README.md").read_text().splitlines())
    assert [r for r in rows if r not in page] == []


def test_three_d_tables_are_what_the_records_give():
    """three_d/summarise.py on the committed runs and comparisons prints tables whose every
    row is in three_d/README.md, one row per committed run."""
    folder = ROOT / "docs" / "results" / "three_d"
    out = subprocess.run([sys.executable, str(folder / "summarise.py")], capture_output=True,
                         text=True, check=True, cwd=ROOT).stdout
    rows = [line for line in out.splitlines() if line.startswith("|")]
    runs = [r for r in rows if r.startswith("| `ku")]
    assert len(runs) == len(list((folder / "runs").iterdir())) >= 6
    page = set((folder / "README.md").read_text().splitlines())
    assert [r for r in rows if r not in page] == []


def test_noisy_rule_script_runs_at_a_tiny_size(tmp_path):
    """learner_ablation/noisy_rule.py at a tiny size: one row per sigma, finite R_hat, and
    sigma = 0 is the plain rule (equal for two seeds of the noise)."""
    script = ROOT / "docs" / "results" / "learner_ablation" / "noisy_rule.py"
    out = tmp_path / "noisy.json"
    subprocess.run([sys.executable, str(script), str(out), "--sigmas", "0,0,0.5", "--flows",
                    "1", "--swimmers", "4", "--duration", "1"], check=True, cwd=tmp_path)
    rows = json.loads(out.read_text())["rows"]
    assert [r["sigma"] for r in rows] == [0, 0, 0.5]
    assert rows[0]["R_hat_mean"] == rows[1]["R_hat_mean"] > 0
    assert rows[2]["R_hat_mean"] != rows[0]["R_hat_mean"]


def test_pair_with_rule_reproduces_the_asymmetric_critic_test_table(tmp_path):
    """critic3d/pair_with_rule.py on the committed test-flow records gives the numbers of
    learner_ablation/cflow_test_seed0/README.md (× STO and policy − rule, per seed)."""
    import re

    results = ROOT / "docs" / "results"
    tests = results / "learner_ablation" / "cflow_test_seed0"
    out = tmp_path / "pair.json"
    subprocess.run([sys.executable, str(results / "critic3d" / "pair_with_rule.py"),
                    str(results / "optimised_rules" / "ku10_3d" / "test_seed0" / "comparison.json"),
                    "optimised(ku10_3d)",
                    *(str(tests / f"seed{s}" / "comparison.json") for s in range(3)),
                    "--json", str(out)], check=True, cwd=ROOT, capture_output=True)
    pairs = json.loads(out.read_text())
    table = (tests / "README.md").read_text()
    for s in range(3):
        row = re.search(rf"\| \[seed {s}\]\(seed{s}/comparison.md\) \| ([0-9.]+) ± [0-9.]+ \| "
                        rf"([0-9.]+) ± [0-9.]+ \| ([−+-][0-9.]+) ± ([0-9.]+) \|", table)
        label = f"policy(docs/results/learner_ablation/cflow_terms_std02_const_ku10_seed{s})"
        p = pairs["policies"][label]
        assert f"{p['R_hat']:.3f}" == row[1] and f"{p['ratio_to_sto'][0]:.3f}" == row[2]
        assert f"{p['minus_rule'][0]:+.3f}" == row[3].replace("−", "-")
        assert f"{p['minus_rule'][1]:.3f}" == row[4]
    assert f"{pairs['rule']['ratio_to_sto'][0]:.3f}" == "1.150"
