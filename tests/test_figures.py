"""Figures (swimrl.paper): policy-map binning, the S_nn statistic, each figure on a
tiny record, the cached evaluation records, and the builders' names."""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from swimrl.analysis.performance import load, summarise
from swimrl.analysis.policy_maps import binned_mean, snn_extremes
from swimrl.analysis.training_curves import PAPER_EPISODE_FRAMES
from swimrl.paper import (
    ablation,
    decision_stats,
    evaluations,
    mechanism,
    records,
    robustness,
    settings,
    stochastic,
    training,
)
from swimrl.paper.build import BUILDERS
from swimrl.paper.config import figures_config

RESULTS = Path(__file__).parent.parent / "docs" / "results" / "smart_ku_sweep"
RNG = np.random.default_rng(1)


def _record(n: int = 100, n_dec: int = 100):
    """A synthetic smart record: signals uniform, Lambda = tanh(3 n_theta S_np)."""
    sig = RNG.uniform(-1, 1, (n, n_dec, 5))
    return sig, np.tanh(3 * sig[..., 1] * sig[..., 3])


def test_binned_mean_recovers_a_known_policy():
    s1, s2 = RNG.uniform(-1, 1, (2, 200_000))
    lam = 0.5 * s1 - 0.3 * s2  # linear: the bin mean is the value at the bin centre
    mean, edges, counts = binned_mean(lam, [s1, s2], bins=10, ranges=[(-1, 1), (-1, 1)])
    c1, c2 = [(e[1:] + e[:-1]) / 2 for e in edges]
    truth = 0.5 * c1[:, None] - 0.3 * c2[None, :]
    assert mean.shape == (10, 10) and counts.sum() == 200_000
    assert np.abs(mean - truth).max() < 0.01
    m1, e1, _ = binned_mean(np.sign(s1), [s1], bins=4, ranges=[(-1, 1)])
    assert m1 == pytest.approx([-1, -1, 1, 1]) and len(e1) == 1
    sparse, _, _ = binned_mean(lam[:50], [s1[:50], s2[:50]], bins=20, min_count=3)
    assert np.isnan(sparse).any()


def test_snn_statistic_on_a_synthetic_record():
    snn = RNG.permutation(10_000).astype(float)
    lam = np.where(RNG.random(10_000) < 0.5, 0.5, -0.5)
    low = np.flatnonzero(snn < 100)
    lam[low[:82]], lam[low[82:]] = 0.9, -0.9  # 82 % of the lowest 1 % positive
    high = np.flatnonzero(snn >= 9900)
    lam[high] = -0.9
    st = snn_extremes(snn, lam, 0.01)
    assert st["n_low"] == 100 and st["p_pos_given_low"] == pytest.approx(0.82)
    assert st["p_neg_given_high"] == 1.0


def test_streamed_decision_statistics_equal_the_one_shot_ones():
    """DecisionStats fed decision by decision (ranges from the first) gives the maps of
    binned_mean on those ranges, the S_nn statistic of snn_extremes (up to one bin of the
    S_nn histogram), and the correlation of all decisions."""
    sig, lam = _record(400, 50)
    sig[..., 2] = RNG.normal(size=sig.shape[:2])
    lam = np.where(sig[..., 2] < -2, 0.9, lam)
    st = decision_stats.DecisionStats()
    for i in range(sig.shape[1]):
        st.add(sig[:, i], lam[:, i])
    a = st.arrays()
    mean, edges = decision_stats.map_mean(a, "n_theta")
    ref, _, _ = binned_mean(lam, [sig[..., 3], sig[..., 1]], bins=30,
                            ranges=[(e[0], e[-1]) for e in edges], min_count=5)
    assert np.allclose(mean, ref, equal_nan=True) and np.isfinite(mean).sum() > 500
    assert edges[1][0] == -1 and edges[0][-1] == -edges[0][0]
    got, want = decision_stats.snn_statistic(a), snn_extremes(sig[..., 2], lam)
    assert got["n"] == want["n"] == lam.size
    assert abs(got["n_low"] - want["n_low"]) <= 3 and abs(got["n_high"] - want["n_high"]) <= 3
    assert got["p_pos_given_low"] == pytest.approx(want["p_pos_given_low"], abs=0.02)
    assert got["p_neg_given_high"] == pytest.approx(want["p_neg_given_high"], abs=0.02)
    assert decision_stats.correlation(a) == pytest.approx(
        np.corrcoef((sig[..., 1] * sig[..., 3]).ravel(), lam.ravel())[0, 1])
    assert decision_stats.map_correlation(a, a, "omega") == pytest.approx(1.0)


