"""Replay of stored snapshots: exact at stored times, linear in between, windows sliding."""

from __future__ import annotations

import math

import pytest
import torch

from swimrl.env import EnvParams, SwimmerEnv
from swimrl.flows.replay import ReplayFlow


class MemorySource:
    """Snapshots Q_j(x) = (1 + j^2/10) * F(x) + j G(x): non-linear in j, so windows matter."""

    n_runs = 1
    realisation_per_flow = False

    def __init__(self, n=16, n_times=40, dt_store=0.07, length=2 * math.pi):
        self.n, self.n_times, self.dt_store, self.length = n, n_times, dt_store, length
        self.u_rms, self.tau_k = 1.3, 0.35
        x = torch.arange(n, dtype=torch.float64) * length / n
        yy, xx = torch.meshgrid(x, x, indexing="ij")
        self.f = torch.stack(
            [torch.sin(xx), torch.cos(yy), xx * 0 + 0.3, torch.sin(xx + yy), torch.cos(xx - yy)], -1
        )
        self.g = torch.stack(
            [torch.cos(2 * yy), xx * 0 + 1, torch.sin(yy), xx * 0, torch.sin(xx)], -1
        )
        self.reads = 0

    def snapshot(self, j: int) -> torch.Tensor:
        return (1 + j * j / 10) * self.f + j * self.g

    def channels(self, i0: int, i1: int, run: int = 0) -> torch.Tensor:
        assert 0 <= i0 <= i1 <= self.n_times and run == 0
        self.reads += i1 - i0
        return torch.stack([self.snapshot(j) for j in range(i0, i1)]).float()


def grid_value(flow, f: int) -> torch.Tensor:
    return flow.grid_fields()[f].double()


@pytest.mark.parametrize("interval", [0.05, 0.07, 0.16])
def test_replay_is_exact_at_stored_times_and_linear_between(interval):
    src = MemorySource()
    gen = torch.Generator().manual_seed(0)
    flow = ReplayFlow(
        src, 3, interval=interval, episode_time=2.0, dtype=torch.float64, generator=gen
    )
    start = flow.start.clone()
    dt = interval / 5
    for _ in range(12):
        path = flow.coefficient_path(5, dt)
        assert torch.allclose(path.sum(-1), torch.ones(6, 3, dtype=torch.float64))
        for f in range(3):
            s = start[f].item() + flow.time[f].item() / src.dt_store
            j = math.floor(s + 1e-9)
            a = s - j
            expected = (
                (1 - a) * src.snapshot(j) + a * src.snapshot(j + 1)
                if a > 1e-9
                else (src.snapshot(j))
            )
            assert torch.allclose(grid_value(flow, f), expected.double(), atol=1e-5)


def test_replay_reads_each_snapshot_about_once():
    src = MemorySource(n_times=200)
    flow = ReplayFlow(src, 1, interval=0.07, episode_time=5.0, generator=torch.Generator())
    src.reads = 0
    for _ in range(50):
        flow.coefficient_path(7, 0.01)
    assert src.reads <= 50 + 2  # ~ one new snapshot per interval of one Δ


def test_too_short_run_is_a_clear_error():
    with pytest.raises(ValueError, match="stored run has 40 snapshots"):
        ReplayFlow(MemorySource(), 1, interval=0.1, episode_time=10.0)


def test_env_on_replay_uses_the_runs_units():
    src = MemorySource(n_times=400)
    flow = ReplayFlow(
        src,
        2,
        interval=0.1 * src.tau_k,
        episode_time=2.0 * src.tau_k,
        generator=torch.Generator().manual_seed(1),
    )
    env = SwimmerEnv(flow, 5, EnvParams(duration=2.0), kernel="eager")
    assert env.swim_speed == pytest.approx(0.707 * src.u_rms)
    assert env.dt == pytest.approx(0.01 * src.tau_k)
    td = env.rollout(env.params.n_decisions)
    assert torch.isfinite(td["next", "distance"]).all()
    assert td["next", "truncated"][..., -1, :].all()


