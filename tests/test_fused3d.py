"""``kernel=fused`` in the 3D stochastic flow (issue 62, item 6): the fused C++ kernel of the
decision interval (``swimrl/physics/kernels/heun3d_cpu.cpp``) against the eager and compiled
paths of :class:`~swimrl.env.PointSwimmerEnv` from the same state (positions, orientations,
image counts, the flow's clock, coefficients and speed bound), at Ku = 10 and 1, float32 and
float64, redrawn and fixed bases, with and without rotational noise; against
:func:`~swimrl.physics.swimmer3d.heun_step_3d` directly for swimmers in any order and a mode
count that is no multiple of the kernel's padding; STO's R̂ over a short episode; bad input in
one line. The kernel's build (~30-60 s once, then cached) is not part of these timings."""

from __future__ import annotations

import pytest
import torch

from swimrl.env import EnvParams, PointSwimmerEnv
from swimrl.errors import ConfigError
from swimrl.flows.analytic import ABCFlow
from swimrl.flows.stochastic3d import StochasticFlow3D, mode_sum
from swimrl.physics.body3d import SIGNAL_NAMES_3D
from swimrl.physics.integrator import integrate_interval_3d_fused
from swimrl.physics.kernels import load_cpu_kernel_3d
from swimrl.physics.swimmer3d import channels_from_gradient, heun_step_3d

#: Float32 round-off of one interval: positions of size ~30 (ulp 2e-6) and unit vectors.
TOL = {torch.float32: {"pos": 2e-5, "n": 2e-6}, torch.float64: {"pos": 1e-12, "n": 1e-13}}


@pytest.fixture(scope="module", autouse=True)
def kernel():
    ext = load_cpu_kernel_3d()
    if ext is None:
        pytest.skip("no C++ toolchain: the fused 3D kernel cannot be built")
    return ext


def make_env(kernel: str, dtype: torch.dtype, kubo: float, basis: str = "redrawn",
             rot_diffusion: float = 0.0, n_flows: int = 3, n_swimmers: int = 4,
             seed: int = 11, duration: float | None = None) -> PointSwimmerEnv:
    gen = torch.Generator().manual_seed(seed)
    flow = StochasticFlow3D(n_flows, kubo, dtype=dtype, generator=gen, basis=basis)
    extra = {} if duration is None else {"duration": duration}
    params = EnvParams(signals=SIGNAL_NAMES_3D, rot_diffusion=rot_diffusion, **extra)
    return PointSwimmerEnv(flow, n_swimmers, params, generator=gen, kernel=kernel)


def one_interval(kernel: str, dtype: torch.dtype, kubo: float, **kw) -> PointSwimmerEnv:
    """One decision interval from the seed's start, positions spread over ``[0, 30)^3``,
    ``Lambda`` across ``[-0.98, 0.98]``."""
    env = make_env(kernel, dtype, kubo, **kw)
    env.reset()
    env.pos.mul_(3.0)
    env.start_pos.copy_(env.pos)
    lam = torch.linspace(-0.98, 0.98, env.pos.shape[0] * env.pos.shape[1], dtype=dtype)
    env.integrate(lam)
    return env


def assert_same_interval(a: PointSwimmerEnv, b: PointSwimmerEnv) -> dict[str, float]:
    tol = TOL[a.pos.dtype]
    torch.testing.assert_close(a.pos, b.pos, rtol=0, atol=tol["pos"])
    torch.testing.assert_close(a.orientation, b.orientation, rtol=0, atol=tol["n"])
    assert torch.equal(a.image, b.image) and not a.image.any()  # unbounded flow: no images
    # the flow's clock, coefficients (same random numbers, same order) and speed bound
    assert torch.equal(a.flow.time, b.flow.time) and bool((a.flow.time > 0).all())
    assert torch.equal(a.flow.coeffs, b.flow.coeffs)
    assert torch.equal(a.max_flow_speed, b.max_flow_speed)
    norm = a.orientation.norm(dim=-1)
    torch.testing.assert_close(norm, torch.ones_like(norm), rtol=0, atol=4 * tol["n"])
    return {"pos": (a.pos - b.pos).abs().max().item(),
            "n": (a.orientation - b.orientation).abs().max().item()}


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64], ids=["f32", "f64"])
@pytest.mark.parametrize("kubo", [10.0, 1.0])
@pytest.mark.parametrize(("basis", "rot_diffusion"), [("redrawn", 0.0), ("fixed", 0.0),
                                                      ("redrawn", 0.5)])
