r"""The action of :class:`~swimrl.env.core.SwimmerEnv` for each actuation
(:mod:`swimrl.actuation`): its spec (:func:`action_spec`) and what it sets over the next
decision interval (:func:`controls`): the shape factor $\Lambda$ of every swimmer and, where
the swimmer steers, its preferred direction $\boldsymbol k_a$."""

from __future__ import annotations

import torch
from torchrl.data import Bounded, Categorical

from swimrl.actuation import ActuationSpec
from swimrl.physics.gyrotaxis import axis_directions


def action_spec(actuation: ActuationSpec, shape_factor_max: float, dim: int,
                batch: torch.Size, device, dtype):
    r"""The action spec of ``batch`` swimmers in ``dim``-space:

    * ``shape``: $\Lambda\in[-\Lambda_\max, \Lambda_\max]$, ``batch + (1,)``;
    * ``steer``, continuous: $\boldsymbol a\in[-1, 1]^d$, ``batch + (d,)``; discrete: an index
      into :func:`~swimrl.physics.gyrotaxis.axis_directions`, ``Categorical(2d)`` of shape
      ``batch``;
    * ``shape_steer``: $(\Lambda, \boldsymbol a)$, ``batch + (1 + d,)``.
    """
    lam = shape_factor_max
    if actuation.name == "shape":
        return Bounded(low=-lam, high=lam, shape=batch + (1,), device=device, dtype=dtype)
    if actuation.directions == "discrete":
        return Categorical(2 * dim, shape=batch, device=device, dtype=torch.int64)
    width = dim + int(actuation.shapes)
    low = -torch.ones(batch + (width,), device=device, dtype=dtype)
    high = torch.ones(batch + (width,), device=device, dtype=dtype)
    if actuation.shapes:
        low[..., 0], high[..., 0] = -lam, lam
    return Bounded(low=low, high=high, shape=batch + (width,), device=device, dtype=dtype)


def unit_direction(a: torch.Tensor) -> torch.Tensor:
    r"""$\boldsymbol a/|\boldsymbol a|$ (0 where $|\boldsymbol a| = 0$: no torque)."""
    norm = a.norm(dim=-1, keepdim=True)
    return a / torch.where(norm > 0, norm, torch.ones_like(norm))


def controls(actuation: ActuationSpec, action: torch.Tensor, shape_factor_max: float,
             batch: torch.Size, dim: int, dtype
             ) -> tuple[torch.Tensor, torch.Tensor | None]:
    r"""$\Lambda$ ``(F S,)`` (clamped to $\pm\Lambda_\max$) and $\boldsymbol k_a$ ``(F, S, d)``
    (None: the swimmer does not steer) from the ``action`` of :func:`action_spec`."""
    lam = shape_factor_max
    if actuation.name == "shape":
        return action.reshape(-1).clamp(-lam, lam), None
    held = torch.full((batch.numel(),), float(actuation.shape_factor), device=action.device,
                      dtype=dtype)
    if actuation.directions == "discrete":
        dirs = axis_directions(dim, action.device, dtype)
        return held, dirs[action.reshape(batch).long()]
    a = action.reshape(*batch, -1).to(dtype)
    if actuation.shapes:
        return a[..., 0].reshape(-1).clamp(-lam, lam), unit_direction(a[..., 1:])
    return held, unit_direction(a)


def up_action(actuation: ActuationSpec, dim: int, vertical_axis: int, shape: float
              ) -> list[float] | int:
    r"""The action of a swimmer that steers straight up (the naive gyrotactic swimmer,
    $\boldsymbol k_a = \hat{\boldsymbol z}$), with the shape factor ``shape`` where the action
    sets it: an index (discrete) or the vector $(\Lambda,)\ \hat{\boldsymbol z}$."""
    if actuation.directions == "discrete":
        return vertical_axis
    up = [0.0] * dim
    up[vertical_axis] = 1.0
    return ([float(shape)] if actuation.shapes else []) + up
