"""Gyrotaxis (swimrl.physics.gyrotaxis), the steering actuation and task=vertical, against
analytic results: relaxation at rest, the 2D limit of the 3D swimmer, the fixed points of a
trapped swimmer in a Taylor-Green cell, and the bad-input lines."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from omegaconf import OmegaConf

from swimrl.actuation import ActuationSpec
from swimrl.analysis.trapping import (
    critical_psi,
    fixed_points,
    jacobian,
    rhs,
    stable_fixed_point,
)
from swimrl.config import env_params, gyrotaxis_numbers
from swimrl.env import EnvParams, SwimmerEnv, build_env
from swimrl.env.actuation import controls
from swimrl.errors import ConfigError
from swimrl.flows.analytic import TaylorGreenSpec
from swimrl.flows.stochastic import StochasticFlow
from swimrl.flows.stochastic3d import Stochastic3DSpec
from swimrl.physics.body import body
from swimrl.physics.body2d import twelve_states
from swimrl.physics.body3d import SIGNAL_NAMES_3D
from swimrl.physics.gyrotaxis import GyrotacticBody, axis_directions
from swimrl.runtime import Runtime
from swimrl.task import TaskSpec

F64 = Runtime.from_names("cpu", "float64", 1)


def _relax(b, orientation, bottom_heaviness, t_end, dt=1e-3):
    """Heun steps of a gyrotactic body at rest (no flow, v_s = 0) until ``t_end``."""
    n_ch = b.n_channels
    pos = torch.zeros(*orientation.shape[:1], b.dim, dtype=torch.float64)

    def channels(p):
        return torch.zeros(*p.shape[:-1], n_ch, dtype=torch.float64)

    lam = torch.zeros(orientation.shape[0], dtype=torch.float64)
    for _ in range(round(t_end / dt)):
        pos, orientation = b.heun_step(channels, lambda: None, pos, orientation, lam, 0.0, dt,
                                       None, 0.0, 1.0)
    return orientation


def test_relaxation_at_rest_2d():
    """dphi/dt = -sin(phi)/(2B): tan(phi/2) = tan(phi0/2) exp(-t/(2B)), phi from the vertical."""
    B, t = 0.7, 1.3
    g = GyrotacticBody(body(2), B)
    phi0 = torch.tensor([0.3, 1.2, 2.5, -2.0], dtype=torch.float64)
    theta = _relax(g, phi0 + math.pi / 2, B, t)
    expect = 2 * torch.atan(torch.tan(phi0 / 2) * math.exp(-t / (2 * B)))
    assert torch.allclose(theta - math.pi / 2, expect, atol=1e-8)
    # without the torque nothing turns (the check can fail)
    assert not torch.allclose(phi0, expect, atol=1e-2)


def test_relaxation_at_rest_3d_and_the_2d_limit():
    """The same law for the angle from z of the 3D swimmer, about any horizontal axis."""
    B, t = 0.4, 0.9
    g = GyrotacticBody(body(3), B)
    phi0 = torch.tensor([0.2, 1.0, 2.9], dtype=torch.float64)
    az = torch.tensor([0.0, 1.1, -2.3], dtype=torch.float64)
    n0 = torch.stack((torch.sin(phi0) * torch.cos(az), torch.sin(phi0) * torch.sin(az),
                      torch.cos(phi0)), -1)
    n = _relax(g, n0, B, t)
    phi = torch.acos(n[:, 2].clamp(-1, 1))
    expect = 2 * torch.atan(torch.tan(phi0 / 2) * math.exp(-t / (2 * B)))
    assert torch.allclose(phi, expect, atol=1e-8)
    assert torch.allclose(torch.atan2(n[:, 1], n[:, 0]), az, atol=1e-10)  # no azimuthal turn


def test_3d_swimmer_in_a_plane_is_the_2d_swimmer():
    """A planar flow in (x, z), the 3D swimmer's n in that plane and k = z: its trajectory is
    the 2D swimmer's in (x, y) with k = y (flow, torque and shape term all in the plane)."""
    a2 = torch.tensor([[0.3, -0.8], [0.5, -0.3]], dtype=torch.float64)
    a3 = torch.zeros(3, 3, dtype=torch.float64)
    a3[0, 0], a3[0, 2], a3[2, 0], a3[2, 2] = a2[0, 0], a2[0, 1], a2[1, 0], a2[1, 1]
    b2, b3 = GyrotacticBody(body(2), 0.6), GyrotacticBody(body(3), 0.6)
    pos2 = torch.tensor([[0.2, -0.4], [1.0, 0.5]], dtype=torch.float64)
    theta = torch.tensor([0.4, 2.8], dtype=torch.float64)
    pos3 = torch.stack((pos2[:, 0], torch.zeros(2, dtype=torch.float64), pos2[:, 1]), -1)
    n3 = torch.stack((torch.cos(theta), torch.zeros(2, dtype=torch.float64), torch.sin(theta)),
                     -1)
    lam = torch.tensor([0.9, -0.5], dtype=torch.float64)

    def ch2(p):
        return b2.channels(p @ a2.T, a2.expand(*p.shape[:-1], 2, 2))

    def ch3(p):
        return b3.channels(p @ a3.T, a3.expand(*p.shape[:-1], 3, 3))

    for _ in range(200):
        pos2, theta = b2.heun_step(ch2, lambda: None, pos2, theta, lam, 0.4, 0.01, None, 0, 1)
        pos3, n3 = b3.heun_step(ch3, lambda: None, pos3, n3, lam, 0.4, 0.01, None, 0, 1)
    assert torch.allclose(pos3[:, [0, 2]], pos2, atol=1e-10)
    assert torch.allclose(n3[:, [0, 2]], torch.stack((torch.cos(theta), torch.sin(theta)), -1),
                          atol=1e-10)