def test_one_interval_equals_the_eager_one(dtype, kubo, basis, rot_diffusion):
    """Same state, one interval: the fused kernel gives the eager positions and orientations
    to round-off, the flow advanced through the same coefficients between the stages."""
    kw = {"basis": basis, "rot_diffusion": rot_diffusion}
    fused = one_interval("fused", dtype, kubo, **kw)
    eager = one_interval("eager", dtype, kubo, **kw)
    assert fused.flow.time[0].item() == pytest.approx(0.1 * fused.tau_k)
    assert_same_interval(fused, eager)


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64], ids=["f32", "f64"])
def test_one_interval_equals_the_compiled_one(dtype):
    """Same state, one interval, Ku = 10 and 1: fused = ``kernel=compiled`` (the compiled mode
    sum) to round-off. Both Kubo numbers share one compilation per dtype."""
    for kubo in (10.0, 1.0):
        fused = one_interval("fused", dtype, kubo)
        compiled = one_interval("compiled", dtype, kubo)
        assert_same_interval(fused, compiled)


def test_kernel_against_heun_step_3d_in_any_order():
    """The kernel's own contract: swimmers in any order (runs of one flow broken up), rows
    and flows differing (a fixed basis), ``M K`` = 15 modes (not a multiple of the padding),
    far-out positions; against ``K`` steps of :func:`heun_step_3d` on the mode sum."""
    dtype, k_steps, n_flows = torch.float64, 7, 3
    gen = torch.Generator().manual_seed(3)
    flow = StochasticFlow3D(n_flows, 1.0, n_modes=3, n_waves=5, dtype=dtype, generator=gen,
                            basis="fixed")
    path = [flow.coeffs.clone()]
    for _ in range(k_steps):
        flow.advance(0.02)
        path.append(flow.coeffs.clone())
    path = torch.stack(path)
    flows = torch.tensor([2, 0, 1, 0, 2, 2, 1, 0])
    pos = 40 * torch.randn(8, 3, generator=gen, dtype=dtype)
    n = torch.randn(8, 3, generator=gen, dtype=dtype)
    n = n / n.norm(dim=-1, keepdim=True)
    lam = torch.linspace(-0.9, 0.9, 8, dtype=dtype)
    noise = torch.randn(k_steps, 8, 3, generator=gen, dtype=dtype)
    rows = torch.zeros_like(flows)
    before = (pos.clone(), n.clone())
    got = integrate_interval_3d_fused(flow.wavevectors, flow.table, path, rows, flows, pos, n,
                                      lam, noise, flow.n_waves, 0.7, 0.02, 0.3)
    stage = [0]

    def sample(p):  # (P, 3): each swimmer alone in its flow
        u_a = mode_sum(p.unsqueeze(1), flow.wavevectors, flow.table,
                       path[stage[0]][flows], flow.n_waves)[:, 0]
        return channels_from_gradient(u_a[:, :3], u_a[:, 3:].unflatten(-1, (3, 3)))

    def advance():
        stage[0] += 1

    x, m = pos, n
    for k in range(k_steps):
        x, m = heun_step_3d(sample, advance, x, m, lam, 0.7, 0.02, noise[k], 0.3)
    torch.testing.assert_close(got[0], x, rtol=0, atol=1e-11)
    torch.testing.assert_close(got[1], m, rtol=0, atol=1e-13)
    assert torch.equal(pos, before[0]) and torch.equal(n, before[1])  # inputs kept