def test_live_dns_flow_matches_its_solver(compose_cfg):
    """flow=dns: a small live DNS; grid fields equal the solver's channels at snapshot times
    and the swimmer units are the measured u_rms and tau_K."""
    from swimrl.config import eval_setup
    from swimrl.env import build_env
    from swimrl.flows.dns import flow_channels

    cfg = compose_cfg(
        [
            "flow=dns",
            "flow.dns.n=32",
            "flow.dns.nu=2e-3",
            "flow.dns.dt=5e-3",
            "flow.spinup.time=1.0",
            "flow.spinup.measure_time=0.5",
            "episode.duration=2.0",
            "threads=1",
            "kernel=eager",
        ]
    )
    setup = eval_setup(cfg)
    env = build_env(setup.flow, setup.params, setup.runtime, 2, 4, 0)
    flow, run = env.flow, env.flow.source
    assert env.tau_k == pytest.approx(run.tau_k) and env.swim_speed == pytest.approx(
        0.707 * run.u_rms
    )
    assert 0 < run.u_rms < 10 and 0 < run.tau_k < 10
    td = env.reset()
    start = int(flow.start[0])
    assert int(flow.start[1]) == start  # both realisations start at the run's current time
    # at t = 0 each flow is its solver realisation at the start snapshot ...
    assert torch.allclose(flow.grid_fields(), run.cache[start], atol=1e-6)
    # ... and the newest cached snapshot is the solver's current state
    q_now = flow_channels(run.dns.state.omega_hat, run.dns.grid)
    assert torch.equal(run.cache[run.latest], q_now)
    for _ in range(5):
        td = env.step(td.set("action", torch.zeros(2, 4, 1))).get("next")
    held = flow.held[flow.row]  # (flows, M): snapshot index in each ring slot
    assert int(held.min()) > start  # the solver advanced with the swimmers
    for f in range(2):  # the ring holds the solver's snapshots of each realisation
        for m in range(flow.n_basis):
            j = int(held[f, m])
            assert j % flow.n_basis == m
            assert torch.equal(flow.basis[flow.row[f], :, :, m], run.cache[j][f])
    assert torch.isfinite(td["distance"]).all()
    assert torch.allclose(flow.coeffs.sum(-1), torch.ones(2))


def test_live_dns_bad_parameter_is_named(compose_cfg):
    from swimrl.config import eval_setup

    with pytest.raises(ValueError, match="flow.spinup.measure_time"):
        eval_setup(compose_cfg(["flow=dns", "flow.spinup.measure_time=20"]))
    with pytest.raises(ValueError, match="flow.dns.nu"):
        eval_setup(compose_cfg(["flow=dns", "flow.dns.nu=-1"]))


class RunsSource(MemorySource):
    """Two runs: run r's snapshot j is (1 + r) * MemorySource's."""

    n_runs = 2

    def channels(self, i0: int, i1: int, run: int = 0) -> torch.Tensor:
        assert run in (0, 1)
        self.reads += i1 - i0
        return torch.stack([(1 + run) * self.snapshot(j) for j in range(i0, i1)]).float()


def test_flows_of_a_group_share_a_run_a_start_and_one_decode():
    src = RunsSource(n_times=200)
    gen = torch.Generator().manual_seed(4)
    flow = ReplayFlow(src, 6, interval=0.07, episode_time=5.0, dtype=torch.float64,
                      generator=gen, flows_per_start=3)
    assert flow.basis.shape[0] == 2  # two rows for six flows
    for group in (slice(0, 3), slice(3, 6)):
        assert len(set(flow.run[group].tolist())) == 1
        assert len(set(flow.start[group].tolist())) == 1
        assert len(set(flow.row[group].tolist())) == 1
    decodes = flow.decodes
    for _ in range(10):
        flow.coefficient_path(7, 0.01)
        for f in range(6):  # each flow is its own run at its own time, exactly
            s = flow.start[f].item() + flow.time[f].item() / src.dt_store
            j = math.floor(s + 1e-9)
            a = s - j
            want = (1 + flow.run[f].item()) * ((1 - a) * src.snapshot(j)
                                               + a * src.snapshot(j + 1))
            assert torch.allclose(flow.grid_fields([f])[0], want.double(), atol=1e-9)
    assert flow.decodes - decodes <= 2 * 10 + 2  # one per row per interval of one Δ


def test_a_partial_reset_gives_the_reset_flows_a_row_of_their_own():
    src = RunsSource(n_times=200)
    flow = ReplayFlow(src, 4, interval=0.07, episode_time=5.0, dtype=torch.float64,
                      generator=torch.Generator().manual_seed(2), flows_per_start=4)
    flow.coefficient_path(7, 0.01)
    kept = flow.grid_fields([0, 1])
    flow.reset(torch.tensor([False, False, True, True]))
    assert flow.row[2] == flow.row[3] != flow.row[0] == flow.row[1]
    assert torch.equal(flow.grid_fields([0, 1]), kept)  # untouched flows keep their state
    assert flow.time[2] == 0 and flow.time[0] > 0
    flow.coefficient_path(7, 0.01)  # rows at different times advance together
    assert torch.allclose(flow.coeffs.sum(-1), torch.ones(flow.basis.shape[0], dtype=torch.float64))


