r"""A strategy distilled into a policy network: the start of a warm-started PPO run
(``train.init_policy``), to ask whether the learner keeps, improves or loses a reference it is
handed.

The teacher (a baseline, e.g. the optimised rule, :class:`~swimrl.policies.baselines.StrategySpec`)
swims its own episodes in ``n_flows`` flows of the config; every ``stride``-th decision of every
swimmer gives one sample, the student's observation $s$ (``signals.names``) and the teacher's
shape $\Lambda_T$. The actor of ``model.*`` (:func:`~swimrl.policies.networks.tanh_normal_actor`,
whose deterministic action is $\Lambda_\max\tanh\mu(s)$) is fitted by Adam to

$$
L = \big\langle\big(\Lambda_\max\tanh\mu(s) - \Lambda_T\big)^2\big\rangle ,
$$

and its state-independent $\sigma$ is set to ``model.init_std`` (the exploration the PPO run
starts from). The fit's loss and the agreement on held-back samples are recorded.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch

from swimrl.env import build_env
from swimrl.errors import as_float, as_int
from swimrl.policies.baselines import StrategySpec, build_strategy
from swimrl.policies.networks import ModelSpec, actor_critic, mean_network
from swimrl.runs.spec import RunSpec


@dataclass(frozen=True)
class DistillSettings:
    """``distill.*``: the teacher's episodes (flows, swimmers, seed, every ``stride``-th
    decision kept) and the fit (epochs, minibatch, Adam rate, the held-back fraction, the
    minibatch order's seed)."""

    n_flows: int
    n_swimmers: int
    stride: int
    epochs: int
    minibatch_size: int
    lr: float
    holdout: float
    fit_seed: int

    def __post_init__(self) -> None:
        for key in ("n_flows", "n_swimmers", "stride", "epochs", "minibatch_size"):
            as_int(f"distill.{key}", getattr(self, key), low=1)
        as_int("distill.fit_seed", self.fit_seed, low=0)
        as_float("distill.lr", self.lr, lambda v: v > 0, "> 0")
        as_float("distill.holdout", self.holdout, lambda v: 0 <= v < 1, "in [0, 1)")


@dataclass(frozen=True)
class TeacherSamples:
    """The student's observations ``(n, k)``, the teacher's actions ``(n, m)``, the
    teacher's mean score over its episodes and the environment's unbatched action spec."""

    obs: torch.Tensor
    action: torch.Tensor
    score: float
    action_spec: object


def teacher_samples(setup: RunSpec, teacher: StrategySpec, n_flows: int, n_swimmers: int,
                    stride: int) -> TeacherSamples:
    r"""The samples of every ``stride``-th decision of the teacher's own episodes
    (``n_flows`` flows of ``setup.seed`` $\times$ ``n_swimmers`` swimmers)."""
    env = build_env(setup.flow, setup.params, setup.runtime, n_flows, n_swimmers, setup.seed)
    actor = build_strategy(teacher, env.action_spec_unbatched).to(setup.runtime.device)
    obs, act = [], []
    td = env.reset()
    with torch.no_grad():
        for i in range(setup.params.n_decisions):
            td = actor(td)
            if i % stride == 0:
                obs.append(td["observation"].reshape(-1, td["observation"].shape[-1]).clone())
                act.append(td["action"].reshape(obs[-1].shape[0], -1).clone())
            td = env.step(td).get("next")
    return TeacherSamples(torch.cat(obs), torch.cat(act), float(env.score(td).mean()),
                          env.action_spec_unbatched)


def fit_actor(model: ModelSpec, obs: torch.Tensor, act: torch.Tensor, action_spec,
              settings: DistillSettings, log: Callable[[str], None] | None = None):
    r"""The actor of ``model`` fitted to ``act`` from ``obs`` (loss of the module docstring)
    on all but a held-back fraction ``holdout`` of the samples (shuffled by ``fit_seed``; the
    held-back states come from the same episodes); returns the
    actor and ``{"train_mse", "holdout_mse", "holdout_corr"}``."""
    gen = torch.Generator().manual_seed(settings.fit_seed)
    perm = torch.randperm(len(obs), generator=gen)
    obs, act = obs[perm], act[perm]
    n_hold = int(round(settings.holdout * len(obs)))
    x, y, xh, yh = obs[n_hold:], act[n_hold:], obs[:n_hold], act[:n_hold]
    actor, _ = actor_critic(model, obs.shape[-1], action_spec, dtype=obs.dtype)
    mean = mean_network(actor)
    high = torch.as_tensor(action_spec.space.high, dtype=obs.dtype).reshape(-1)[:act.shape[-1]]
    low = torch.as_tensor(action_spec.space.low, dtype=obs.dtype).reshape(-1)[:act.shape[-1]]

    def deterministic(z: torch.Tensor) -> torch.Tensor:
        return (high + low) / 2 + (high - low) / 2 * torch.tanh(mean(z))

    opt = torch.optim.Adam(mean.parameters(), lr=settings.lr)
    for epoch in range(settings.epochs):
        order = torch.randperm(len(x), generator=gen)
        total = 0.0
        for j in range(0, len(x), settings.minibatch_size):
            idx = order[j:j + settings.minibatch_size]
            loss = ((deterministic(x[idx]) - y[idx]) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(idx)
        if log is not None:
            log(f"epoch {epoch + 1}/{settings.epochs}: mse {total / len(x):.5f}")
    with torch.no_grad():
        train_mse = float(((deterministic(x) - y) ** 2).mean())
        out = {"train_mse": train_mse, "n_train": len(x), "n_holdout": n_hold}
        if n_hold > 1:
            pred = deterministic(xh)
            out["holdout_mse"] = float(((pred - yh) ** 2).mean())
            out["holdout_corr"] = float(torch.corrcoef(
                torch.stack((pred.reshape(-1), yh.reshape(-1))))[0, 1])
    return actor, out