def _steer_params(phi, psi, **kw):
    return EnvParams(swim_speed=2 * math.sqrt(2) * phi, bottom_heaviness=psi / 2,
                     actuation=ActuationSpec(name="steer"),
                     signals=("n_r", "n_theta", "omega"), **kw)


def test_trapped_swimmer_sits_at_the_analytic_fixed_point_of_a_taylor_green_cell():
    """The attracting fixed point of the papers' equations (swimrl.analysis.trapping), moved
    to swimrl's lattice (x = x' + pi/2, y = z' + pi/2, n = (sin theta', cos theta')): the
    environment's naive swimmer stays there, and one started beside it returns."""
    phi, psi = 0.3, 1.0
    stable = [p for p in fixed_points(phi, psi)
              if np.linalg.eigvals(jacobian(p, phi, psi)).real.max() < 0]
    assert stable
    x, z, th = stable[0]
    env = build_env(TaylorGreenSpec(), _steer_params(phi, psi, duration=60.0,
                                                     update_interval=0.5,
                                                     task=TaskSpec(name="vertical",
                                                                   burn_in=30.0)),
                    F64, 1, 2, seed=0)
    td = env.reset()
    env.pos[0, 0] = torch.tensor([x + math.pi / 2, z + math.pi / 2])
    env.pos[0, 1] = env.pos[0, 0] + torch.tensor([0.15, -0.1])
    env.start_pos.copy_(env.pos)
    env.orientation[0, :] = math.atan2(math.cos(th), math.sin(th))
    start = env.pos.clone()
    up = torch.zeros(1, 2, 2, dtype=torch.float64)
    up[..., 1] = 1.0
    for _ in range(env.params.n_decisions):
        td.set("action", up)
        td = env.step(td)["next"]
    assert (env.pos[0, 0] - start[0, 0]).norm() < 1e-6
    assert (env.pos[0, 1] - start[0, 0]).norm() < 0.05
    assert env.outcomes()["trapped"].min() == 1


def test_trapping_condition_is_the_eigenvalue_boundary():
    """Phi < 1/2 and Psi < (1 - 4 Phi^2)^-1/2 (derived in docs/physics.md) is where an
    attracting fixed point exists, read from the Jacobian's eigenvalues; every fixed point
    found is one (the right-hand side vanishes)."""
    for phi in (0.1, 0.25, 0.3, 0.4, 0.45):
        ps = critical_psi(phi)
        assert stable_fixed_point(phi, 0.98 * ps) and not stable_fixed_point(phi, 1.02 * ps)
        for p in fixed_points(phi, 0.5 * ps):
            assert np.abs(rhs(p, phi, 0.5 * ps)).max() < 1e-9
    assert not any(stable_fixed_point(phi, psi) for phi in (0.6, 1.0) for psi in (0.1, 1, 3))


