"""Trajectory records (``eval.record``): the recorded swimmers are the evaluation's own."""

from __future__ import annotations

import numpy as np
import pytest

from swimrl.config import eval_config
from swimrl.errors import ConfigError
from swimrl.evaluation.rollout import evaluate, evaluate_shared
from swimrl.evaluation.trajectories import TrajectoryRecorder, load_trajectories, save_trajectories
from swimrl.policies.baselines import StrategySpec

from .conftest import SMALL

SIZE = ["eval.n_flows=3", "eval.flows_per_batch=2", "eval.n_swimmers=4", "episode.duration=1.0"]


def test_record_reproduces_r_hat(compose_cfg, tmp_path):
    """Recording every swimmer: |x(T) - x_0| / (v_s T) of the record, averaged per flow, is the
    evaluation's per-flow R_hat; recording changes nothing; the file round-trips."""
    c = eval_config(compose_cfg(SMALL + SIZE + ["strategy=sto", "eval.record=4"]))
    rec = TrajectoryRecorder(4)
    m = evaluate(c.setup, c.strategy, "sto", rec)
    a = rec.arrays()
    n_dec = c.setup.params.n_decisions
    assert a["signals"].shape == (3, 1, 4, n_dec, 5) and a["Lambda"].shape == (3, 1, 4, n_dec)
    assert a["position"].shape == (3, 1, 4, n_dec + 1, 2) and a["time"].shape == (n_dec + 1,)
    r = np.linalg.norm(a["position"][..., -1, :] - a["position"][..., 0, :], axis=-1)
    r_hat = r / a["reference_distance"]
    assert r_hat == pytest.approx(a["R_hat"], rel=1e-5, abs=1e-6)
    assert r_hat.mean(axis=(1, 2)) == pytest.approx(m["per_flow"], rel=1e-5)
    assert evaluate(c.setup, c.strategy, "sto")["per_flow"] == m["per_flow"]
    assert np.all(np.abs(a["Lambda"]) <= c.setup.params.shape_factor_max + 1e-6)
    back = load_trajectories(save_trajectories(a, tmp_path / "t.npz", ["sto"], c.setup.record))
    assert back["strategies"] == ["sto"] and back["config"]["strategy"]["name"] == "sto"
    np.testing.assert_allclose(back["position"], a["position"], rtol=1e-6)


def test_record_blocks_and_subset(compose_cfg):
    """Two strategies on shared flows, 2 of 4 swimmers recorded: each block's first swimmers,
    naive's Lambda is its constant, and recording is deterministic."""
    c = eval_config(compose_cfg(SMALL + SIZE))
    naive = StrategySpec("naive", shape_factor=-0.5)
    runs = []
    for _ in range(2):
        rec = TrajectoryRecorder(2)
        evaluate_shared(c.setup, [StrategySpec("sto"), naive], recorder=rec)
        runs.append(rec.arrays())
    a = runs[0]
    assert a["Lambda"].shape[:3] == (3, 2, 2)
    assert np.allclose(a["Lambda"][:, 1], -0.5)
    assert np.array_equal(a["position"], runs[1]["position"])
    # the blocks start from the same flows and points (common random numbers), then the two
    # strategies take them apart
    assert np.array_equal(a["position"][:, 0, :, 0], a["position"][:, 1, :, 0])
    assert not np.allclose(a["position"][:, 0, :, -1], a["position"][:, 1, :, -1])


def test_record_bound(compose_cfg):
    with pytest.raises(ConfigError, match="eval.record=5"):
        eval_config(compose_cfg(SMALL + SIZE + ["eval.record=5"]))


def test_record_vorticity_frames(compose_cfg):
    """field_every=m: omega tau_K of the first flow at decisions 0, m, ... and at T; the first
    frame is the evaluation's initial flow."""
    from swimrl.paper.evaluations import flow_vorticity

    c = eval_config(compose_cfg(SMALL + SIZE))
    rec = TrajectoryRecorder(1, field_every=4, field_stride=2)
    evaluate(c.setup, c.strategy, "sto", rec)
    a = rec.arrays()
    assert a["vorticity"].shape == (4, 32, 32)  # decisions 0, 4, 8 and T (N = 10)
    assert a["field_time"] == pytest.approx([0.0, 0.4, 0.8, 1.0])
    np.testing.assert_allclose(a["vorticity"][0], flow_vorticity(c.setup)[::2, ::2], atol=1e-4)
