"""Flows by name (the registry) and swimmers in flows evaluated at points, 2D and 3D
(:class:`swimrl.env.PointSwimmerEnv`): the 2D limit of the 3D env, the Jeffery rotation in a
linear flow, the 3D signals and STO through the env, targets, trajectories, bad input."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest
import torch
from omegaconf import OmegaConf

from swimrl.config import eval_config, flow_spec
from swimrl.env import EnvParams, PointSwimmerEnv, build_env
from swimrl.errors import ConfigError
from swimrl.flows.analytic import LinearFlow, LinearSpec
from swimrl.flows.build import build_flow
from swimrl.flows.entry import FlowEntry
from swimrl.flows.registry import flow_dimension, flow_entry, flow_names, register_flow
from swimrl.flows.stochastic import StochasticSpec
from swimrl.flows.stochastic3d import Stochastic3DSpec
from swimrl.physics.body3d import SIGNAL_NAMES_3D
from swimrl.runtime import Runtime

CPU = Runtime.from_names("cpu", "float64", 1)
SHORT = {"duration": 0.4, "update_interval": 0.1, "dt": 0.01}


def test_every_flow_is_registered_with_its_dimension():
    names = flow_names()
    assert {"stochastic", "dns_replay", "dns", "stochastic3d", "linear", "abc",
            "taylor_green"} <= set(names)
    assert [flow_dimension(n) for n in ("stochastic", "dns", "stochastic3d", "abc",
                                        "taylor_green")] == [2, 2, 3, 3, 2]
    assert flow_dimension(LinearSpec(((0.0, 1.0), (0.0, 0.0)))) == 2
    assert flow_dimension({"name": "linear", "gradient": [[0, 1, 0], [0, 0, 0], [0, 0, 0]]}) == 3
    with pytest.raises(ConfigError, match=r"^flow.name='vortex' is invalid: allowed "):
        flow_entry("vortex")


def test_a_new_flow_is_one_registration(monkeypatch):
    """A flow registered by its own module is built by ``build_flow`` and mapped from its
    ``flow`` node by ``config.flow_spec`` with no edit to either."""

    @dataclass(frozen=True)
    class UniformSpec:
        speed: float
        name: str = "uniform_test"

    class Uniform(LinearFlow):
        def sample(self, pos, flows=None):
            u, grad = super().sample(pos, flows)
            return u + self.speed, grad

    def build(spec, n, device, dtype, generator, interval, duration):
        flow = Uniform(((0.0, 1.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), n, device, dtype)
        flow.speed = spec.speed
        return flow

    monkeypatch.setattr("swimrl.flows.registry._ENTRIES", dict(
        __import__("swimrl.flows.registry", fromlist=["_ENTRIES"])._ENTRIES))
    register_flow(FlowEntry("uniform_test", UniformSpec, build, 3))
    spec = flow_spec(OmegaConf.create({"name": "uniform_test", "speed": 0.5}), CPU)
    assert spec == UniformSpec(0.5)
    env = build_env(spec, EnvParams(**SHORT, signals=SIGNAL_NAMES_3D), CPU, 2, 3, seed=0)
    assert isinstance(env, PointSwimmerEnv) and env.dim == 3
    assert env.rollout(4, break_when_any_done=False)["next", "reward"].shape == (2, 3, 4, 1)


def test_the_3d_env_in_a_plane_is_the_2d_env():
    """Swimmers started in the x-y plane of a planar 3D linear flow stay in it and follow the
    2D point env's swimmers (the same flow as a 2x2 gradient) to round-off; the 3D signals
    are the 2D ones as signals3d's docstring states."""
    a2 = ((0.3, 1.1), (-0.4, -0.3))
    a3 = ((0.3, 1.1, 0.0), (-0.4, -0.3, 0.0), (0.0, 0.0, 0.0))
    env2 = build_env(LinearSpec(a2), EnvParams(**SHORT), CPU, 1, 6, seed=1)
    env3 = build_env(LinearSpec(a3), EnvParams(**SHORT, signals=SIGNAL_NAMES_3D), CPU,
                     1, 6, seed=1)
    env2.reset()
    env3.reset()
    theta = torch.linspace(0.1, 6.0, 6, dtype=torch.float64).view(1, 6)
    start = torch.randn(1, 6, 2, dtype=torch.float64, generator=torch.Generator().manual_seed(3))
    env2.theta.copy_(theta)
    env2.pos.copy_(start)
    env2.start_pos.copy_(start)
    env3.orientation.copy_(torch.stack((theta.cos(), theta.sin(), 0 * theta), -1))
    env3.pos.copy_(torch.cat((start, torch.zeros(1, 6, 1, dtype=torch.float64)), -1))
    env3.start_pos.copy_(env3.pos)
    lam = torch.tensor([0.9, -0.5, 0.0, 0.3, -0.98, 0.7], dtype=torch.float64).view(1, 6, 1)
    for _ in range(3):
        out2 = env2.step(env2._observe().set("action", lam))["next"]
        out3 = env3.step(env3._observe().set("action", lam))["next"]
    n3 = env3.orientation
    torch.testing.assert_close(n3[..., 2], torch.zeros_like(n3[..., 2]), atol=1e-14, rtol=0)
    torch.testing.assert_close(env3.pos[..., :2], env2.pos, atol=1e-12, rtol=0)
    torch.testing.assert_close(torch.atan2(n3[..., 1], n3[..., 0]).remainder(2 * math.pi),
                               env2.theta, atol=1e-12, rtol=0)
    torch.testing.assert_close(out3["reward"], out2["reward"], atol=1e-12, rtol=0)
    s2, s3 = out2["signals"], out3["signals"]
    sign = -torch.sign(s2[..., 1])                       # p1 = -sign(n_theta) p
    torch.testing.assert_close(s3[..., 0], s2[..., 0], atol=1e-12, rtol=0)      # n_r
    torch.testing.assert_close(s3[..., 1], s2[..., 2], atol=1e-12, rtol=0)      # S_nn
    torch.testing.assert_close(s3[..., 2], sign * s2[..., 3], atol=1e-12, rtol=0)  # S_np1
    torch.testing.assert_close(s3[..., 6], sign * s2[..., 4], atol=1e-12, rtol=0)  # omega_p2


