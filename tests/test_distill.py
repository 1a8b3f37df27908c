"""swimrl-distill (swimrl.analysis.distill): the student fits a known teacher function, and
the command's policy file is a policy the evaluation and a warm start accept."""

from __future__ import annotations

import json
import subprocess
import sys

import torch
from tensordict import TensorDict

from swimrl.analysis.distill import DistillSettings, fit_actor
from swimrl.config import env_params, model_spec
from swimrl.policies.networks import ModelSpec, action_spec
from swimrl.runs.policy_files import initial_actor_weights, load_policy


def test_student_fits_a_smooth_teacher():
    """A teacher ``0.98 tanh(2 x0 - x1)`` on Gaussian observations: the student's deterministic
    action agrees on held-back samples (correlation > 0.99, mse < 1e-3); sigma = init_std."""
    gen = torch.Generator().manual_seed(0)
    obs = torch.randn(20000, 3, generator=gen)
    act = (0.98 * torch.tanh(2 * obs[:, 0] - obs[:, 1])).unsqueeze(-1)
    settings = DistillSettings(n_flows=1, n_swimmers=1, stride=1, epochs=30,
                               minibatch_size=512, lr=3e-3, holdout=0.1, fit_seed=0)
    model = ModelSpec(hidden=(64, 64), activation="tanh", init_std=0.3, min_std=1e-4)
    actor, fit = fit_actor(model, obs, act, action_spec(0.98), settings)
    assert fit["holdout_corr"] > 0.99 and fit["holdout_mse"] < 1e-3
    assert fit["n_holdout"] == 2000
    scale = actor.module[0].module[1].state_independent_scale
    assert torch.allclose(scale.exp(), torch.tensor(0.3))


def test_distill_command_writes_a_policy_the_evaluation_and_a_warm_start_accept(compose_cfg,
                                                                               tmp_path):
    out = tmp_path / "d"
    subprocess.run([sys.executable, "-m", "swimrl.cli.distill", "flow=stochastic3d",
                    "flow.kubo=10", "strategy=optimised3d", "kernel=fused", "signals=rule_terms",
                    "distill.n_flows=1",
                    "distill.n_swimmers=8", "distill.epochs=2", "episode.duration=2",
                    f"hydra.run.dir={out}"], check=True, capture_output=True, cwd=tmp_path)
    rec = json.loads((out / "distill.json").read_text())
    assert rec["teacher"] == "optimised" and rec["n_samples"] == 8 * 20 // 4
    cfg = compose_cfg(["flow=stochastic3d", "flow.kubo=10", "signals=rule_terms"],
                      name="train")
    params = env_params(cfg)
    actor = load_policy(str(out), params)
    td = actor(TensorDict({"observation": torch.zeros(4, len(params.signals))}, batch_size=[4]))
    assert td["action"].shape == (4, 1)
    model = model_spec(compose_cfg(["model.init_std=0.3"], name="train").model)
    path, weights = initial_actor_weights(str(out), params, model)
    assert path.name == "policy.pt" and any("scale" in k for k in weights)