def test_vertical_task_reward_score_and_naive_trapping():
    """Rewards sum to the rise; the score is the rise over the window / (v_s (T - T_b));
    naive swimmers at Phi = 0.3, Psi = 1 do not rise (trapped)."""
    p = _steer_params(0.3, 1.0, duration=60.0, update_interval=0.5,
                      task=TaskSpec(name="vertical", burn_in=20.0))
    env = build_env(TaylorGreenSpec(), p, F64, 1, 48, seed=3)
    td = env.reset()
    up = torch.zeros(1, 48, 2, dtype=torch.float64)
    up[..., 1] = 1.0
    total = torch.zeros(1, 48, dtype=torch.float64)
    z_burn = None
    for i in range(p.n_decisions):
        td.set("action", up)
        td = env.step(td)["next"]
        total += td["reward"].squeeze(-1)
        if i + 1 == 40:
            z_burn = td["rise"].squeeze(-1).clone()
    rise = td["rise"].squeeze(-1)
    assert torch.allclose(total, rise, atol=1e-9)
    expect = (rise - z_burn) / (env.swim_speed * 40 * env.tau_k)
    assert torch.allclose(env.score(td), expect, atol=1e-12)
    assert float(env.outcomes()["trapped"].mean()) > 0.9
    assert float(env.score(td).abs().mean()) < 0.1


def test_steering_controls():
    act = ActuationSpec(name="steer", directions="discrete")
    lam, k = controls(act, torch.tensor([[0, 1, 2, 3]]), 0.98, torch.Size([1, 4]), 2,
                      torch.float32)
    assert torch.equal(k[0], axis_directions(2))
    assert torch.equal(axis_directions(2)[1], torch.tensor([0.0, 1.0]))  # index 1: up
    assert torch.equal(lam, torch.zeros(4))
    both = ActuationSpec(name="shape_steer")
    lam, k = controls(both, torch.tensor([[[2.0, 3.0, -4.0]]]), 0.98, torch.Size([1, 1]), 2,
                      torch.float32)
    assert float(lam) == pytest.approx(0.98) and torch.allclose(k, torch.tensor([0.6, -0.8]))


def test_twelve_states():
    # (n_r, n_theta, S_nn, S_np, omega): up & omega > 2/3 -> 8; right (n_theta < 0) & calm -> 5
    sig = torch.tensor([[0.9, 0.1, 0, 0, 1.0], [0.1, -0.9, 0, 0, 0.0],
                        [-0.8, 0.3, 0, 0, -1.0], [0.2, 0.7, 0, 0, 0.5]])
    assert twelve_states(sig).argmax(-1).tolist() == [8, 5, 2, 7]
    assert torch.equal(twelve_states(sig).sum(-1), torch.ones(4))


def test_gyrotaxis_on_a_gridded_flow_runs_eager_and_vanishes_with_infinite_b():
    """On flow=stochastic the torque is integrated by the eager kernel; with B -> infinity the
    gyrotactic swimmer is the plain one (kernel=eager), and with B small it differs."""
    def run(b):
        gen = torch.Generator().manual_seed(1)
        flow = StochasticFlow(1, 1.0, n_grid=16, spacing=0.5, dtype=torch.float64,
                              generator=gen)
        p = EnvParams(duration=1.0, bottom_heaviness=b)
        env = SwimmerEnv(flow, 4, p, generator=gen, kernel="eager")
        td = env.reset()
        for _ in range(5):
            td.set("action", torch.full((1, 4, 1), 0.5, dtype=torch.float64))
            td = env.step(td)["next"]
        return env.orientation.clone()

    plain = run(None)
    assert torch.allclose(run(1e15), plain, atol=1e-12)
    assert not torch.allclose(run(0.05), plain, atol=1e-3)


