"""Actors, PPO, policy files and baselines for every actuation (``actuation=shape``, ``steer``
continuous and discrete, ``shape_steer``), the shape factor's actor as it always was."""

from __future__ import annotations

import math

import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import AddStateIndependentNormalScale
from torchrl.data import Categorical
from torchrl.envs.utils import ExplorationType, set_exploration_type

from swimrl.actuation import ActuationSpec
from swimrl.config import eval_config, train_config
from swimrl.env import EnvParams
from swimrl.env.actuation import action_spec as env_action_spec
from swimrl.errors import ConfigError
from swimrl.evaluation.rollout import actor_for, evaluate
from swimrl.evaluation.trajectories import TrajectoryRecorder
from swimrl.policies.baselines import StrategySpec, build_strategy
from swimrl.policies.networks import (
    ModelSpec,
    action_bounds,
    action_layout,
    action_spec,
    actor_critic,
    deterministic_actor,
    make_mlp,
    policy_std,
    tanh_normal_actor,
)
from swimrl.rl.run import train
from swimrl.runs.policy_files import load_file, load_policy, policy_meta, save_policy

MODEL = ModelSpec(hidden=(16, 16), activation="tanh", init_std=1.0, min_std=1e-4)
LAM_MAX = 0.9
#: (actuation, directions, dim) of the action specs checked
LAYOUTS = [("shape", "continuous", 2), ("steer", "continuous", 2), ("steer", "continuous", 3),
           ("steer", "discrete", 2), ("steer", "discrete", 3), ("shape_steer", "continuous", 2),
           ("shape_steer", "continuous", 3)]
#: short episodes, no progress bars (the analytic flows have no grid to shrink)
SMALL = ["episode.duration=2.0", "eval.progress=false", "threads=1"]
#: a steering swimmer in the Taylor-Green flow (task=vertical), small and short
STEER = ["flow=taylor_green", "swimmer.bottom_heaviness=0.5", "task=vertical",
         "task.burn_in=1.0", "signals.names=[n_r,n_theta,omega]"]
TINY_TRAIN = ["train.compile=false", "train.n_flows=2", "train.n_swimmers=4",
              "train.rollout_length=10", "train.total_frames=320", "train.minibatch_size=40",
              "train.eval_every=2", "train.eval_flows=1", "train.eval_swimmers=4",
              "train.progress=false", "eval.n_flows=2", "eval.n_swimmers=4"]
ACTUATIONS = {"steer": ["actuation=steer"],
              "steer_discrete": ["actuation=steer", "actuation.directions=discrete"],
              "shape_steer": ["actuation=shape_steer"]}


def spec_of(name: str, directions: str, dim: int):
    """The environment's unbatched action spec of an actuation in ``dim``-space."""
    act = ActuationSpec(name=name, directions=directions)
    return env_action_spec(act, LAM_MAX, dim, torch.Size(), None, torch.float32)


@pytest.mark.parametrize("layout", LAYOUTS, ids=lambda t: "-".join(map(str, t)))
def test_actor_of_every_action_spec(layout):
    """Shapes, bounds, finite log-probabilities, the deterministic actor as the distribution's
    deterministic sample, and the layout read back from the spec."""
    name, directions, dim = layout
    spec = spec_of(name, directions, dim)
    got, got_dim = action_layout(spec)
    assert (got.name, got.directions) == (name, directions)
    assert got_dim == (None if name == "shape" else dim)
    torch.manual_seed(0)
    actor, critic = actor_critic(MODEL, 3, spec)
    td = actor(TensorDict({"observation": 3 * torch.randn(256, 3)}, [256]))
    a, logp = td["action"], td["action_log_prob"]
    assert logp.shape == (256,) and torch.isfinite(logp).all()
    assert critic(td)["state_value"].shape == (256, 1)
    policy = deterministic_actor(actor)
    det = policy(td.clone())["action"]
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        mode = actor(td.clone())["action"]
    if isinstance(spec, Categorical):
        assert a.shape == (256,) and a.dtype == torch.int64
        assert int(a.min()) >= 0 and int(a.max()) < 2 * dim
        assert policy_std(actor).numel() == 0  # no sigma: the trainer logs no policy/std
        assert torch.equal(det, mode) and torch.equal(det, td["logits"].argmax(-1))
        return
    m = spec.shape[-1]
    low, high = spec.space.low, spec.space.high
    assert a.shape == (256, m) and ((a >= low) & (a <= high)).all()
    assert policy_std(actor).shape == (m,)
    assert det.shape == (256, m) and torch.allclose(det, mode, atol=1e-6)
    if m > 1:  # the one-component reader refuses a wider action
        with pytest.raises(ValueError, match="one-component"):
            action_bounds(spec)


