r"""Quantities of a swimmer in the task's frame that the policy's signals do not hold: its
alignment with the frame, which the swimming reward and $\hat S$ integrate, and the flow's
velocity along and across the frame, which an asymmetric critic reads
(``train.critic_flow``).

The frame is the task's direction $\boldsymbol e_r$ (:meth:`~swimrl.env.SwimmerEnv.frame`),
$\boldsymbol n$ where its vector vanishes (a swimmer at its start), as for the signals
(:func:`~swimrl.physics.body3d.radial_direction`, which holds in any dimension).
"""

from __future__ import annotations

import torch
from torchrl.data import Unbounded

from swimrl.physics.body3d import radial_direction


def radial_alignment(n: torch.Tensor, frame: torch.Tensor) -> torch.Tensor:
    r"""$n_r = \boldsymbol n\cdot\boldsymbol e_r$, ``(...)`` (1 at the start point)."""
    return (n * radial_direction(n, frame)).sum(-1)


def flow_features(u: torch.Tensor, n: torch.Tensor, frame: torch.Tensor,
                  swim_speed: float) -> torch.Tensor:
    r"""$(u_r, u_\perp)/v_s$, ``(..., 2)``: the flow's velocity along $\boldsymbol e_r$,
    $u_r = \boldsymbol u\cdot\boldsymbol e_r$, and the size of the rest,
    $u_\perp = |\boldsymbol u - u_r\boldsymbol e_r|$, in units of the swimming speed."""
    e_r = radial_direction(n, frame)
    u_r = (u * e_r).sum(-1, keepdim=True)
    return torch.cat((u_r, (u - u_r * e_r).norm(dim=-1, keepdim=True)), -1) / swim_speed


def observe_flow_for_critic(env) -> None:
    """Add ``critic_observation`` to every observation of ``env`` (``train.critic_flow``): the
    observation and :func:`flow_features` at the swimmers; the policy's observation, and so
    the policy, is unchanged."""
    env.critic_flow = True
    spec = env.observation_spec.clone()
    n_obs = spec["observation"].shape[-1] + 2
    spec["critic_observation"] = Unbounded(shape=env.batch_size + (n_obs,), device=env.device,
                                           dtype=env.pos.dtype)
    env.observation_spec = spec