@pytest.mark.parametrize("kernel", ["eager", "fused"])
def test_shared_decoding_gives_bit_identical_trajectories(kernel):
    """Six flows replaying two (run, start) pairs: one row per pair (shared decoding) and one
    row per flow (decoding per flow) move the swimmers identically, bit for bit."""
    if kernel == "fused":
        from swimrl.physics.kernels import load_cpu_kernel

        if load_cpu_kernel() is None:
            pytest.skip("no C++ toolchain for the fused kernel")

    class Pairs(ReplayFlow):  # flows 0-2: run 1 from index 17; flows 3-5: run 0 from 42
        def start_indices(self, count):
            return torch.tensor([17, 42]).repeat_interleave(count // 2)

        def start_runs(self, count):
            return torch.tensor([1, 0]).repeat_interleave(count // 2)

    src = RunsSource(n_times=200)
    params = EnvParams(duration=2.0)
    out = []
    for per_start in (3, 1):
        flow = Pairs(src, 6, interval=0.1 * src.tau_k, episode_time=2.0 * src.tau_k,
                     flows_per_start=per_start)
        env = SwimmerEnv(flow, 5, params, generator=torch.Generator().manual_seed(9),
                         kernel=kernel)
        td = env.reset()
        assert flow.run.tolist() == [1, 1, 1, 0, 0, 0]
        decodes = flow.decodes
        for i in range(env.params.n_decisions):
            act = (0.9 * torch.sin(torch.arange(30.0) + i)).view(6, 5, 1)
            td = env.step(td.set("action", act)).get("next")
        out.append((env.pos.clone(), env.theta.clone(), flow.decodes - decodes,
                    flow.basis.shape[0]))
    (pos_a, th_a, dec_a, rows_a), (pos_b, th_b, dec_b, rows_b) = out
    assert torch.equal(pos_a, pos_b) and torch.equal(th_a, th_b)
    assert (rows_a, rows_b) == (2, 6)
    # either way each (run, snapshot) is decoded once: the rows of the per-flow replay take
    # the snapshots their neighbours decoded from the cache
    assert dec_a == dec_b <= 2 * (env.params.n_decisions + 3)


@pytest.mark.parametrize("dt_store", [0.098, 0.0999, 0.1])
def test_an_episode_from_the_last_start_runs_to_the_end_of_the_run(dt_store):
    """Δ slightly below T_u (a real store's interval is whole solver steps): the window of
    the last decision would reach one snapshot past the run; it must not be read."""
    src = MemorySource(n_times=30, dt_store=dt_store)
    flow = ReplayFlow(src, 2, interval=0.1, episode_time=2.0, dtype=torch.float64,
                      generator=torch.Generator().manual_seed(0))
    flow.start_indices = lambda count: torch.full((count,), flow.max_start, dtype=torch.int64)
    flow.reset()
    for _ in range(20):
        path = flow.coefficient_path(10, 0.01)
        assert torch.allclose(path.sum(-1), torch.ones(11, 1, dtype=torch.float64))
    s = flow.start[0].item() + flow.time[0].item() / dt_store
    assert s <= src.n_times - 1 + 1e-9
    j = min(math.floor(s + 1e-9), src.n_times - 1)
    a = s - j
    want = (1 - a) * src.snapshot(j) + (a * src.snapshot(j + 1) if a > 1e-9 else 0)
    assert torch.allclose(grid_value(flow, 0), want.double(), atol=1e-6)


def test_a_replay_checkpoint_from_before_the_sharing_keys_resumes_as_before(compose_cfg):
    """A training checkpoint of flow=dns_replay written before flow.decode_n and
    flow.flows_per_start existed gets the values that reproduce the old replay, which are
    the defaults: its config then equals today's."""
    from omegaconf import OmegaConf

    from swimrl.runs.checkpoint import upgrade_config

    now = OmegaConf.to_container(compose_cfg(["flow=dns_replay"], name="train"))
    old = {**now, "flow": {k: v for k, v in now["flow"].items()
                           if k not in ("decode_n", "flows_per_start")}}
    assert upgrade_config(old) == now