def test_figure_functions_on_tiny_records(tmp_path):
    sig, lam = _record()
    n_dec = sig.shape[1]
    traj = np.cumsum(RNG.normal(0, 0.1, (3, 2, n_dec + 1, 2)), axis=2)
    stats = decision_stats.decision_stats(sig, lam)
    out = mechanism.fig_ku01(traj, stats, sig[:2], np.sign(sig[:2, :, 1]), tmp_path / "a.png")
    assert out["corr_smart"] > 0.8 and (tmp_path / "a.png").stat().st_size > 0
    assert out["corr_smart"] == pytest.approx(
        np.corrcoef((sig[..., 1] * sig[..., 3]).ravel(), lam.ravel())[0, 1])
    ku_inf = mechanism.fig_ku_inf(stats, tmp_path / "b.png")
    assert ku_inf["snn"]["n"] == lam.size and ku_inf["b"].shape == (30, 30)
    pattern = mechanism.fig_ku_pattern({0.1: stats, 10.0: decision_stats.decision_stats(sig, -lam)},
                                       tmp_path / "c.png")
    top = pattern[(0.1, "n_theta")]
    assert np.nanmean(top[-5:, -5:]) > 0.5 and np.nanmean(top[:5, -5:]) < -0.5  # S_np x n_theta
    vort = RNG.normal(size=(8, 8))
    two = {"a": traj[0, 0] + 1, "b": traj[1, 0] + 1}
    sw = stochastic.fig_swimmer(vort, 2.0, two, tmp_path / "d.png")
    assert sw["path_length"]["a"] > 0 and sw["extent"][1] - sw["extent"][0] >= 2.0
    summaries = [summarise(r) for r in load([RESULTS])]
    finals = {k: traj[:, :, -1] for k in (0.1, 1.0)}
    perf = stochastic.fig_smart_performance(summaries, finals, tmp_path / "e.png")
    assert perf["kubo"] == [0.1, 1.0, 10.0, 1e7] and perf["STO"][0] > perf["naive"][0]
    assert perf["spread"][1.0] == pytest.approx(np.linalg.norm(finals[1.0], axis=-1).mean(1))
    frames = np.arange(5.0) * 1e6
    curves = {"ku10_seed0": {"frames": frames, "eval/R_hat": np.r_[0.3, np.nan, 0.5, 0.6, 0.62]},
              "ku1e7_seed0": {"frames": frames, "eval/R_hat": np.r_[0.4, 0.5, 0.6, 0.7, 0.71],
                              "eval/R_hat_sem": np.full(5, 0.01)}}
    assert training.fig_training_curves(curves, tmp_path / "f.png") == {
        "ku10_seed0": 0.62, "ku1e7_seed0": 0.71}
    assert PAPER_EPISODE_FRAMES == 20000
    r = {"smart": np.array([1.2, 1.0]), "naive": np.array([0.5, 0.5]), "STO": np.array([1, 1.0])}
    sweep = robustness.fig_sweep(np.array([0.0, 1e-2]), r, {k: 0 * v for k, v in r.items()},
                                 "x", tmp_path / "g.png", ratio=(r["smart"], np.full(2, 0.01)))
    assert sweep["ratio"] == pytest.approx([1.2, 1.0]) and sweep["ratio_sem"] == [0.01, 0.01]


def test_ku_record_is_cached_and_consistent(compose_cfg, tmp_path):
    cfg = replace(figures_config(compose_cfg(
        ["figures.n_flows=2", "figures.n_swimmers=3", "figures.n_traj=2", "progress=false",
         "episode.duration=1.0", "flow.n_grid=64", "flow.spacing=0.1"], name="figures")),
        out=tmp_path / "fig", cache=tmp_path / "cache")
    a = evaluations.ku_record(cfg, 10.0)
    assert a["final"].shape == (3, 6, 2) and a["traj"].shape == (3, 2, 11, 2)
    assert a["sto_signals"].shape == (4, 10, 5) and a["sto_Lambda"].shape == (4, 10)
    assert np.allclose(a["per_flow"], a["R_hat"].reshape(3, 2, 3).mean(-1))
    assert np.allclose(a["traj"][:, :, -1], a["final"][:, :2], atol=1e-5)
    ref = 0.707 * 1.0 * 0.5  # v_s T in flow units (tau_K = 0.5 l_f / u_rms)
    assert np.linalg.norm(a["final"], axis=-1) / ref == pytest.approx(a["R_hat"], rel=1e-3)
    assert len(list((tmp_path / "cache").glob("ku_ku10-*.npz"))) == 1
    b = evaluations.ku_record(cfg, 10.0)
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert math.isclose(float(a["time"][-1]), 1.0)


