"""The TorchRL environment: specs, reward, resets, determinism, kernels."""

from __future__ import annotations

import pytest
import torch
from torchrl.envs.utils import check_env_specs

from swimrl.config import eval_setup
from swimrl.env import EnvParams, SwimmerEnv, build_env
from swimrl.env.features import observe_flow_for_critic
from swimrl.errors import ConfigError
from swimrl.flows.stochastic import StochasticFlow
from swimrl.policies.baselines import ShortTimeOptimal, as_actor
from swimrl.task import RewardSpec, TaskSpec

from .conftest import SMALL


def small_env(
    n_flows=2, n_swimmers=8, seed=0, kubo=1.0, kernel="eager", dtype=torch.float32, **params
):
    gen = torch.Generator().manual_seed(seed)
    flow = StochasticFlow(n_flows, kubo, n_grid=64, spacing=0.1, dtype=dtype, generator=gen)
    p = EnvParams(**{"duration": 2.0, **params})
    return SwimmerEnv(flow, n_swimmers, p, generator=gen, kernel=kernel)


def test_check_env_specs():
    check_env_specs(small_env())
    check_env_specs(small_env(signals=("n_theta", "S_np")))


def test_reward_telescopes_to_the_final_distance():
    env = small_env(n_swimmers=16)
    td = env.rollout(env.params.n_decisions, as_actor(ShortTimeOptimal(0.98)))
    total = td["next", "reward"].sum(dim=-2)  # sum over time
    final = td["next", "distance"][..., -1, :]
    assert torch.allclose(total, final, atol=1e-4)
    assert td["next", "truncated"][..., -1, :].all()
    assert not td["next", "truncated"][..., :-1, :].any()
    assert not td["next", "terminated"].any()


def test_same_seed_same_episode_different_seed_different():
    def run(seed):
        env = small_env(seed=seed)
        env.set_seed(seed)
        return env.rollout(5, as_actor(ShortTimeOptimal(0.98)))["next", "observation"]

    assert torch.equal(run(3), run(3))
    assert not torch.allclose(run(3), run(4))


def test_partial_reset_restarts_only_the_masked_swimmers_and_flows():
    env = small_env(n_flows=2, n_swimmers=4)
    env.reset()
    env.rand_step()
    basis = env.flow.basis.clone()
    pos = env.pos.clone()
    mask = torch.zeros(2, 4, 1, dtype=torch.bool)
    mask[0] = True  # all swimmers of flow 0
    mask[1, 2] = True  # one swimmer of flow 1
    from tensordict import TensorDict

    td = env.reset(TensorDict({"_reset": mask}, batch_size=[2, 4]))
    assert not torch.equal(env.flow.basis[0], basis[0])  # new realisation for flow 0
    assert torch.equal(env.flow.basis[1], basis[1])  # flow 1 kept
    assert torch.equal(env.pos[1, [0, 1, 3]], pos[1, [0, 1, 3]])
    assert not torch.equal(env.pos[1, 2], pos[1, 2])
    assert td["distance"][mask.squeeze(-1)].abs().max() == 0
    assert (env.step_count[mask.squeeze(-1)] == 0).all()


def test_unbounded_motion_keeps_the_displacement():
    """In still fluid a swimmer goes straight across many periodic boxes: x - x_0 = v_s t n."""
    gen = torch.Generator().manual_seed(0)
    flow = StochasticFlow(1, 1.0, n_grid=16, spacing=0.5, generator=gen)
    env = SwimmerEnv(flow, 64, EnvParams(duration=2.0, swim_speed=20.0), generator=gen)
    td = env.reset()
    flow.basis.zero_()  # still fluid (after the reset, which draws a new realisation)
    theta0 = env.theta.clone()
    for _ in range(env.params.n_decisions):
        td = env.step(td.set("action", torch.zeros(1, 64, 1))).get("next")
    t = env.params.duration * flow.tau_k
    expected = env.swim_speed * t * torch.stack((theta0.cos(), theta0.sin()), -1)
    assert env.reference_distance == pytest.approx(env.swim_speed * t)
    assert expected.norm(dim=-1).min() > 2 * flow.grid.length  # crossed several boxes
    assert torch.all(env.pos >= 0) and torch.all(env.pos < flow.grid.length)
    assert torch.allclose(env.displacement(), expected, atol=1e-4)
    assert torch.allclose(td["distance"].squeeze(-1), expected.norm(dim=-1), atol=1e-4)


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_fused_kernel_matches_eager(dtype):
    outs = []
    for kernel in ("eager", "fused"):
        env = small_env(kernel=kernel, dtype=dtype, rot_diffusion=0.1)
        env.set_seed(7)
        env.reset()
        lam = torch.linspace(-0.98, 0.98, env.batch_size.numel(), dtype=dtype)
        for _ in range(10):
            env.integrate(lam)
        outs.append((env.displacement(), env.theta))
    tol = 1e-12 if dtype == torch.float64 else 2e-5
    assert torch.allclose(outs[0][0], outs[1][0], atol=tol)
    assert torch.allclose(outs[0][1], outs[1][1], atol=tol)


