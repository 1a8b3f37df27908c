"""Impossible results are refused: the displacement bound ``|x(T) - x_0| <= (v_s + max|u|) T``.

The bound holds exactly for the integrated dynamics (bilinear interpolation and the Heun
average are convex combinations of node velocities), so a violation means a doctored or
corrupted flow or state, never physics.
"""

from __future__ import annotations

import pytest
import torch

from swimrl.errors import IntegrityError
from swimrl.evaluation.rollout import run_episodes
from swimrl.flows.base import max_speed
from swimrl.policies.baselines import ShortTimeOptimal, as_actor

from .test_env import small_env


def test_speed_bound_covers_the_node_speeds_along_the_path():
    env = small_env(n_flows=3, kubo=0.1)
    env.reset()
    flow = env.flow
    coeffs0 = flow.coeffs.clone()
    path = flow.coefficient_path(10, env.dt)
    bound = flow.speed_bound(path)
    exact = torch.stack([
        max_speed(torch.einsum("fm,fyxmc->fyxc", c, flow.basis).unsqueeze(-2))[..., 0]
        for c in path
    ]).amax(0)
    assert torch.equal(path[0], coeffs0)
    assert torch.all(bound >= exact * (1 - 1e-6))
    assert torch.all(bound <= exact * flow.n_basis)  # triangle inequality: at most M x


def test_honest_episode_passes_and_records_the_flow_speed():
    env = small_env(n_flows=2, n_swimmers=16, kubo=1.0)
    r_hat = run_episodes(env, as_actor(ShortTimeOptimal(0.98)))
    env.check_displacement()
    assert torch.all(env.max_flow_speed > 0)
    # the realised R_hat sits below its bound 1 + U_f / v_s
    assert torch.all(r_hat <= 1 + env.max_flow_speed.unsqueeze(1) / env.swim_speed)


def test_doctored_flow_is_refused():
    env = small_env(n_flows=2, n_swimmers=16, kubo=1.0)

    def doctor(i, td):
        if i == 0:  # velocities that the recorded speed bound does not know of
            env.flow.basis *= 1e4

    run = run_episodes(env, as_actor(ShortTimeOptimal(0.98)), on_decision=doctor)
    assert torch.isfinite(run).all()
    with pytest.raises(IntegrityError, match="impossible result: swimmer .* beyond"):
        env.check_displacement()


@pytest.mark.parametrize("value", [1e17, float("nan")])
def test_doctored_state_is_refused(value):
    env = small_env(n_flows=2, n_swimmers=4)
    run_episodes(env, as_actor(ShortTimeOptimal(0.98)))
    env.pos[1, 2, 0] = value
    with pytest.raises(IntegrityError, match="swimmer 2 of flow 1"):
        env.check_displacement()