def test_the_shape_factor_actor_is_built_as_before():
    """The 1-component actor: the same parameters, in the same random order, as the mean
    network and scale built the old way (before steering existed), and the same actions."""
    torch.manual_seed(5)
    mean = make_mlp(5, 1, [64, 64], "tanh", 0.01)
    scale = AddStateIndependentNormalScale(1, scale_mapping="exp", scale_lb=1e-4,
                                           init_value=math.log(1.0))
    obs = torch.randn(16, 5)
    torch.manual_seed(5)
    actor = tanh_normal_actor(5, action_spec(0.98), hidden=[64, 64], activation="tanh",
                              init_std=1.0, min_std=1e-4)
    built = actor.state_dict()
    old = {**{f"module.0.module.0.{k}": v for k, v in mean.state_dict().items()},
           **{f"module.0.module.1.{k}": v for k, v in scale.state_dict().items()}}
    assert sorted(built) == sorted(old)
    assert all(torch.equal(built[k], old[k]) for k in old)
    lam_max = float(torch.tensor(0.98))  # the spec's float32 bound, as a number
    assert actor.module[1].distribution_kwargs == {"low": -lam_max, "high": lam_max}
    with torch.no_grad():
        lam = deterministic_actor(actor)(TensorDict({"observation": obs}, [16]))["action"]
        assert torch.equal(lam, 0.98 * torch.tanh(mean(obs)))


def test_the_shipped_ku10_policy_acts_as_before():
    """``pretrained/ku10`` gives the actions it gave before steering existed (pinned here) and
    ``Lambda_max tanh(mu)`` of the stored weights, computed by hand."""
    torch.manual_seed(0)
    obs = torch.randn(100, 5, dtype=torch.float64)
    lam = load_policy("pretrained/ku10", EnvParams())(TensorDict({"observation": obs},
                                                                 [100]))["action"]
    pinned = [-0.9056891798973083, -0.9760211706161499, 0.9782372713088989]
    assert lam[:3, 0].tolist() == pytest.approx(pinned, abs=1e-6)
    from swimrl.runs.policy_files import resolve_policy_file

    data = load_file(resolve_policy_file("pretrained/ku10"))
    w = {k.removeprefix("module.0.module.0."): v for k, v in data["actor"].items()
         if k.startswith("module.0.module.0.")}
    x = obs.float()
    n_layers = len([k for k in w if k.endswith("weight")])
    for i in range(n_layers):
        x = x @ w[f"{2 * i}.weight"].T + w[f"{2 * i}.bias"]
        x = torch.tanh(x) if i < n_layers - 1 else x
    assert torch.equal(lam, (0.98 * torch.tanh(x)).double())


@pytest.mark.parametrize("actuation", list(ACTUATIONS))
def test_tiny_ppo_trains_every_steering_actuation(compose_cfg, tmp_path, actuation):
    """320 frames of PPO (stock ``ClipPPOLoss``, GAE) on the Taylor-Green flow, the final
    evaluation and the policy file, whose action record rebuilds the trained actor."""
    over = SMALL + STEER + TINY_TRAIN + ACTUATIONS[actuation] + ["loss.entropy_coeff=0.01"]
    cfg = train_config(compose_cfg(over, name="train"))
    metrics = train(cfg, tmp_path)
    assert math.isfinite(metrics["R_hat_mean"])
    record = load_file(tmp_path / "policy.pt")["action"]
    kind, width = {"steer": ("bounded", 2), "steer_discrete": ("categorical", 4),
                   "shape_steer": ("bounded", 3)}[actuation]
    assert (record["kind"], record["width"]) == (kind, width)
    policy = load_policy(str(tmp_path), cfg.params)
    assert action_layout(policy.action_spec)[0].name == cfg.params.actuation.name


def params_of(name: str, directions: str = "continuous", signals=("n_r", "S_nn")) -> EnvParams:
    return EnvParams(shape_factor_max=LAM_MAX, bottom_heaviness=0.5, signals=signals,
                     actuation=ActuationSpec(name=name, directions=directions))


@pytest.mark.parametrize("layout", LAYOUTS[1:], ids=lambda t: "-".join(map(str, t)))
def test_policy_file_round_trip(tmp_path, layout):
    """Save, load: the loaded policy acts as the deterministic actor it was saved from."""
    name, directions, dim = layout
    spec, params = spec_of(name, directions, dim), params_of(name, directions)
    torch.manual_seed(1)
    actor, _ = actor_critic(MODEL, 2, spec)
    with torch.no_grad():
        for p in actor.parameters():
            p.normal_(0, 0.5)
    save_policy(tmp_path / "policy.pt", actor=actor, counters={}, config={},
                meta=policy_meta(params, MODEL, "float32", spec))
    loaded = load_policy(str(tmp_path), params, action=spec)
    td = TensorDict({"observation": torch.randn(64, 2)}, [64])
    assert torch.equal(loaded(td.clone())["action"], deterministic_actor(actor)(td)["action"])


