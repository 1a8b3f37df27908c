"""Figures beyond the paper (swimrl.paper.beyond_target, beyond_paths, beyond_energy): the
Pareto front, and the figures drawn from tiny ``swimrl-compare`` records (``task=target`` at
two distances; the displacement task with energies), or reported pending without them."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace

import numpy as np
import pytest

from swimrl.config import compare_config
from swimrl.evaluation.compare import compare
from swimrl.paper import beyond_energy, beyond_paths, beyond_target
from swimrl.paper.config import figures_config
from swimrl.runs.policy_files import PRETRAINED_ROOT

from .conftest import SMALL

SIZE = ["eval.n_flows=2", "eval.n_swimmers=6", "eval.flows_per_batch=2",
        "compare.shared_flows=true", "compare.naive_shape_factors=[0.98,-0.98]"]


def test_pareto_front():
    r = np.array([0.5, 0.6, 0.4, 0.6, 0.3])
    e = np.array([1.0, 1.5, 1.2, 1.4, 0.9])
    # 2 is dominated by 0, 1 by 3 (same R_hat, more energy)
    assert beyond_energy.pareto_front(r, e).tolist() == [4, 0, 3]


def test_labels_of_rows():
    assert beyond_target.row_kind("sto") == "target-STO"
    assert beyond_target.row_kind("naive(-0.98)") == "naive"
    assert beyond_target.row_kind("policy(pretrained/ku10)") == "displacement policy"
    assert beyond_target.row_kind("policy(outputs/beyond/target_ku10_seed1)") == "smart (target)"
    warm = "policy(docs/results/beyond/runs/target_ku10_warm_seed0/policy.pt)"
    assert beyond_target.row_kind(warm) == "smart (warm start)"
    assert beyond_energy.energy_weight("policy(docs/results/beyond/energy_ku10_w0.3_seed2)") == 0.3
    protocol = "policy(docs/results/paper_runs/ku10_seed0/policy.pt)"
    assert beyond_energy.energy_weight(protocol) == 0.0
    assert beyond_energy.energy_weight("naive(+0.98)") is None


@pytest.fixture
def figures(compose_cfg, tmp_path):
    cfg = figures_config(compose_cfg(["threads=1", "progress=false", "flow.n_grid=64",
                                      "flow.spacing=0.1", "episode.duration=1.0",
                                      "figures.n_swimmers=4"], name="figures"))
    return replace(cfg, out=tmp_path / "fig", beyond=tmp_path / "beyond",
                   cache=tmp_path / "cache")


def test_pending_without_records(figures):
    assert "pending" in beyond_target.build_beyond_target(figures)
    assert "pending" in beyond_energy.build_beyond_energy(figures)


def _compare(compose_cfg, out, over):
    cfg = compare_config(compose_cfg([*SMALL, *SIZE, *over], name="compare"))
    out.mkdir(parents=True)
    (out / "comparison.json").write_text(json.dumps(compare(cfg)))


def test_figures_from_comparison_records(compose_cfg, figures, tmp_path):
    smart = tmp_path / "beyond" / "target_ku10_seed0"
    energy = tmp_path / "beyond" / "energy_ku10_w0.3_seed0"
    shutil.copytree(PRETRAINED_ROOT / "ku10", smart)
    shutil.copytree(PRETRAINED_ROOT / "ku10", energy)
    for d in (1.0, 2.0):
        _compare(compose_cfg, tmp_path / "beyond" / "target" / f"ku10_D{d:g}",
                 ["flow.kubo=10", "task=target", f"task.distance={d}",
                  "task.arrival_radius=0.5", "episode.duration=5.0",
                  "compare.strategies=[sto,naive,policy]",
                  f"compare.policies=[pretrained/ku10,{smart}]"])
    _compare(compose_cfg, tmp_path / "beyond" / "energy" / "ku10",
             ["flow.kubo=10", "compare.strategies=[sto,naive,policy]",
              f"compare.policies=[pretrained/ku10,{energy}]"])
    out = beyond_target.build_beyond_target(figures)
    assert (tmp_path / "fig" / "beyondTarget.png").is_file()
    summary = out["summary"][10.0]
    assert set(summary) == {"1.0", "2.0"}
    assert set(summary["1.0"]) == {"target-STO", "best naive", "displacement policy",
                                   "smart (target)"}
    rec = json.loads((tmp_path / "beyond" / "target" / "ku10_D1" / "comparison.json").read_text())
    naive = max((r for r in rec["rows"] if r["label"].startswith("naive")),
                key=lambda r: r["arrival_mean"])
    assert summary["1.0"]["best naive"]["arrival"] == naive["arrival_mean"]
    assert "| Ku = 10 | 1 | target-STO |" in (tmp_path / "fig" / "beyondTarget.md").read_text()
    out = beyond_energy.build_beyond_energy(figures)
    assert (tmp_path / "fig" / "beyondEnergy.png").is_file()
    assert out["ku10"]["front"]  # at least one non-dominated row
    assert (tmp_path / "fig" / "beyondEnergyMaps.png").is_file()
    assert out["maps"] == {"ku10_w0": "pretrained/ku10", "ku10_w0.3": str(energy)}
    out = beyond_paths.build_beyond_target_paths(figures)
    assert (tmp_path / "fig" / "beyondTargetPaths.png").is_file()
    assert out["ku10"]["distance"] == 2.0  # the middle of D = 1, 2
    assert set(out["ku10"]["actors"]) == {"target-STO", "best naive", "displacement policy",
                                          "smart (target)"}
    cache = next((tmp_path / "cache").glob("target_paths_ku10_D2-*.npz"))
    a = np.load(cache)
    xy = beyond_paths.target_frame(a["position"][0], a["target"][0])
    gap = np.linalg.norm(xy[..., -1, :] - [2.0, 0.0], axis=-1)
    arrived = np.isfinite(a["arrival_time"][0])
    # an arrived swimmer ends within the arrival radius of its target and stops there
    assert np.all(gap[arrived] <= 0.5 + 1e-5) and np.all(gap[~arrived] > 0.5 - 1e-5)
    assert list(out["ku10"]["arrived"].values()) == arrived.sum(-1).tolist()


def test_target_frame():
    """Start at the origin, target on the positive x axis, lengths kept."""
    rng = np.random.default_rng(1)
    start, target = rng.normal(size=(5, 2)), rng.normal(size=(5, 2)) * 10
    path = start[:, None, :] + rng.normal(size=(5, 7, 2)).cumsum(1)
    path[:, 0] = start
    path[:, -1] = target
    xy = beyond_paths.target_frame(path, target)
    d = np.linalg.norm(target - start, axis=-1)
    assert np.allclose(xy[:, 0], 0.0)
    assert np.allclose(xy[:, -1], np.stack([d, np.zeros(5)], -1))
    assert np.allclose(np.linalg.norm(xy, axis=-1), np.linalg.norm(path - start[:, None], axis=-1))


def test_sto_amplitudes_of_rows():
    assert beyond_energy.sto_amplitudes("sto", 0.98) == (0.98, 0.98)
    assert beyond_energy.sto_amplitudes("sto(+0.90,-0.20)", 0.98) == (0.9, 0.2)
    assert beyond_energy.sto_amplitudes("naive(+0.98)", 0.98) is None


def test_energy_baselines_join_the_energy_record_on_the_same_flows(tmp_path):
    """``energy_baselines/ku*/comparison.json`` adds its rows to ``energy/ku*``'s when seed,
    sizes and flow keys are equal, and is refused (one line naming the file) otherwise."""
    def record(path, labels, seed=0):
        path.mkdir(parents=True)
        rows = [{"label": x, "R_hat_mean": 0.5, "energy_mean": 1.0} for x in labels]
        rec = {"rows": rows, "seed": seed, "n_flows": 20, "n_swimmers": 200,
               "config": {"flow": {"name": "stochastic", "kubo": 10}}}
        (path / "comparison.json").write_text(json.dumps(rec))

    record(tmp_path / "energy" / "ku10", ["sto", "naive(+0.98)"])
    record(tmp_path / "energy_baselines" / "ku10", ["sto(+0.98,-0.98)", "sto(+0.60,-0.00)"])
    rows = [r["label"] for r in beyond_energy.read_energy(tmp_path)[10.0]["rows"]]
    assert rows == ["sto", "naive(+0.98)", "sto(+0.98,-0.98)", "sto(+0.60,-0.00)"]
    shutil.rmtree(tmp_path / "energy_baselines")
    record(tmp_path / "energy_baselines" / "ku10", ["sto(+0.60,-0.00)"], seed=1)
    with pytest.raises(ValueError, match="energy_baselines/ku10/comparison.json: not the flows"):
        beyond_energy.read_energy(tmp_path)


def _target_row(label, arrived, half, with_cdf=True):
    row = {"label": label, "arrival_mean": arrived, "arrival_sem": 0.01,
           "arrival_time_median": 3.0, "n_arrived": 10}
    if with_cdf:
        t = np.linspace(0.5, 10.0, 20)
        row.update(arrival_cdf_t=t.tolist(),
                   arrival_cdf_mean=(arrived * t / 10.0).tolist(),
                   arrival_cdf_sem=[0.01] * 20, arrival_time_half=half,
                   arrival_time_rmst_mean=7.5, arrival_time_rmst_sem=0.2,
                   arrival_time_quartile=None)
    return row


def _target_record(path, d, with_cdf):
    path.mkdir(parents=True)
    rows = [_target_row("sto", 0.8, 6.2, with_cdf), _target_row("naive(+0.98)", 0.01, None,
                                                                 with_cdf),
            _target_row("naive(-0.98)", 0.02, None, with_cdf),
            _target_row("policy(pretrained/ku10)", 0.3, None, with_cdf),
            _target_row("policy(runs/target_ku10_seed0)", 0.9, 5.0, with_cdf),
            _target_row("policy(runs/target_ku10_seed1)", 0.4, None, with_cdf)]
    rec = {"task": "target", "target_distance": d, "arrival_radius": 1.0, "n_flows": 4,
           "n_swimmers": 10, "seed": 0, "config": {"episode": {"duration": 10.0}}, "rows": rows}
    (path / "comparison.json").write_text(json.dumps(rec))


@pytest.mark.parametrize("with_cdf", [True, False])
def test_target_figure_draws_the_arrival_time_cdf_where_recorded(figures, tmp_path, with_cdf):
    """Records with the arrival-time distribution: the CDF at D = 20 below, and the half and
    restricted mean times in the table; records without: the median of the arrived, ``—``."""
    for d in (10.0, 20.0, 40.0):
        _target_record(tmp_path / "beyond" / "target" / f"ku10_D{d:g}", d, with_cdf)
    out = beyond_target.build_beyond_target(figures)
    assert (tmp_path / "fig" / "beyondTarget.png").is_file()
    assert out["cdf_distance"] == {10.0: 20.0 if with_cdf else None}
    table = (tmp_path / "fig" / "beyondTarget.md").read_text()
    assert "time by which half arrived (τ_K)" in table
    assert "median arrival time of the arrived (τ_K)" in table
    smart = out["summary"][10.0]["20.0"]["smart (target)"]
    if with_cdf:
        assert "| Ku = 10 | 20 | target-STO | 0.800 ± 0.010 | 6.2 | 7.5 ± 0.2 | 3.0 |" in table
        assert "| best naive | 0.020 ± 0.010 | > T | 7.5 ± 0.2 |" in table
        assert "| smart (target) | 0.650 ± 0.354 | 5.0 / > T (per seed) | 7.5 ± 0.0 |" in table
        assert [len(v["cdf"]) for v in smart["values"]] == [20, 20]
    else:
        assert "| Ku = 10 | 20 | target-STO | 0.800 ± 0.010 | — | — | 3.0 |" in table
        assert "| smart (target) | 0.650 ± 0.354 | — | — | 3.0 |" in table