def test_pure_rotation_turns_the_orientation_at_half_the_vorticity():
    """``A`` antisymmetric (vorticity ``omega = 2 w`` along z): ``n`` turns at ``w`` for any
    ``Lambda``, exactly (Heun is exact for a rotation at constant rate up to O(dt^3) per
    step; 40 steps of 0.01/w)."""
    w = 1.0
    spec = LinearSpec(((0.0, -w, 0.0), (w, 0.0, 0.0), (0.0, 0.0, 0.0)))
    params = EnvParams(**SHORT, swim_speed=1e-9, signals=SIGNAL_NAMES_3D)
    env = build_env(spec, params, CPU, 1, 5, seed=2)
    td = env.reset()
    n0 = env.orientation.clone()
    for _ in range(4):
        td = env.step(td.set("action", torch.full((1, 5, 1), 0.8, dtype=torch.float64)))["next"]
    t = 0.4 * env.tau_k
    c, s = math.cos(w * t), math.sin(w * t)
    rot = torch.tensor([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], dtype=torch.float64)
    torch.testing.assert_close(env.orientation, n0 @ rot.T, atol=1e-6, rtol=0)


def test_3d_stochastic_env_signals_sto_and_bound():
    """In the 3D stochastic flow: seven signals; the env's STO actor is ``Lambda_max
    sign(S_np1)`` of them; a whole short episode stays within ``(v_s + max|u|) t``."""
    from swimrl.policies.baselines import StrategySpec, build_strategy

    params = EnvParams(**SHORT, signals=SIGNAL_NAMES_3D)
    env = build_env(Stochastic3DSpec(kubo=1.0), params, CPU, 3, 8, seed=4)
    actor = build_strategy(StrategySpec("sto"), env.action_spec_unbatched)
    td = env.rollout(params.n_decisions, actor)
    assert td["signals"].shape == (3, 8, 4, 7)
    s_np1 = td["signals"][..., SIGNAL_NAMES_3D.index("S_np1")]
    torch.testing.assert_close(td["action"][..., 0], 0.98 * torch.sign(s_np1))
    assert bool((env.max_flow_speed > 0).all())
    env.check_displacement()
    env.pos[0, 0] += 1e3
    with pytest.raises(Exception, match="impossible result"):
        env.check_displacement()


