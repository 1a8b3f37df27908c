"""The one builder of environments: it picks the class for the flow (a gridded flow: the core
:class:`~swimrl.env.core.SwimmerEnv`; a flow evaluated at points: the
:class:`~swimrl.env.point.PointSwimmerEnv`) and the swimmer's
:class:`~swimrl.physics.body.Body` for the flow's dimension (:func:`~swimrl.physics.body.body`).
"""

from __future__ import annotations

import torch

from swimrl.env.core import SwimmerEnv
from swimrl.env.params import EnvParams, clock_offsets
from swimrl.env.point import PointSwimmerEnv
from swimrl.flows.build import FlowSpec, build_flow
from swimrl.flows.pointwise import PointFlow
from swimrl.runtime import Runtime


def env_from_flow(flow, n_swimmers: int, params: EnvParams, **kwargs) -> SwimmerEnv:
    """The environment of a flow already built: a :class:`~swimrl.env.core.SwimmerEnv` for a
    :class:`~swimrl.flows.base.GriddedFlow`, a :class:`~swimrl.env.point.PointSwimmerEnv` for
    a :class:`~swimrl.flows.pointwise.PointFlow`, with the body of the flow's dimension
    (``flow.dim``; a gridded flow is 2D; bottom-heavy where ``params.bottom_heaviness`` is
    set: :meth:`~swimrl.env.params.EnvParams.body`). ``kwargs``: the constructor's
    (``generator``, ``kernel``, ``ic_blocks``)."""
    env_cls = PointSwimmerEnv if isinstance(flow, PointFlow) else SwimmerEnv
    return env_cls(flow, n_swimmers, params, body=params.body(getattr(flow, "dim", 2),
                                                              flow.tau_k), **kwargs)


def build_env(
    flow: FlowSpec,
    params: EnvParams,
    runtime: Runtime,
    n_flows: int,
    n_swimmers: int,
    seed: int,
    ic_blocks: int = 1,
    stagger: int = 1,
) -> SwimmerEnv:
    """Environment of ``n_flows x n_swimmers`` swimmers in new realisations of ``flow``;
    all randomness (flows, initial conditions, noise) from ``seed``; ``ic_blocks`` blocks
    of swimmers per flow with identical initial conditions.

    Parameters
    ----------
    flow
        The flow's spec (``flow=X``: :func:`~swimrl.flows.build.build_flow`).
    params
        Swimmer and episode parameters.
    runtime
        Device, dtype and integration kernel (its threads are not applied here).
    n_flows, n_swimmers
        The batch shape.
    seed
        Seeds the one generator of the flows, the initial conditions and the noise.
    ic_blocks
        Blocks of swimmers per flow that start from the same positions and orientations.
    stagger
        Groups of flows whose episodes are offset
        (:meth:`~swimrl.env.core.SwimmerEnv.stagger`; 1: none).

    Returns
    -------
    SwimmerEnv
        The environment (:func:`env_from_flow`), not reset yet (TorchRL's ``reset`` or
        ``rollout`` does it).
    """
    device, dtype = runtime.device, runtime.dtype
    offset = clock_offsets(n_flows, params.n_decisions, stagger, device)
    gen = torch.Generator(device=device).manual_seed(int(seed))
    realisations = build_flow(
        flow, n_flows, device, dtype, gen, params.update_interval, params.duration
    )
    env = env_from_flow(realisations, n_swimmers, params, generator=gen,
                        kernel=runtime.kernel, ic_blocks=ic_blocks)
    env._clock_offset = offset
    return env
