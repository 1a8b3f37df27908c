r"""Integrate swimmers in a flow evaluated at their positions over one decision interval
($K = T_u/\delta t$ Heun steps, $\Lambda$ held): the loop of
:class:`~swimrl.env.point.PointSwimmerEnv`, for any :class:`~swimrl.physics.body.Body`
(:func:`integrate_point_interval`), and the fused CPU kernel of the 3D stochastic flow
(:func:`integrate_point_interval_fused`, ``swimrl/physics/kernels/heun3d_cpu.cpp``), which
draws the same random numbers in the same order.
"""

from __future__ import annotations

from collections.abc import Callable

import torch

from swimrl.flows.stochastic3d import StochasticFlow3D
from swimrl.physics.body import Body
from swimrl.physics.integrator import integrate_interval_3d_fused


def integrate_point_interval(
    body: Body,
    channels: Callable[[torch.Tensor], torch.Tensor],
    advance: Callable[[], None],
    track: Callable[[], None],
    pos: torch.Tensor,
    orientation: torch.Tensor,
    shape_factor: torch.Tensor,
    swim_speed: float,
    dt: float,
    n_substeps: int,
    rot_diffusion: float,
    tau_k: float,
    generator: torch.Generator,
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""$K$ = ``n_substeps`` Heun steps (:meth:`~swimrl.physics.body.Body.heun_step`) of
    ``pos`` ``(F, S, d)`` and ``orientation``, ``shape_factor`` $\Lambda$ ``(F, S)`` held;
    ``channels(pos)`` the body's channels at the current flow time, ``advance()`` moves the flow
    by $\delta t$ (between the stages), ``track()`` after each step. With
    $D_r$ = ``rot_diffusion / tau_k`` $> 0$, each step first draws standard normal noise of
    the orientation's shape from ``generator``. Returns the new positions and orientations
    (:meth:`~swimrl.physics.body.Body.normalise`\ d)."""
    d_r = rot_diffusion / tau_k
    batch = pos.shape[:-1]
    for _ in range(n_substeps):
        noise = None
        if d_r > 0:
            noise = torch.randn(batch + body.orientation_shape, generator=generator,
                                device=pos.device, dtype=pos.dtype)
        pos, orientation = body.heun_step(channels, advance, pos, orientation, shape_factor,
                                          swim_speed, dt, noise, rot_diffusion, tau_k)
        track()
    return pos, body.normalise(orientation)


def integrate_point_interval_fused(
    flow: StochasticFlow3D,
    flow_index: torch.Tensor,
    advance: Callable[[], None],
    track: Callable[[], None],
    pos: torch.Tensor,
    orientation: torch.Tensor,
    shape_factor: torch.Tensor,
    swim_speed: float,
    dt: float,
    n_substeps: int,
    rot_diffusion: float,
    tau_k: float,
    generator: torch.Generator,
) -> tuple[torch.Tensor, torch.Tensor]:
    r""":func:`integrate_point_interval` of the 3D body in the 3D stochastic flow by the fused
    kernel (:func:`~swimrl.physics.integrator.integrate_interval_3d_fused`): the flow is
    advanced through the interval first (its coefficients at the $K + 1$ step times kept,
    ``track()`` after each advance), the rotational noise of each step drawn just before that
    step's advance, as the eager loop draws them (one generator: the same numbers in the same
    order). ``flow_index`` ``(F S,)``: each swimmer's flow. Returns ``(F S, 3)`` each."""
    d_r = rot_diffusion / tau_k
    path = [flow.coeffs.clone()]
    noise = []
    for _ in range(n_substeps):
        if d_r > 0:
            noise.append(torch.randn(orientation.shape, generator=generator,
                                     device=pos.device, dtype=pos.dtype))
        advance()
        path.append(flow.coeffs.clone())
        track()
    # a fixed basis is one row for every flow
    rows = flow_index if flow.wavevectors.shape[0] > 1 else flow_index * 0
    return integrate_interval_3d_fused(
        flow.wavevectors, flow.table, torch.stack(path), rows, flow_index,
        pos.reshape(-1, 3), orientation.reshape(-1, 3), shape_factor.reshape(-1),
        torch.stack(noise) if noise else None, flow.n_waves, swim_speed, dt, d_r)