def test_3d_target_task_freezes_arrived_swimmers():
    """``task=target`` in 3D: targets at distance ``D`` in random directions; an arrived
    swimmer keeps its position and orientation."""
    from swimrl.task import TaskSpec

    params = EnvParams(**SHORT, signals=SIGNAL_NAMES_3D,
                       task=TaskSpec("target", distance=0.05, arrival_radius=0.04))
    env = build_env(Stochastic3DSpec(kubo=1.0), params, CPU, 2, 16, seed=5)
    td = env.reset()
    torch.testing.assert_close(env.target.norm(dim=-1), torch.full((2, 16), 0.05,
                                                                   dtype=torch.float64))
    for _ in range(4):
        before = (env.pos.clone(), env.orientation.clone(), env.arrived.clone())
        td = env.step(td.set("action", torch.zeros(2, 16, 1, dtype=torch.float64)))["next"]
        was = before[2]
        torch.testing.assert_close(env.pos[was], before[0][was])
        torch.testing.assert_close(env.orientation[was], before[1][was])
    assert bool(env.arrived.any())


def test_build_flow_dispatches_by_name():
    flow = build_flow(Stochastic3DSpec(kubo=10.0), 2, torch.device("cpu"), torch.float32,
                      torch.Generator().manual_seed(0), 0.1, 1.0)
    assert flow.dim == 3 and flow.n_flows == 2
    grid = build_flow(StochasticSpec(kubo=10.0, n_grid=16, spacing=0.5), 1,
                      torch.device("cpu"), torch.float32, torch.Generator().manual_seed(0),
                      0.1, 1.0)
    assert grid.basis.shape == (1, 16, 16, 5, 5)


SMALL_3D = ["flow=stochastic3d", "episode.duration=0.5", "eval.n_flows=2",
            "eval.n_swimmers=6", "eval.flows_per_batch=2", "threads=1", "eval.progress=false"]


@pytest.mark.parametrize(("override", "key"), [
    ("signals.names=[n_r,n_theta]", "signals.names"),
    ("signals=nth_snp", "signals.names"),
    ("strategy=minimal", "strategy=minimal"),
    ("flow.n_waves=0", "flow.n_waves"),
    ("flow.basis=grid", "flow.basis"),
])
def test_3d_bad_input_names_the_key(compose_cfg, override, key):
    cfg = compose_cfg(SMALL_3D + override.split())
    with pytest.raises(ConfigError) as err:
        eval_config(cfg)
    assert key in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(("flow", "override", "key"), [
    ("linear", "flow.gradient=[[0,0],[0,0]]", "flow.gradient"),
    ("linear", "flow.gradient=[[1,0],[0,1]]", "flow.gradient"),
    ("linear", "flow.gradient=[[1,0,0],[0,1]]", "flow.gradient"),
    ("abc", "flow.terms=[[1,1,1,0]]", "flow.terms"),
    ("abc", "flow.modulation=.nan", "flow.modulation"),
    ("abc", "kernel=fused", "kernel"),  # fused: flow=stochastic3d (and the 2D grids) only
    ("taylor_green", "flow.wavenumber=-1", "flow.wavenumber"),
])
def test_analytic_flow_bad_input(compose_cfg, flow, override, key):
    cfg = compose_cfg([f"flow={flow}", override])
    with pytest.raises(ConfigError) as err:
        eval_config(cfg)
    assert key in str(err.value) and "\n" not in str(err.value)