def test_videos_on_a_tiny_record(tmp_path):
    from swimrl.paper.videos import video_cloud, video_trajectories

    steps = RNG.normal(0, 0.2, (3, 4, 3, 2))
    rec = {"cloud": np.cumsum(steps, axis=2), "traj_abs": 5 + np.cumsum(steps, axis=2),
           "vorticity": RNG.normal(size=(3, 8, 8)), "box": np.asarray(4.0),
           "time": np.arange(21) * 0.1}
    cloud = video_cloud(rec, 10.0, tmp_path / "c.mp4", fps=2)
    assert cloud["frames"] == 3 and (tmp_path / "c.mp4").stat().st_size > 1000
    assert cloud["mean_distance"] == pytest.approx(np.linalg.norm(rec["cloud"][:, :, -1],
                                                                  axis=-1).mean(1))
    traj = video_trajectories(rec, 10.0, tmp_path / "t.mp4", fps=2)
    assert traj["frames"] == 3 and traj["extent"][0] <= rec["traj_abs"][..., 0].min()
    # with the shape factors: head dots coloured by Lambda, the cloud's read-out, stills
    rec["traj_lambda"] = RNG.uniform(-0.98, 0.98, (3, 4, 3))
    rec["cloud_lambda"] = RNG.uniform(-0.98, 0.98, (3, 4, 3))
    video_cloud(rec, 10.0, tmp_path / "c2.mp4", fps=2, still=tmp_path / "s" / "c2.png")
    video_trajectories(rec, 10.0, tmp_path / "t2.mp4", fps=2, still=tmp_path / "s" / "t2.png")
    assert (tmp_path / "s" / "c2.png").stat().st_size > 1000
    assert (tmp_path / "s" / "t2.png").stat().st_size > 1000


def test_frame_lambda_holds_the_shape_from_each_frame_on():
    from swimrl.paper.evaluations import FRAME_EVERY, frame_lambda

    n = 2 * FRAME_EVERY
    lam = np.arange(n, dtype=float).reshape(1, 1, 1, n) * np.ones((2, 3, 4, 1))
    out = frame_lambda(lam)
    assert out.shape == (3, 2, 4, 3)
    assert out[0, 0, 0].tolist() == [0, FRAME_EVERY, n - 1]


def test_minimal_model_figure_reads_fits_and_draws_both_panels(tmp_path):
    """ablation (b), (c): fits read per Ku, the minimal model named by its coefficients (an
    actor the evaluation understands), the figure's returned data."""
    for kubo, c1 in ((0.1, 1.5), (1e7, 0.4)):
        d = tmp_path / "fits" / f"ku{kubo:g}"
        d.mkdir(parents=True)
        (d / "fit.json").write_text(json.dumps({
            "coefficients": {"c1": c1, "c2": 0.2, "c3": 0.1, "c4": -0.05},
            "stderr": dict.fromkeys(("c1", "c2", "c3", "c4"), 0.01),
            "config": {"flow": {"kubo": kubo}, "eval": {"n_flows": 8}}}))
    fits = ablation.read_fits(tmp_path / "fits")
    assert list(fits) == [0.1, 1e7]
    name = ablation.minimal_name(fits[1e7])
    assert name == "minimal(0.4,0.2,0.1,-0.05)"
    spec = evaluations.actor(name, None)
    assert spec.name == "minimal" and spec.coeffs == (0.4, 0.2, 0.1, -0.05)
    kus = np.array(list(fits))
    r = {"smart": np.array([0.9, 0.7]), "minimal": np.array([0.88, 0.6]),
         "STO": np.array([0.93, 0.48])}
    coeffs = {k: np.array([f["coefficients"][k] for f in fits.values()])
              for k in ("c1", "c2", "c3", "c4")}
    out = ablation.fig_ablation(kus, r, {k: 0 * v for k, v in r.items()}, coeffs,
                               {k: 0 * v for k, v in coeffs.items()}, tmp_path / "m.png")
    assert out["kubo"] == [0.1, 1e7] and out["c1"] == [1.5, 0.4] and out["minimal"][1] == 0.6
    assert "ablation" not in out  # (a) pending without records
    assert (tmp_path / "m.png").stat().st_size > 1000


