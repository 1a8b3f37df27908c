"""What a CUDA-graph capture of the training loop needs, checked on the CPU.

A capture (``train.cudagraphs=true``) is invalidated by any host synchronisation (``.item()``,
``bool(tensor)``, ``.cpu()``, a boolean-mask index) and ``torch.compile(fullgraph=True)``
refuses any graph break, which is where Dynamo meets such a synchronisation or Python it
cannot trace. So, on the CPU:

* the integration interval (``kernel=compiled``), TorchRL's GAE as the trainer builds it, and
  the PPO loss compile with ``fullgraph=True`` and give the eager values;
* the environment step (both tasks) and the eager gradient step run under a guard that makes
  every host-synchronising tensor method raise.
"""

from __future__ import annotations

import contextlib

import pytest
import torch
from torchrl.objectives.value import GAE

from swimrl.config import train_config
from swimrl.env import EnvParams, SwimmerEnv
from swimrl.flows.stochastic import StochasticFlow
from swimrl.physics.integrator import integrate_interval, select_kernel
from swimrl.rl.builders import FiniteObservationGAE, make_collector
from swimrl.rl.plan import make_plan
from swimrl.rl.trainer import PPOTrainer
from swimrl.task import TaskSpec

from .test_train import TINY

#: Tensor methods that copy a value to the host (or branch on one).
SYNCING = ("item", "tolist", "cpu", "numpy", "__bool__", "__int__", "__float__", "nonzero")


@contextlib.contextmanager
def no_host_sync():
    """Every method of :data:`SYNCING` raises inside the block (a CPU stand-in for
    ``torch.cuda.set_sync_debug_mode("error")``)."""
    saved = {name: getattr(torch.Tensor, name) for name in SYNCING}

    def refuse(name):
        def method(self, *args, **kwargs):
            raise AssertionError(f"host synchronisation: Tensor.{name}")
        return method

    try:
        for name in SYNCING:
            setattr(torch.Tensor, name, refuse(name))
        yield
    finally:
        for name, method in saved.items():
            setattr(torch.Tensor, name, method)


def _env(task: TaskSpec | None = None, kernel: str = "eager", **params) -> SwimmerEnv:
    task = TaskSpec() if task is None else task
    gen = torch.Generator().manual_seed(3)
    flow = StochasticFlow(2, 10.0, n_grid=64, spacing=0.1, generator=gen)
    p = EnvParams(task=task, **{"duration": 1.0, **params})
    return SwimmerEnv(flow, 8, p, generator=gen, kernel=kernel)


@pytest.mark.parametrize("task", [TaskSpec(), TaskSpec(name="target", distance=0.25,
                                                        arrival_radius=0.2)])
def test_env_step_holds_no_host_sync(task):
    """``env.step`` (the decision interval, rewards, signals, the target task's arrivals and
    frozen swimmers) reads no tensor value on the host."""
    env = _env(task, rot_diffusion=0.1, duration=4.0)
    td = env.reset()
    td.set("action", env.action_spec.rand())
    for _ in range(30):  # the target task: some swimmers arrive within these steps
        with no_host_sync():
            td = env.step(td).get("next").clone()
        td.set("action", env.action_spec.rand())
    if task.target:  # the frozen-swimmer path was taken, and not by everyone
        assert 0 < int(env.arrived.sum()) < env.arrived.numel()


def test_compiled_interval_has_no_graph_break_and_matches_eager():
    """``kernel=compiled`` (``torch.compile(fullgraph=True)`` of the interval, the CUDA
    default) gives the eager reference to float32 round-off, rotational noise included."""
    env = _env(kernel="eager", dt=0.05, rot_diffusion=0.1)  # K = 2: a short compilation
    env.reset()
    flow, k = env.flow, env.params.n_substeps
    path = flow.coefficient_path(k, env.dt)
    theta = env.theta.view(-1)
    kicks = 0.1 * torch.randn((k,) + theta.shape, generator=torch.Generator().manual_seed(1))
    lam = torch.linspace(-0.98, 0.98, theta.numel())
    args = (flow.table, path, flow.rows(env._flow_index), env.pos.view(-1, 2), theta, lam,
            kicks, flow.grid.n, flow.grid.spacing, env.swim_speed, env.dt)
    pos_e, theta_e = integrate_interval(*args)
    pos_c, theta_c = select_kernel("compiled", torch.device("cpu"))(*args)
    torch.testing.assert_close(pos_c, pos_e, rtol=1e-5, atol=1e-5)
    torch.testing.assert_close(theta_c, theta_e, rtol=1e-5, atol=1e-5)
    assert float((pos_e - env.pos.view(-1, 2)).abs().max()) > 1e-3  # the swimmers moved