def test_a_policy_in_another_action_is_one_clear_line(tmp_path):
    """A 2D steering policy in a 3D flow, a steering policy in a shape env, a continuous one
    in a discrete env: one line naming both."""
    spec2 = spec_of("steer", "continuous", 2)
    actor, _ = actor_critic(MODEL, 2, spec2)
    save_policy(tmp_path / "policy.pt", actor=actor, counters={}, config={},
                meta=policy_meta(params_of("steer"), MODEL, "float32", spec2))
    with pytest.raises(ConfigError) as err:
        load_policy(str(tmp_path), params_of("steer"), action=spec_of("steer", "continuous", 3))
    msg = str(err.value)
    assert "in a 2D flow" in msg and "in a 3D flow" in msg and "\n" not in msg
    for params in (params_of("shape"), params_of("steer", "discrete"), params_of("shape_steer")):
        with pytest.raises(ConfigError, match="actuation=steer") as err:
            load_policy(str(tmp_path), params)
        assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="action spec"):  # the spec is not known from params
        policy_meta(params_of("steer"), MODEL, "float32")


def test_a_2d_steering_policy_in_a_3d_evaluation_is_refused(compose_cfg, tmp_path):
    spec2 = spec_of("steer", "continuous", 2)
    params = params_of("steer")
    actor, _ = actor_critic(MODEL, 2, spec2)
    save_policy(tmp_path / "policy.pt", actor=actor, counters={}, config={},
                meta=policy_meta(params, MODEL, "float32", spec2))
    c = eval_config(compose_cfg(SMALL + [
        "flow=abc", "swimmer.bottom_heaviness=0.5", "actuation=steer",
        "signals.names=[n_r,S_nn]", "strategy=policy", f"policy={tmp_path}",
        f"swimmer.shape_factor_max={LAM_MAX}", "eval.n_flows=1", "eval.n_swimmers=2"]))
    with pytest.raises(ConfigError, match="in a 2D flow.*in a 3D flow"):
        evaluate(c.setup, actor_for(c.strategy, c.policy, c.setup.params), "policy")


@pytest.mark.parametrize(("layout", "up"), [
    (("steer", "continuous", 2), [0.0, 1.0]), (("steer", "continuous", 3), [0.0, 0.0, 1.0]),
    (("steer", "discrete", 2), 1), (("steer", "discrete", 3), 2),
    (("shape_steer", "continuous", 2), [0.5, 0.0, 1.0]),
    (("shape_steer", "continuous", 3), [0.5, 0.0, 0.0, 1.0])])
def test_naive_steers_straight_up_and_shape_baselines_are_refused(layout, up):
    spec = spec_of(*layout)
    naive = build_strategy(StrategySpec("naive", shape_factor=0.5), spec)
    a = naive(TensorDict({"signals": torch.randn(4, 3, 5)}, [4, 3]))["action"]
    assert a.shape == (4, 3) + (() if isinstance(up, int) else (len(up),))
    assert (a == torch.tensor(up, dtype=a.dtype)).all()
    assert spec.is_in(a[0, 0])
    for strategy in (StrategySpec("sto"), StrategySpec("minimal", coeffs=(1, 0, 0, 0)),
                     StrategySpec("optimised", coeffs=(1, 0, 0, 0, 0, 1))):
        with pytest.raises(ConfigError, match=f"strategy={strategy.name} is invalid") as err:
            build_strategy(strategy, spec)
        assert "\n" not in str(err.value)


def test_steering_evaluation_records_the_directions(compose_cfg):
    """``strategy=naive`` on a steering env: every swimmer steers up, the held shape is
    recorded as Lambda; ``strategy=sto`` is refused when the config is read."""
    base = SMALL + STEER + ["actuation=steer", "eval.n_flows=1", "eval.n_swimmers=4"]
    c = eval_config(compose_cfg(base + ["strategy=naive"]))
    rec = TrajectoryRecorder(2)
    m = evaluate(c.setup, actor_for(c.strategy, c.policy, c.setup.params), "naive", rec)
    assert math.isfinite(m["R_hat_mean"])
    arrays = rec.arrays()
    n = c.setup.params.n_decisions
    assert arrays["direction"].shape == (1, 1, 2, n, 2)
    assert (arrays["direction"] == torch.tensor([0.0, 1.0]).numpy()).all()
    assert (arrays["Lambda"] == 0.0).all()
    with pytest.raises(ConfigError, match="strategy=sto is invalid with actuation=steer"):
        eval_config(compose_cfg(base + ["strategy=sto"]))