def _ablation_run(root, signals, seed, smart, sto, frames=1000, kubo=10.0, curve=(0.3, 0.5),
                  evals=None, name=None):
    """A run directory as `swimrl-train train.compare_baselines=true` writes it."""
    d = root / (name or f"{'_'.join(signals)}_seed{seed}")
    d.mkdir(parents=True)
    cfg = {"signals": {"names": list(signals)}, "seed": seed, "flow": {"kubo": kubo},
           "train": {"total_frames": frames}}
    per_flow = [smart - 0.01, smart + 0.01]
    (d / "metrics.json").write_text(json.dumps({"config": cfg, "per_flow": per_flow}))
    rows = [{"label": "sto", "R_hat_mean": sto, "ratio_to_first": 1.0, "ratio_sem": 0.0},
            {"label": "naive(+0.98)", "R_hat_mean": 0.3, "ratio_to_first": 0.3 / sto,
             "ratio_sem": 0.01},
            {"label": f"policy({d})", "R_hat_mean": smart, "ratio_to_first": smart / sto,
             "ratio_sem": 0.01, "per_flow": per_flow}]
    (d / "comparison.json").write_text(json.dumps({"rows": rows, "config": cfg, "n_flows": 2,
                                                   "n_swimmers": 4}))
    evals = evals if evals is not None else ((0, curve[0]), (frames, curve[1]))
    lines = [f"{f},{y:g}," for f, y in evals] + ["500,,0.4"]
    (d / "curves.csv").write_text("frames,eval/R_hat,train/R_hat\n" + "\n".join(lines) + "\n")
    return d


def test_signal_ablation_records_summary_and_panel(tmp_path):
    """ablation (a): runs read from their records, grouped per signal set in the paper's order
    (whatever order the config lists the signals in), mean and std over seeds of the paired
    ratio; curves averaged over the evaluation frames every seed has; one budget, Ku and
    held-out size for all runs, one run per set and seed, a comparison that is its run's,
    or a one-line refusal."""
    from swimrl.analysis import signal_ablation as sa

    root = tmp_path / "ablation"
    _ablation_run(root, ("omega", "S_np", "S_nn", "n_theta", "n_r"), 0, 0.65, 0.5,
                  evals=((0, 0.3), (500, 0.5), (1000, 0.6)))
    _ablation_run(root, ("omega", "S_np", "S_nn", "n_theta", "n_r"), 1, 0.62, 0.5,
                  evals=((0, 0.3), (1000, 0.62)))  # evaluated less often: frames 0, 1000 only
    _ablation_run(root, ("n_r", "n_theta", "S_nn", "omega"), 0, 0.4, 0.5, evals=())
    _ablation_run(root, ("n_theta", "S_np"), 0, 0.51, 0.5)
    runs = sa.read_ablation(root)
    assert len(runs) == 4 and {r.seed for r in runs} == {0, 1}
    assert [r.curve is None for r in runs if r.signals == sa.SIGNAL_SETS[4]] == [True]
    summary = sa.summarise_sets(runs)
    assert [s["signals"] for s in summary] == [sa.SIGNAL_SETS[0], sa.SIGNAL_SETS[3],
                                               sa.SIGNAL_SETS[4]]
    assert summary[0]["ratios"].tolist() == pytest.approx([1.3, 1.24])
    assert summary[0]["mean"] == pytest.approx(1.27) and summary[0]["sem_one"] is None
    assert summary[0]["std"] == pytest.approx(np.std([1.3, 1.24], ddof=1))
    assert summary[2]["std"] == 0.0 and summary[2]["mean"] == pytest.approx(0.8)
    assert summary[2]["n"] == 1 and summary[2]["sem_one"] == 0.01
    assert sa.set_label(("S_np", "n_theta")) == r"[$n_\theta, S_{np}$]"
    with pytest.raises(ValueError, match="allowed"):
        sa.canonical(("n_r", "S_pn"))
    out = ablation.fig_ablation(np.array([10.0]), {"smart": np.array([0.6])},
                               {"smart": np.array([0.0])}, {"c1": np.array([1.0])},
                               {"c1": np.array([0.1])}, tmp_path / "a.png", runs=runs)
    first = out["ablation"][summary[0]["label"]]
    assert first["seeds"] == [0, 1] and first["mean"] == pytest.approx(1.27)
    # mean over the seeds at the frames both evaluated (the 500 of seed 0 alone is left out)
    assert out["curves_last"][summary[0]["label"]] == pytest.approx(0.61)
    assert summary[2]["label"] not in out["curves_last"]  # no held-out evaluations
    table = out["table"].splitlines()
    assert table[0].startswith("Ku = 10, 0.001M frames per run") and len(table) == 4 + 3
    assert table[4].startswith("| n_r, n_theta, S_nn, S_np, omega | 0, 1 | 0.650, 0.620 |")
    assert table[4].endswith("| **1.270 ± 0.042** |")
    assert (tmp_path / "a.png").stat().st_size > 1000

    def refused(match):
        with pytest.raises(ValueError, match=match) as err:
            sa.read_ablation(root)
        assert "\n" not in str(err.value)

    dup = _ablation_run(root / "again", ("n_theta", "S_np"), 0, 0.5, 0.5)
    refused("found twice")
    shutil.rmtree(dup)
    other = _ablation_run(root, ("n_r", "n_theta", "S_np"), 0, 0.5, 0.5, frames=2000)
    refused("differ in frames")
    shutil.rmtree(other)
    stale = _ablation_run(root, ("n_r", "n_theta", "S_np"), 0, 0.5, 0.5)
    (stale / "metrics.json").write_text(json.dumps(
        {"config": json.loads((stale / "metrics.json").read_text())["config"],
         "per_flow": [0.7, 0.8]}))
    refused("stale comparison")


