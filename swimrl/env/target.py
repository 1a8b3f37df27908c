"""One decision of ``task=target`` (point-to-point navigation, :mod:`swimrl.task`) in a
:class:`~swimrl.env.SwimmerEnv`."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase


def step_target(env, action: torch.Tensor) -> TensorDictBase:
    """One decision of ``task=target``: arrived swimmers stay where they are (no motion,
    reward or energy); ``r_i = rho(t_{i-1}) - rho(t_i)`` for the others, who arrive when
    ``rho <= task.arrival_radius``."""
    moving = ~env.arrived
    rho_before = (env.target - env.displacement()).norm(dim=-1)
    # the arrived swimmers' state put back after the interval, with no branch on whether
    # there are any (a branch on a tensor value would wait for the device)
    frozen = [x.clone() for x in env.state()]
    env.integrate(action)
    for x, old in zip(env.state(), frozen, strict=True):
        keep = env.arrived.view(*env.batch_size, *([1] * (x.dim() - 2)))
        x.copy_(torch.where(keep, old, x))
    env.step_count += 1
    env.flow_step += 1
    rho = (env.target - env.displacement()).norm(dim=-1)
    now = moving & (rho <= env.arrival_radius)
    env.arrived |= now
    env.arrival_step.copy_(torch.where(now, env.step_count, env.arrival_step))
    cost = env._cost(action.view(env.batch_size), moving)
    reward = torch.where(moving, rho_before - rho, torch.zeros_like(rho))
    out = env._observe()
    out.set("reward", (reward if cost is None else reward - cost).unsqueeze(-1))
    return out