def test_threads_split_the_swimmers_without_changing_them():
    """With several torch threads the kernel splits the swimmers over plain threads (>= 256
    swimmers each): the same numbers, bit for bit."""
    out = {}
    threads = torch.get_num_threads()
    try:
        for n in (1, 2):
            torch.set_num_threads(n)
            env = one_interval("fused", torch.float32, 10.0, n_flows=8, n_swimmers=80)
            out[n] = (env.pos.clone(), env.orientation.clone())
    finally:
        torch.set_num_threads(threads)
    assert torch.equal(out[1][0], out[2][0]) and torch.equal(out[1][1], out[2][1])


def test_sto_episode_r_hat_agrees_within_sem():
    """STO over a short episode (5 tau_K, 4 flows x 50 swimmers, Ku = 10): R̂ by the fused
    kernel equals the eager one's within the standard error (the trajectories agree to
    round-off until a sign choice of STO at S_np1 ~ 0 tells them apart)."""
    from swimrl.policies.baselines import StrategySpec, build_strategy

    r_hat = {}
    for kernel in ("fused", "eager"):
        env = make_env(kernel, torch.float32, 10.0, n_flows=4, n_swimmers=50, seed=2,
                       duration=5.0)
        actor = build_strategy(StrategySpec("sto"), env.action_spec_unbatched)
        td = env.rollout(env.params.n_decisions, actor)
        r_hat[kernel] = env.score(td[..., -1]["next"]).flatten()
        env.check_displacement()
    sem = r_hat["eager"].std() / r_hat["eager"].numel() ** 0.5
    diff = (r_hat["fused"].mean() - r_hat["eager"].mean()).abs()
    assert diff <= sem, (diff, sem)
    assert (r_hat["fused"] - r_hat["eager"]).abs().median() < 1e-3


def test_bad_input_is_one_line():
    """``fused`` only where it exists: the 3D stochastic flow on the CPU (float32 or float64);
    an analytic flow or another device is refused naming ``kernel``, in one line."""
    params = EnvParams(signals=SIGNAL_NAMES_3D)
    with pytest.raises(ConfigError, match="kernel") as err:
        PointSwimmerEnv(ABCFlow(1), 2, params, kernel="fused")
    assert "\n" not in str(err.value) and "stochastic3d" in str(err.value)
    env = make_env("fused", torch.float32, 10.0)
    with pytest.raises(ConfigError, match="kernel") as err:
        env._select_kernel("fused", torch.device("cuda"))
    assert "\n" not in str(err.value) and "device=cuda" in str(err.value)
    with pytest.raises(ConfigError, match="kernel"):
        make_env("fast", torch.float32, 10.0)
    flow = StochasticFlow3D(1, 10.0)
    ones = torch.ones(2, 3)
    with pytest.raises(RuntimeError, match="fused 3D kernel") as err:  # the kernel's own checks
        integrate_interval_3d_fused(flow.wavevectors, flow.table, flow.coeffs[None],
                                    torch.tensor([0, 1]), torch.tensor([0, 0]), ones, ones,
                                    torch.zeros(2), None, flow.n_waves, 0.7, 0.02)
    assert "out of range" in str(err.value).splitlines()[0]


def test_config_accepts_fused_for_stochastic3d_only(compose_cfg):
    from swimrl.config import eval_config

    small = ["episode.duration=0.5", "eval.n_flows=2", "eval.n_swimmers=6",
             "eval.flows_per_batch=2", "threads=1", "eval.progress=false", "kernel=fused"]
    assert eval_config(compose_cfg(["flow=stochastic3d", *small])).setup.runtime.kernel == "fused"
    with pytest.raises(ConfigError, match="kernel") as err:
        eval_config(compose_cfg(["flow=abc", *small]))
    assert "\n" not in str(err.value)