def test_find_curves_follows_linked_run_directories(tmp_path):
    """``paper_runs/ku*_seed*`` are links to the runs: their curves are found, by link name."""
    run = tmp_path / "runs" / "ku10_seed0"
    run.mkdir(parents=True)
    (run / "curves.csv").write_text("frames,eval/R_hat\n0,0.2\n")
    (tmp_path / "chosen").mkdir()
    (tmp_path / "chosen" / "ku10_seed3").symlink_to(run, target_is_directory=True)
    assert training.find_curves(tmp_path / "chosen") == {
        "ku10_seed3": tmp_path / "chosen" / "ku10_seed3" / "curves.csv"}


def test_builders_are_the_configured_figures():
    """``only=`` is checked against :data:`settings.FIGURES` (without importing the builders):
    the same names, in build order, as :data:`BUILDERS`."""
    assert tuple(BUILDERS) == settings.FIGURES


def _held_out_comparison(path, runs, signals, sto=0.5, seed=0, n_flows=2, n_swimmers=4,
                         kubo=10.0):
    """``held_out/<run>/comparison.json`` (or the protocol's): STO, naive and one policy row
    per run directory ``runs`` (name -> smart R_hat), on the test seed's flows."""
    rows = [{"label": "sto", "R_hat_mean": sto, "ratio_to_first": 1.0, "ratio_sem": 0.0},
            {"label": "naive(+0.98)", "R_hat_mean": 0.3, "ratio_to_first": 0.3 / sto,
             "ratio_sem": 0.01}]
    rows += [{"label": f"policy({d / 'policy.pt'})", "R_hat_mean": smart,
              "ratio_to_first": smart / sto, "ratio_sem": 0.005} for d, smart in runs.items()]
    path.mkdir(parents=True, exist_ok=True)
    (path / "comparison.json").write_text(json.dumps({
        "rows": rows, "n_flows": n_flows, "n_swimmers": n_swimmers, "seed": seed,
        "config": {"signals": {"names": list(signals)}, "flow": {"kubo": kubo}}}))