def test_rotational_noise_diffuses_the_orientation():
    """In a still fluid theta performs Brownian motion: <dtheta^2> = 2 D_r t."""
    gen = torch.Generator().manual_seed(0)
    flow = StochasticFlow(1, 1.0, n_grid=16, spacing=0.5, dtype=torch.float64, generator=gen)
    env = SwimmerEnv(flow, 4000, EnvParams(duration=2.0, rot_diffusion=0.5), generator=gen)
    env.reset()
    flow.basis.zero_()  # still fluid
    theta0 = env.theta.clone()
    lam = torch.zeros(4000, dtype=torch.float64)
    unwrapped = torch.zeros_like(theta0)
    for _ in range(10):
        prev = env.theta.clone()
        env.integrate(lam)
        unwrapped += torch.remainder(env.theta - prev + torch.pi, 2 * torch.pi) - torch.pi
    t = 10 * env.params.update_interval * flow.tau_k
    d_r = 0.5 / flow.tau_k
    assert unwrapped.var().item() == pytest.approx(2 * d_r * t, rel=0.1)
    del theta0


def test_build_env_from_config(compose_cfg):
    setup = eval_setup(compose_cfg(SMALL + ["signals=nth_snp"]))
    env = build_env(setup.flow, setup.params, setup.runtime, 2, 3, 0)
    td = env.reset()
    assert td["observation"].shape == (2, 3, 2)
    assert torch.equal(td["observation"], td["signals"][..., [1, 3]])


def test_staggered_episodes_end_and_redraw_one_group_at_a_time():
    """``stagger(G)``: flow ``f``'s first episode is ``(f mod G) floor(N/G)`` decisions
    shorter, so the groups' episodes end (done, then a new realisation of only their flows)
    ``floor(N/G)`` decisions apart; later episodes keep the full length ``N``."""
    from torchrl.envs.utils import step_mdp

    env = small_env(n_flows=4, n_swimmers=3, duration=0.8)  # N = 8 decisions
    n = env.params.n_decisions
    env.stagger(2)  # flows 0, 2: offset 0; flows 1, 3: offset 4
    td = env.reset()
    assert env.flow_step.tolist() == [0, 4, 0, 4]
    ended = []
    for i in range(1, 2 * n + 1):
        td.set("action", env.action_spec.rand())
        basis = env.flow.basis.clone()
        td = env.step(td)
        done = td["next", "done"].squeeze(-1).all(dim=1)
        if done.any():
            ended.append((i, done.nonzero().flatten().tolist()))
        td = step_mdp(td)
        if done.any():  # the collector's partial reset of the done swimmers
            td.set("_reset", done[:, None, None].expand(4, 3, 1).clone())
            td = env.reset(td)
            redrawn = [not torch.equal(env.flow.basis[f], basis[f]) for f in range(4)]
            assert redrawn == done.tolist()
    assert ended == [(4, [1, 3]), (8, [0, 2]), (12, [1, 3]), (16, [0, 2])]
    with pytest.raises(ValueError, match="groups=5"):
        env.stagger(5)


def test_swimming_reward_is_the_distance_reward_less_the_advection():
    """reward.progress=swimming: r_i = v_s T_u (n_r(t_{i-1}) + n_r(t_i)) / 2, on the same
    trajectory as the distance reward; the difference of the two is the advection
    u . e_r integrated over the decision (trapezoid, from the flow's velocity at the swimmers,
    an independent computation; short decisions, swimmers away from their start, the median
    over swimmers: a swimmer back near its start turns e_r within a decision)."""
    envs = [small_env(n_swimmers=16, seed=5, duration=4.0, update_interval=0.02,
                      reward=RewardSpec(progress=p))
            for p in ("distance", "swimming")]
    tds = [env.reset() for env in envs]
    sto = as_actor(ShortTimeOptimal(0.98))
    ref = envs[0]
    t_u = ref.params.update_interval * ref.tau_k
    v_t = ref.decision_length

    def advection() -> torch.Tensor:  # u . e_r at the swimmers, (F, S)
        q = ref.flow.sample(ref._flow_index, ref.pos.view(-1, 2)).view(*ref.batch_size, -1)
        d = ref.displacement()
        return (q[..., :2] * d).sum(-1) / d.norm(dim=-1)

    worst = 0.0
    for i in range(200):
        n_r = tds[1]["signals"][..., 0]
        u_r = advection() if i >= 100 else None  # far from the start: |x - x_0| >> v T_u
        tds = [env.step(sto(td))["next"] for env, td in zip(envs, tds, strict=True)]
        assert torch.equal(envs[0].pos, envs[1].pos)  # the reward does not change the motion
        swim = tds[1]["reward"][..., 0]
        torch.testing.assert_close(swim, 0.5 * v_t * (n_r + tds[1]["signals"][..., 0]))
        if u_r is not None:
            rest = tds[0]["reward"][..., 0] - swim - 0.5 * t_u * (u_r + advection())
            worst = max(worst, float(rest.abs().median()))  # the trapezoid's error aside
    assert worst < 0.05 * v_t, worst


