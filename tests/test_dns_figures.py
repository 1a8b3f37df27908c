"""Fig. dnsFlow and the DNS videos: the replay record, the transfer summary, the drawing."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_module

from swimrl.paper import dns as dfig
from swimrl.paper import dns_replay, dns_transfer, evaluations
from swimrl.paper.config import figures_config
from swimrl.policies.baselines import StrategyLabel

torch.set_num_threads(1)


def test_glyph_aspect_inverts_the_shape_factor():
    a = np.array([0.2, 1.0, 3.0, 9.95])
    lam = (a**2 - 1) / (a**2 + 1)
    assert dfig.spheroid_aspect(lam) == pytest.approx(a)


def _comparison(path, rows: dict[str, list[float]]):
    path.mkdir(parents=True)
    (path / "comparison.json").write_text(json.dumps(
        {"rows": [{"label": k, "per_flow": v} for k, v in rows.items()]}))


def test_transfer_summary_pairs_each_flow_with_sto(tmp_path):
    _comparison(tmp_path / "0", {"sto": [1.0, 2.0], "policy(pretrained/ku10)": [1.2, 2.8],
                                 "minimal(ku10)": [0.9, 1.8], "naive(+0.98)": [0.5, 1.0]})
    _comparison(tmp_path / "1", {"sto": [1.0, 1.0], "policy(pretrained/ku10)": [1.0, 1.2],
                                 "minimal(ku10)": [1.1, 0.9], "naive(+0.98)": [0.5, 0.5]})
    per = dns_transfer.read_transfer(tmp_path)
    assert per["realisation"].tolist() == [0, 0, 1, 1]
    s = dns_transfer.transfer_summary(per)
    smart = s["policy(pretrained/ku10)"]
    assert smart["ratio"] == pytest.approx(6.2 / 5)  # the ratio of the means, paired
    assert smart["ratio_realisations"] == pytest.approx([4.0 / 3, 1.1])
    assert smart["ratio_realisation_std"] == pytest.approx(np.std([4.0 / 3, 1.1], ddof=1))
    assert s["naive(+0.98)"]["ratio"] == pytest.approx(0.5)
    assert s["sto"]["ratio_realisation_std"] == 0 and s["sto"]["n_realisations"] == 2
    table = dns_transfer.transfer_markdown(s)
    assert "| policy(pretrained/ku10) |" in table and "1.240 ±" in table and "1.333, 1.100" in table
    ku_of = lambda label: StrategyLabel.parse(label).kubo  # noqa: E731
    assert ku_of("policy(pretrained/ku1e7)") == 1e7
    assert ku_of("minimal(ku0.1)") == 0.1 and ku_of("policy(pretrained/dns)") is None
    assert ku_of("policy(runs/ku10_seed0)") is None and ku_of("minimal(ku1_0)") is None


def test_trained_ratio_per_realisation_and_its_spread_over_runs(tmp_path):
    _comparison(tmp_path / "0", {"sto": [1.0, 1.0], "policy(pretrained/ku10)": [1.2, 1.6],
                                 "policy(a)": [1.0, 1.0], "policy(b)": [1.4, 1.4]})
    _comparison(tmp_path / "1", {"sto": [1.0, 1.0], "policy(pretrained/ku10)": [1.0, 1.0],
                                 "policy(a)": [0.5, 1.5], "policy(b)": [1.0, 1.5]})
    r = dns_transfer.trained_ratio(dns_transfer.read_transfer(tmp_path), "policy(pretrained/ku10)",
                           ["policy(a)", "policy(b)"])
    np.testing.assert_allclose(r["per_realisation"], [[1.4, 1.0], [1.0, 0.8]])
    assert r["realisation_mean"] == pytest.approx([1.2, 0.9])
    assert r["realisation_std_over_runs"] == pytest.approx([np.std([1.4, 1.0], ddof=1),
                                                            np.std([1.0, 0.8], ddof=1)])
    assert r["overall"] == pytest.approx([4.8 / 4.0, 4.8 / 5.3])
    assert r["overall_std_over_runs"] == pytest.approx(np.std(r["overall"], ddof=1))
    table = dns_transfer.trained_ratio_markdown(r, dns_transfer.realisation_names(tmp_path))
    assert "| 0 | 1.400 | 1.000 | 1.200 |" in table and "| all flows | 1.200 |" in table
    assert "| 2 | 1.400 |" in dns_transfer.trained_ratio_markdown(r, ["2", "3"])


def test_dns_trained_must_be_one_of_the_trained_seeds():
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose(config_name="figures", overrides=["dns.trained=pretrained/ku10"])
    from swimrl.errors import ConfigError
    with pytest.raises(ConfigError, match="dns.trained='pretrained/ku10' is invalid"):
        figures_config(cfg)


def test_figure_draws_every_panel_from_tiny_records(tmp_path):
    rng = np.random.default_rng(0)
    n = 50  # decisions, T_u = 0.1 tau_K
    path = np.cumsum(rng.normal(0, 0.01, (2, n + 1, 2)), axis=1) + 0.5
    rec = {"smart_path": path, "smart_theta": rng.uniform(0, 6, (2, n + 1)),
           "smart_Lambda": rng.uniform(-0.98, 0.98, (2, n)), "update_interval": np.asarray(0.1),
           "vorticity": rng.normal(size=(3, 16, 16))}
    edges = np.linspace(-1, 1, 5)
    for other in ("n_theta", "omega"):
        rec[f"map_{other}"] = np.where(np.eye(4) > 0, 0.5, np.nan)
        rec[f"map_{other}_x"] = rec[f"map_{other}_y"] = edges
    z = np.linspace(-5, 5, 21)
    pdfs = {"omega": {"z": z.tolist(), "pdf": np.exp(-z**2 / 2).tolist()}}
    def row(ratio, err):
        return {"ratio": ratio, "ratio_realisation_std": err, "n_flows": 4, "n_realisations": 2}

    summary = {"sto": row(1.0, 0.0), "policy(pretrained/ku10)": row(1.1, 0.05),
               "policy(pretrained/ku1)": row(0.9, 0.05), "policy(pretrained/dns)": row(1.2, 0.04),
               "naive(+0.98)": row(0.6, 0.02), "policy(runs/other)": row(1.0, 0.1)}
    curve = {"frames": np.array([0.0, 1e6, 2e6]), "eval/R_hat": np.array([0.2, np.nan, 0.5]),
             "eval/R_hat_sem": np.array([0.01, np.nan, 0.01])}
    out = dfig.fig_dns_flow(rec, pdfs, summary, tmp_path / "d.png", glyph_window=4.0,
                            glyph_every=1.0, curves={"seed0": curve, "seed1": curve})
    assert out["f"] == {"seed0": [0.2, 0.5], "seed1": [0.2, 0.5]}
    assert (tmp_path / "d.png").stat().st_size > 10_000
    assert out["a"]["window_decisions"] == 40 and out["a"]["glyphs"] == 4  # t = 0, 1, 2, 3
    assert out["b"] == ["omega"] and out["d"] == 4 and out["e"] == 4
    assert out["c"]["smart"] == [[1.0, 0.9, 0.05], [10.0, 1.1, 0.05]]
    assert out["c"]["lines"] == {"trained in the DNS": 1.2, "naive(+0.98)": 0.6}
    assert out["c"]["not_drawn"] == ["policy(runs/other)"]
    none = dfig.fig_dns_flow(None, None, None, tmp_path / "e.png")
    assert none == {} and (tmp_path / "e.png").exists()


def test_replay_record_is_made_once_from_the_store_and_read_after(tmp_path):
    """dns_record on a tiny stored run: made from the store, written, then read (also with
    the store gone); box units; R_hat = final distance / v_s T; videos 5 and 10 draw it."""
    from swimrl.config import dns_run
    from swimrl.flows.dns.run import run_dns
    from swimrl.paper.videos import video_cloud, video_trajectories

    store = tmp_path / "run.zarr"
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        dns_cfg = compose(config_name="dns", overrides=[
            "dns.n=32", "dns.nu=5e-3", "dns.dt=4e-3", "spinup.time=0.2",
            "spinup.measure_time=0.1", "store.n_times=40", "store.diag_every=5",
            "progress=false", "threads=1", f"store.path={store}"])
    run_dns(dns_run(dns_cfg))
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        fig_cfg = compose(config_name="figures", overrides=["episode.duration=1.0",
                                                            "progress=false"])
    cfg = replace(figures_config(fig_cfg), out=tmp_path / "fig", cache=tmp_path / "cache")
    dns = replace(cfg.dns, store=store, record=tmp_path / "rec" / "record.npz",
                  transfer=tmp_path / "none", checks=tmp_path / "none.json",
                  policy="naive(-0.5)", trained="naive(0.5)", trained_seeds=("naive(0.5)",),
                  curves=(), n_swimmers=5,
                  n_traj=2, decode_n=None)
    missing, why = dns_replay.dns_record(cfg, replace(dns, policy="nowhere/policy.pt"))
    assert missing is None and "dns.policy" in why and not dns.record.exists()
    a, why = dns_replay.dns_record(cfg, dns)
    assert dns.record.exists() and why == ""
    frames = 1 + 10 // evaluations.FRAME_EVERY  # every FRAME_EVERY decisions of 10
    assert a["cloud"].shape == (3, 5, frames, 2) and a["smart_path"].shape == (2, 11, 2)
    assert a["smart_Lambda"].shape == (2, 10) and np.allclose(a["smart_Lambda"], -0.5)
    for other in ("n_theta", "omega"):  # the 'trained' block: constant Lambda = 0.5
        m = a[f"map_{other}"]
        assert m.shape == (30, 30) and np.all(np.isnan(m) | np.isclose(m, 0.5))
        assert a[f"map_{other}_x"].shape == (31,)
    assert a["R_hat"].shape == (4, 5)
    assert np.all(a["cloud"][:, :, 0] == 0) and float(a["box"]) == 1.0
    final = a["smart_path"][:, -1] - a["smart_path"][:, 0]
    assert np.allclose(a["traj_abs"][0, :, 0], a["smart_path"][:, 0])
    dist = np.linalg.norm(final, axis=-1)  # box units, as reference_distance
    assert dist / float(a["reference_distance"]) == pytest.approx(a["R_hat"][0, :2], rel=1e-4)
    assert a["vorticity"].shape[0] == 2 and math.isclose(float(a["time"][-1]), 1.0)
    summary = dns_replay.replay_summary(a)
    assert list(summary) == ["naive(-0.5)", "naive", "sto", "naive(0.5)"]
    assert summary["naive(-0.5)"]["R_hat"] == pytest.approx(float(a["R_hat"][0].mean()))
    assert summary["naive(-0.5)"]["distance_L"] == pytest.approx(  # box units, as dist
        float(a["R_hat"][0].mean() * a["reference_distance"]))
    assert "| sto |" in dns_replay.replay_markdown(summary, "run.zarr")
    store.rename(tmp_path / "gone.zarr")
    b, _ = dns_replay.dns_record(cfg, dns)
    assert all(np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f") for k in a)
    other, why = dns_replay.dns_record(cfg, replace(dns, n_swimmers=6))  # made with other inputs
    assert other is None and "n_swimmers" in why
    v = video_cloud(b, "DNS", tmp_path / "v10.mp4", fps=2, unit="L")
    t = video_trajectories(b, "DNS", tmp_path / "v5.mp4", fps=2, unit="L")
    assert v["frames"] == frames and t["frames"] == frames