def test_held_out_ablation_layout(tmp_path):
    """ablation (a) from ``<ablation>/held_out/<run>/comparison.json`` (one policy row: the
    run's policy.pt) and the protocol's comparison at the runs' Ku (the all-signal runs, one
    row per seed); the held-out sizes may differ in swimmers, not in flows or seed."""
    root, runs_root, protocol = tmp_path / "ablation", tmp_path / "runs", tmp_path / "protocol"
    nth = _ablation_run(root, ("n_theta", "S_np"), 0, 0.5, 0.5)
    (nth / "policy.pt").write_bytes(b"policy")
    _held_out_comparison(root / "held_out" / nth.name, {nth: 0.49}, ("n_theta", "S_np"))
    every = ("n_r", "n_theta", "S_nn", "S_np", "omega")
    seeds = [_ablation_run(runs_root, every, s, 0.7, 0.5, name=f"ku10_seed{s}") for s in (0, 1)]
    for d in seeds:
        (d / "policy.pt").write_bytes(b"policy")
    _held_out_comparison(protocol / "ku10", {d: 0.65 + 0.01 * i for i, d in enumerate(seeds)},
                         every, n_swimmers=10)
    runs, held, files = ablation.read_held_out(root, protocol)
    assert held == {"seed": 0, "n_flows": 2} and len(runs) == 3
    assert [(r.signals, r.seed, r.held_out) for r in runs] == [
        (("n_theta", "S_np"), 0, (2, 4)), (every, 0, (2, 10)), (every, 1, (2, 10))]
    assert runs[0].ratio == pytest.approx(0.98) and runs[2].smart == pytest.approx(0.66)
    assert {p.name for p in files} == {"comparison.json", "metrics.json", "policy.pt",
                                       "curves.csv"}
    summary = ablation.summarise_sets(runs)
    table = ablation.held_out_markdown(runs, summary, held["seed"]).splitlines()
    assert "(evaluation seed 0)" in table[0] and "| 2 x 10 |" in table[4]
    _held_out_comparison(protocol / "ku10", {seeds[0]: 0.7}, every, seed=3)
    with pytest.raises(ValueError, match="differ in held-out seed") as err:
        ablation.read_held_out(root, protocol)
    assert "\n" not in str(err.value)
    _held_out_comparison(protocol / "ku10", {seeds[0]: 0.7}, ("n_theta", "S_np"))
    with pytest.raises(ValueError, match="trained with"):
        ablation.read_held_out(root, protocol)
    _held_out_comparison(protocol / "ku10", {runs_root / "gone": 0.7}, every)
    with pytest.raises(ValueError, match="no run directory"):
        ablation.read_held_out(root, protocol)


# -- what the referee asked of the figures (issue "Results a referee accepts") ---------------
def test_sign_agreement_with_sto_counts_every_decision():
    """ku0.1: the fraction of decisions with sign(Lambda) = sign(Lambda_STO) = -sign(n_theta
    S_np), over the decisions where STO has a sign (n_theta = 0 at a first decision: none),
    streamed equal to one shot, and in the figure's returned data."""
    sig = RNG.uniform(-1, 1, (200, 30, 5))
    sig[:, 0, 1] = 0.0  # each trajectory's first decision: n_theta = 0
    x = sig[..., 1] * sig[..., 3]
    lam = -0.9 * np.sign(x)
    flip = RNG.random(lam.shape) < 0.2
    lam[flip] *= -1
    st = decision_stats.DecisionStats()
    for i in range(sig.shape[1]):
        st.add(sig[:, i], lam[:, i])
    a = st.arrays()
    got = decision_stats.sign_agreement(a)
    ok = x != 0
    assert got["undetermined"] == 200 and got["n"] == lam.size
    assert got["agree"] == int((~flip & ok).sum()) and got["disagree"] == int((flip & ok).sum())
    assert got["fraction"] == pytest.approx((~flip & ok).sum() / ok.sum())
    assert decision_stats.sign_agreement(decision_stats.decision_stats(sig, lam)) == got
    old = {k: v for k, v in a.items() if k != "sign_STO"}  # arrays cached before the counts
    assert decision_stats.sign_agreement(old) is None
    sto = decision_stats.sign_agreement(decision_stats.decision_stats(sig, -0.98 * np.sign(x)))
    assert sto["fraction"] == 1.0 and sto["disagree"] == 0