def test_bad_input_lines():
    with pytest.raises(ConfigError, match=r"swimmer\.bottom_heaviness.*> 0"):
        EnvParams(bottom_heaviness=0.0)
    with pytest.raises(ConfigError, match=r"swimmer\.bottom_heaviness.*> 0"):
        EnvParams(bottom_heaviness=-1.0)
    with pytest.raises(ConfigError, match=r"actuation\.name.*bottom_heaviness"):
        EnvParams(actuation=ActuationSpec(name="steer"))
    with pytest.raises(ConfigError, match=r"actuation\.directions"):
        ActuationSpec(name="shape_steer", directions="discrete")
    with pytest.raises(ConfigError, match=r"task\.burn_in"):
        EnvParams(duration=10.0, task=TaskSpec(name="vertical", burn_in=10.0))
    # a 12-state signal with a 3D flow: one line, before any compute
    p = EnvParams(signals=("state12_0",))
    with pytest.raises(ConfigError, match=r"signals\.names.*state12_0.*3D"):
        build_env(Stochastic3DSpec(kubo=1.0, n_modes=2), p, F64, 1, 2, seed=0)
    # the fused kernels have no torque
    with pytest.raises(ConfigError, match=r"kernel.*gyrotactic"):
        SwimmerEnv(StochasticFlow(1, 1.0, n_grid=16, spacing=0.5), 2,
                   EnvParams(bottom_heaviness=1.0), kernel="fused")
    with pytest.raises(ConfigError, match=r"kernel.*gyrotactic"):
        build_env(Stochastic3DSpec(kubo=1.0, n_modes=2),
                  EnvParams(bottom_heaviness=1.0, signals=SIGNAL_NAMES_3D),
                  Runtime.from_names("cpu", "float32", 1, "fused"), 1, 2, seed=0)
    # Phi and Psi only where they are defined
    with pytest.raises(ConfigError, match=r"swimmer\.phi.*taylor_green"):
        gyrotaxis_numbers(OmegaConf.create({"phi": 0.3, "psi": None}), "stochastic")
    with pytest.raises(ConfigError, match=r"swimmer\.psi.*> 0"):
        gyrotaxis_numbers(OmegaConf.create({"phi": None, "psi": -1}), "taylor_green")


def test_phi_and_psi_set_the_swimmer():
    got = gyrotaxis_numbers(OmegaConf.create({"phi": 0.3, "psi": 1.0}), "taylor_green")
    assert got == pytest.approx({"swim_speed": 0.6 * math.sqrt(2), "bottom_heaviness": 0.5})
    from hydra import compose, initialize_config_module
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose("evaluate", ["flow=taylor_green", "actuation=steer", "task=vertical",
                                   "swimmer.phi=0.3", "swimmer.psi=1"])
    p = env_params(cfg)
    assert p.bottom_heaviness == pytest.approx(0.5) and p.actuation.name == "steer"
    # the swimmer's v_s in flow units is Phi u0 = Phi * 2U (U = flow.amplitude = 1)
    env = build_env(TaylorGreenSpec(), p, F64, 1, 1, seed=0)
    assert env.swim_speed == pytest.approx(0.3 * 2.0)
    assert env.body.bottom_heaviness == pytest.approx(1.0 / 2.0)  # Psi / omega0, omega0 = 2


def test_compiled_point_kernel_integrates_the_torque_as_the_eager_one(compose_cfg):
    """``kernel=compiled`` on a 3D point flow compiles the flow sampler only; a gyrotactic
    swimmer's torque stays in the eager Heun step: over one decision its positions and
    orientations equal the eager kernel's to float32 round-off, and differ from a swimmer
    without the torque."""
    from swimrl.env import PointSwimmerEnv
    from swimrl.flows.stochastic3d import StochasticFlow3D

    def run(kernel, bottom_heaviness):
        over = ["flow=stochastic3d", "episode.duration=1.0"]
        if bottom_heaviness is not None:
            over.append(f"swimmer.bottom_heaviness={bottom_heaviness}")
        params = env_params(compose_cfg(over))
        gen = torch.Generator().manual_seed(5)
        env = PointSwimmerEnv(StochasticFlow3D(2, 10.0, generator=gen), 4, params,
                              generator=gen, kernel=kernel)
        td = env.reset()
        env.step(td.set("action", torch.full((2, 4, 1), 0.5)))
        return env.pos.clone(), env.orientation.clone()

    eager, compiled = run("eager", 0.2), run("compiled", 0.2)
    torch.testing.assert_close(compiled[0], eager[0], rtol=1e-4, atol=1e-5)
    torch.testing.assert_close(compiled[1], eager[1], rtol=1e-4, atol=1e-5)
    plain = run("eager", None)
    assert (eager[1] - plain[1]).abs().max() > 1e-2