@pytest.fixture(scope="module")
def trainer_and_batch(tmp_path_factory):
    """A tiny trainer and one collected batch of its env."""
    from hydra import compose, initialize_config_module

    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose(config_name="train", overrides=TINY)
    c = train_config(cfg)
    trainer = PPOTrainer(c, make_plan(c), tmp_path_factory.mktemp("run"))
    collector = make_collector(trainer.env, trainer.actor, c.train, c.train.frames_per_batch,
                               "cpu")
    data = next(iter(collector))
    collector.shutdown()
    return trainer, data


def test_gae_has_no_graph_break_and_equals_torchrl_gae(trainer_and_batch):
    """The trainer's GAE (TorchRL's, without the NaN-observation sanitiser) gives TorchRL's
    ``GAE`` bit for bit in eager mode and compiles with ``fullgraph=True``, where the stock
    ``GAE`` breaks the graph (its sanitiser branches on ``isnan(..).any()``)."""
    trainer, data = trainer_and_batch
    gae = trainer.gae
    assert isinstance(gae, FiniteObservationGAE)
    stock = GAE(gamma=gae.gamma, lmbda=gae.lmbda, value_network=trainer.critic,
                average_gae=False)
    with torch.no_grad():
        ref = stock(data.clone())
        ours = gae(data.clone())
        assert torch.equal(ours["advantage"], ref["advantage"])
        assert torch.equal(ours["value_target"], ref["value_target"])
        compiled = torch.compile(gae, fullgraph=True)(data.clone())
        with pytest.raises(torch._dynamo.exc.Unsupported):
            torch.compile(stock, fullgraph=True)(data.clone())
    torch.testing.assert_close(compiled["advantage"], ref["advantage"], rtol=1e-5, atol=1e-6)


@pytest.mark.slow  # torch.compile of the loss and its backward, fullgraph (~15 s)
def test_loss_has_no_graph_break_and_the_gradient_step_no_host_sync(trainer_and_batch):
    """The clipped-PPO loss compiles with ``fullgraph=True`` (its backward is AOTAutograd's
    compiled graph) and equals the eager loss; the compiled loss, its backward and the
    per-network gradient clipping read no tensor value on the host. (Eager, TorchRL's
    ``TanhNormal`` asks ``(high != 1).any()`` unless it is being compiled or captured; Adam's
    step is captured with ``capturable=True`` on CUDA, as in TorchRL's
    ``sota-implementations/ppo``.)"""
    trainer, data = trainer_and_batch
    with torch.no_grad():
        data = trainer.gae(data.clone())
    batch = data.select(*trainer._loss_keys(data), strict=False).reshape(-1)[:40]
    total_e, out_e = trainer._loss(batch)
    loss = torch.compile(trainer._loss, fullgraph=True)
    total_c, out_c = loss(batch)
    torch.testing.assert_close(total_c, total_e, rtol=1e-5, atol=1e-6)
    for key in ("loss_objective", "loss_critic"):
        torch.testing.assert_close(out_c[key], out_e[key], rtol=1e-5, atol=1e-6)
    groups = [list(trainer.actor.parameters()), list(trainer.critic.parameters())]
    for g in groups:
        for p in g:
            p.grad = None
    with no_host_sync():
        total, _ = loss(batch)
        total.backward()
        for g in groups:
            torch.nn.utils.clip_grad_norm_(g, 0.5)
    assert all(p.grad is not None for g in groups for p in g)