def test_occupancy_weight_follows_the_stated_rule(tmp_path):
    """kuInf (b), (c): full colour at the uniform share or above, white at 1/100 of it or
    below, half way (log scale) at 1/10; blank under MIN_COUNT decisions; the figure reports
    how many decisions each weight class holds and where (a)'s sample comes from."""
    counts = np.full((10, 10), 1000)
    counts[0, 0], counts[0, 1], counts[0, 2], counts[0, 3] = 100, 10, 3, 0
    w = mechanism.occupancy_weight(counts, decades=2, min_count=5)
    uniform = counts.sum() / counts.size
    assert w[5, 5] == 1.0
    assert w[0, 0] == pytest.approx(1 + np.log10(100 / uniform) / 2)
    assert w[0, 1] == pytest.approx(max(0.0, 1 + np.log10(10 / uniform) / 2))
    assert w[0, 2] == w[0, 3] == 0.0  # fewer than 5 decisions
    rule = mechanism.occupancy_rule(30)
    assert rule["full_colour_share"] == pytest.approx(1 / 900)
    assert rule["white_share"] == pytest.approx(1 / 90000) and rule["min_count"] == 5
    sig, lam = _record(300, 40)
    stats = decision_stats.decision_stats(sig, lam)
    out = mechanism.fig_ku_inf(stats, tmp_path / "b.png", sample="(a test sample)")
    assert out["a"] == {"drawn": 8000, "sample": lam.size}
    for panel in "bc":
        occ = out["occupancy"][panel]
        assert 0 <= occ["under_half"] <= 1 - occ["full_colour"] <= 1
        name = {"b": "omega_nr_pos", "c": "omega_nr_neg"}[panel]
        assert np.array_equal(occ["weight"],
                              mechanism.occupancy_weight(stats[f"map_{name}_count"]))
    assert (tmp_path / "b.png").stat().st_size > 10_000


def test_extend_record_adds_fields_and_changes_none(tmp_path):
    cfg = replace(figures_config(_compose(["progress=false"])), records=tmp_path)
    rec = {"figure": "kuInf", "sizes": {}, "evaluations": {}, "derived": {"a": 1, "b": [1, 2]}}
    (tmp_path / "kuInf.json").write_text(json.dumps(rec))
    same = records.extend_record(cfg, rec, lambda r: None)
    assert same is rec and json.loads((tmp_path / "kuInf.json").read_text()) == rec
    new = records.extend_record(cfg, rec, lambda r: r["derived"].update(c={"x": 0.5}))
    assert new["derived"] == {"a": 1, "b": [1, 2], "c": {"x": 0.5}}
    assert json.loads((tmp_path / "kuInf.json").read_text()) == new
    with pytest.raises(AssertionError, match="derived.a"):
        records.extend_record(cfg, new, lambda r: r["derived"].update(a=2))
    assert json.loads((tmp_path / "kuInf.json").read_text()) == new


def _compose(overrides):
    from hydra import compose, initialize_config_module

    with initialize_config_module("swimrl.conf", version_base="1.3"):
        return compose(config_name="figures", overrides=list(overrides))


def test_smart_performance_panels_share_axes_draw_smart_on_top_and_explain_their_flow(
        tmp_path):
    """(b-e): smart drawn last (on top), one pair of axis limits for all panels; the record's
    panels_b_e names the drawn flow, its order of the strategies against (a)'s means, and for
    a pair ordered otherwise in how many of (a)'s flows they are ordered so."""
    summaries = [summarise(r) for r in load([RESULTS])]
    assert stochastic.DRAW_ORDER[-1] == "smart"
    finals = {0.1: RNG.normal(0, 10, (3, 50, 2)), 1e7: RNG.normal(0, 40, (3, 50, 2))}
    per = {"smart": [0.6], "naive": [0.35], "STO": [0.39]}  # STO > naive here
    rec = {"evaluations": {"ku1e7": {"per_flow": per}}}
    panels = stochastic.drawn_flow(rec, summaries)
    s = next(x for x in summaries if x["kubo"] == 1e7)
    sto, naive = np.asarray(s["sto"]["per_flow"]), np.asarray(s["naive"]["per_flow"])
    d = panels["ku1e7"]
    assert d["order_drawn"] == ["smart", "STO", "naive"] and "ku0.1" not in panels
    assert d["protocol_above"]["STO>naive"] == [int((sto > naive).sum())]
    assert d["protocol_flows"] == sto.size and len(d["protocol_above"]["smart>STO"]) == len(
        s["seeds"])
    notes = stochastic.panel_notes(panels)
    assert "smart 0.600, STO 0.390, naive 0.350" in notes[1e7]
    if d["order_protocol"].index("STO") > d["order_protocol"].index("naive"):
        assert f"STO > naive here, as in {int((sto > naive).sum())}" in notes[1e7]
    out = stochastic.fig_smart_performance(summaries, finals, tmp_path / "e.png", "", notes)
    reach = max(np.abs(f).max() for f in finals.values())
    assert out["lim"] % 10 == 0 and reach <= out["lim"] < reach * 1.05 + 10