def test_swimming_reward_is_refused_for_a_target():
    with pytest.raises(ConfigError, match="reward.progress"):
        EnvParams(task=TaskSpec("target", 3.0, 0.5), reward=RewardSpec(progress="swimming"))
    with pytest.raises(ConfigError, match="reward.progress"):
        RewardSpec(progress="speed")


def test_swimming_share_is_the_sum_of_the_swimming_reward():
    """outcomes()["swimming"], S_hat = (1/T) int n . e_r dt, is the episode's sum of the
    swimming reward over v_s T (the same trapezoids), lies in [-1, 1], and leaves the
    advection's share R_hat - S_hat; a reset clears it."""
    env = small_env(n_swimmers=16, seed=2, duration=3.0, reward=RewardSpec(progress="swimming"))
    td = env.rollout(env.params.n_decisions, as_actor(ShortTimeOptimal(0.98)))
    total = td["next", "reward"].sum(dim=-2)[..., 0]
    total = total / (env.decision_length * env.params.n_decisions)
    share = env.outcomes()["swimming"]
    torch.testing.assert_close(share, total, rtol=1e-4, atol=1e-5)
    assert share.abs().max() <= 1 and share.mean() > 0.3  # STO turns swimmers outward
    env.reset()
    assert not env.outcomes()["swimming"].any()


def test_critic_observation_is_the_observation_and_the_flow_along_e_r():
    """observe_flow_for_critic(env): critic_observation = (observation, u_r / v_s, u_perp / v_s);
    u_r v_s T_u is the advection the distance reward holds beyond the swimming reward (the
    trapezoid check of the test above, here from the env's own features), and
    u_r^2 + u_perp^2 = |u|^2 with u sampled from the flow."""
    env = small_env(n_swimmers=16, seed=5, duration=4.0, update_interval=0.02)
    observe_flow_for_critic(env)
    check_env_specs(env)
    td = env.reset()
    sto = as_actor(ShortTimeOptimal(0.98))
    t_u = env.params.update_interval * env.tau_k
    gaps = []
    for i in range(150):
        dist, align = env.displacement().norm(dim=-1), env.swim_alignment(env.displacement())
        u_r = td["critic_observation"][..., -2] * env.swim_speed
        td = env.step(sto(td))["next"]
        obs = td["critic_observation"]
        assert torch.equal(obs[..., :-2], td["observation"])
        q = env.flow.sample(env._flow_index, env.pos.view(-1, 2)).view(*env.batch_size, -1)
        speed2 = (obs[..., -2:] ** 2).sum(-1) * env.swim_speed**2
        torch.testing.assert_close(speed2, (q[..., :2] ** 2).sum(-1), rtol=1e-4, atol=1e-6)
        if i >= 100:
            swim = 0.5 * env.decision_length * (align + env.swim_alignment(env.displacement()))
            adv = 0.5 * t_u * (u_r + obs[..., -2] * env.swim_speed)
            gaps.append(float((env.displacement().norm(dim=-1) - dist - swim - adv)
                              .abs().median()))
    assert max(gaps) < 0.05 * env.decision_length, max(gaps)


def test_critic_observation_in_a_point_flow():
    """The same features in the 3D point env: |u| from the flow's own sample."""
    from swimrl.env.point import PointSwimmerEnv
    from swimrl.flows.stochastic3d import StochasticFlow3D
    from swimrl.physics.body3d import SIGNAL_NAMES_3D

    gen = torch.Generator().manual_seed(3)
    flow = StochasticFlow3D(2, 10.0, generator=gen)
    env = PointSwimmerEnv(flow, 4, EnvParams(signals=SIGNAL_NAMES_3D, duration=1.0),
                          generator=gen, kernel="eager")
    observe_flow_for_critic(env)
    check_env_specs(env)
    td = env.step(env.rand_action(env.reset()))["next"]
    feats = td["critic_observation"][..., -2:] * env.swim_speed
    u = flow.sample(env.pos)[0]
    torch.testing.assert_close((feats**2).sum(-1), (u**2).sum(-1), rtol=1e-4, atol=1e-6)
    assert (feats[..., 1] >= 0).all()