def test_signals_all_is_the_flows_dimensions_set(compose_cfg):
    assert list(compose_cfg(["flow=stochastic3d"]).signals.names) == list(SIGNAL_NAMES_3D)
    assert list(compose_cfg([]).signals.names) == ["n_r", "n_theta", "S_nn", "S_np", "omega"]
    assert list(compose_cfg(["flow=taylor_green"]).signals.names)[1] == "n_theta"


def test_swimrl_eval_3d_writes_trajectories(tmp_path):
    """``swimrl-eval flow=stochastic3d strategy=sto`` with ``eval.record``: the 3D positions and
    orientations of the evaluation's own swimmers; ``R_hat`` of a recorded swimmer is its
    ``|x(T) - x_0| / (v_s T)``."""
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "swimrl.cli.eval", *SMALL_3D, "strategy=sto", "flow.kubo=10",
           "eval.record=2", f"hydra.run.dir={out}"]
    subprocess.run(cmd, check=True, capture_output=True, text=True, timeout=300)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["config"]["flow"]["name"] == "stochastic3d"
    with np.load(out / "trajectories.npz") as z:
        pos, n = z["position"], z["orientation"]
        assert pos.shape == (2, 1, 2, 6, 3) and n.shape == (2, 1, 2, 6, 3)
        np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-5)
        assert list(z["signal_names"]) == list(SIGNAL_NAMES_3D)
        r = np.linalg.norm(pos[..., -1, :] - pos[..., 0, :], axis=-1) / z["reference_distance"]
        np.testing.assert_allclose(r, z["R_hat"], rtol=1e-5)


def test_sto_amplitude_family():
    """``sto(+a,-b)``: STO's sign choice with the prolate amplitude ``a`` and the oblate ``-b``;
    ``(L, L)`` is plain STO at ``Lambda_max = L``; 2D and 3D; bad pairs named in one line."""
    from torchrl.data import Bounded

    from swimrl.evaluation.compare import strategy_variants
    from swimrl.policies.baselines import ShortTimeOptimal, StrategyLabel, StrategySpec

    sig = torch.randn(1000, 5, generator=torch.Generator().manual_seed(0))
    sto = ShortTimeOptimal(0.98)(sig)
    torch.testing.assert_close(ShortTimeOptimal(0.98, (0.98, 0.98))(sig), sto)
    torch.testing.assert_close(ShortTimeOptimal(0.98, (0.5, 0.5))(sig), sto * (0.5 / 0.98))
    asym = ShortTimeOptimal(0.98, (0.9, 0.2))(sig)
    torch.testing.assert_close(asym, torch.where(sto > 0, 0.9, -0.2))
    sig3 = torch.randn(1000, 7, generator=torch.Generator().manual_seed(1))
    lam3 = ShortTimeOptimal(0.98, (0.9, 0.2))(sig3)[..., 0]
    torch.testing.assert_close(lam3, torch.where(sig3[:, 2] > 0, 0.9, -0.2))
    variants = strategy_variants(["sto"], sto_amplitudes=[[0.98, 0.98], [0.9, 0.2]])
    assert [v.label for v in variants] == ["sto(+0.98,-0.98)", "sto(+0.90,-0.20)"]
    assert StrategyLabel.parse("sto(+0.90,-0.20)").numbers == (0.9, -0.2)
    spec = Bounded(-0.5, 0.5, (1,))
    from swimrl.policies.baselines import build_strategy
    with pytest.raises(ConfigError, match="compare.sto_amplitudes"):
        StrategySpec("sto", amplitudes=(0.9, 0.2)).check_bound(0.5)
    with pytest.raises(ConfigError, match="compare.sto_amplitudes"):
        StrategySpec("sto", amplitudes=(0.9,))
    with pytest.raises(ConfigError, match="compare.sto_amplitudes"):
        StrategySpec("naive", shape_factor=0.5, amplitudes=(0.9, 0.2))
    assert build_strategy(StrategySpec("sto", amplitudes=(0.4, 0.1)), spec) is not None