def test_training_curves_name_each_runs_held_out_flows(tmp_path):
    """trainingCurves: each run's held-out flows (metrics.json) in its legend, a panel whose
    runs were evaluated on different flows says so, the final policies on common flows (the
    protocol's comparison) drawn beside the curves."""
    runs = {}
    for seed in (0, 1):
        d = tmp_path / "runs" / f"ku1e7_seed{seed}"
        d.mkdir(parents=True)
        (d / "curves.csv").write_text("frames,eval/R_hat,eval/R_hat_sem\n0,0.3,0.01\n"
                                      "1000000,0.6,0.01\n")
        (d / "metrics.json").write_text(json.dumps({
            "config": {"train": {"eval_flows": 16, "eval_swimmers": 32}},
            "training": {"eval_seed": 1_000_000 + seed}}))
        (d / "policy.pt").write_bytes(b"policy")
        runs[d] = 0.7 + 0.01 * seed
    assert training.held_out_flows(tmp_path / "runs" / "ku1e7_seed1") == {
        "seed": 1_000_001, "n_flows": 16, "n_swimmers": 32}
    assert training.held_out_flows(tmp_path) is None
    _held_out_comparison(tmp_path / "protocol" / "ku1e7", runs, ("n_r",), kubo=1e7,
                         n_flows=100)
    comp = tmp_path / "protocol" / "ku1e7" / "comparison.json"
    rec = json.loads(comp.read_text())
    for row in rec["rows"]:  # summarise reads per-flow values and stds
        row.update(per_flow=[row["R_hat_mean"]] * 100, R_hat_std=0.0, R_hat_sem=0.0)
    comp.write_text(json.dumps(rec))
    common, sizes = training.common_flows(tmp_path / "protocol")
    assert common == {"ku1e7_seed0": 0.7, "ku1e7_seed1": pytest.approx(0.71)}
    assert sizes == "100 flows x 4 swimmers of test seed 0"
    cfg = replace(figures_config(_compose(["progress=false"])), curves=tmp_path / "runs",
                  results=tmp_path / "protocol", out=tmp_path / "fig")
    out = training.build_training_curves(cfg)
    assert out["ku1e7_seed0"] == 0.6 and out["common"] == common
    assert out["held_out"]["ku1e7_seed0"]["seed"] == 1_000_000
    assert (tmp_path / "fig" / "trainingCurves.png").stat().st_size > 10_000


def test_dns_flow_draws_the_field_at_the_paths_middle_time(tmp_path):
    """dnsFlow (a): the stored vorticity nearest the middle of the drawn window, not t = 0."""
    from swimrl.paper import dns

    n = 50
    rec = {"smart_path": np.cumsum(RNG.normal(0, 0.01, (1, n + 1, 2)), axis=1) + 0.5,
           "smart_theta": RNG.uniform(0, 6, (1, n + 1)),
           "smart_Lambda": RNG.uniform(-0.9, 0.9, (1, n)), "update_interval": np.asarray(0.1),
           "vorticity": RNG.normal(size=(4, 8, 8)), "field_time": np.array([0.0, 1.5, 3.0, 4.5])}
    for other in ("n_theta", "omega"):
        rec[f"map_{other}"] = np.zeros((2, 2))
        rec[f"map_{other}_x"] = rec[f"map_{other}_y"] = np.linspace(-1, 1, 3)
    out = dns.fig_dns_flow(rec, None, None, tmp_path / "d.png", glyph_window=4.0,
                           glyph_every=1.0)
    assert out["a"]["field_time"] == 1.5  # the stored time nearest t = 4 / 2
    del rec["field_time"]
    out = dns.fig_dns_flow(rec, None, None, tmp_path / "e.png", glyph_window=4.0)
    assert out["a"]["field_time"] == 0.0
