"""Loading trained policies: specs, pretrained short names, signal checks, determinism."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import torch
from tensordict import TensorDict
from torchrl.envs.utils import ExplorationType, set_exploration_type

import swimrl.runs.policy_files as pio
from swimrl.config import compare_config, env_params, eval_config, gain_scan_config, train_config
from swimrl.env import EnvParams
from swimrl.errors import ConfigError
from swimrl.evaluation.compare import compare
from swimrl.evaluation.rollout import actor_for, evaluate
from swimrl.policies.networks import action_spec, mean_network, tanh_normal_actor
from swimrl.runs.policy_files import policy_meta, save_policy

from .conftest import SMALL


def write_policy(compose_cfg, directory, signals: str = "all", seed: int = 0):
    """A tiny untrained policy saved as ``directory/policy.pt``; returns its actor."""
    cfg = train_config(compose_cfg(SMALL + [f"signals={signals}"], name="train"))
    params = cfg.params
    torch.manual_seed(seed)
    actor = tanh_normal_actor(len(params.signals), action_spec(params.shape_factor_max))
    with torch.no_grad():  # a non-trivial mean network
        for p in mean_network(actor).parameters():
            p.normal_(0, 0.5)
    save_policy(
        directory / "policy.pt",
        actor=actor,
        counters={"frames": 0, "updates": 0},
        config={},
        meta=policy_meta(params, cfg.model, "float32"),
    )
    return actor


@pytest.fixture
def pretrained(tmp_path, monkeypatch, compose_cfg):
    root = tmp_path / "pretrained"
    for name in ("ku10", "ku1e7"):
        (root / name).mkdir(parents=True)
        write_policy(compose_cfg, root / name)
    monkeypatch.setattr(pio, "PRETRAINED_ROOT", root)
    return root


def test_short_names_resolve_in_the_package_root(pretrained):
    assert pio.available_pretrained() == ["ku10", "ku1e7"]
    assert pio.resolve_policy_file("pretrained/ku10") == pretrained / "ku10" / "policy.pt"
    for alias in ("pretrained/ku1e7", "pretrained/ku1e+07", "pretrained/ku10000000"):
        assert pio.resolve_policy_file(alias) == pretrained / "ku1e7" / "policy.pt"


def test_default_pretrained_root_is_inside_the_package():
    import swimrl

    expected = Path(swimrl.__file__).resolve().parent / "policies" / "pretrained"
    assert expected == pio.PRETRAINED_ROOT


def test_missing_pretrained_lists_what_exists(pretrained):
    with pytest.raises(FileNotFoundError) as err:
        pio.load_policy("pretrained/ku0.1", EnvParams())
    msg = str(err.value)
    assert "ku10, ku1e7" in msg and "ku0.1" in msg and "\n" not in msg


def test_missing_paths_are_clear_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such run directory"):
        pio.load_policy(str(tmp_path / "nope"), EnvParams())
    with pytest.raises(FileNotFoundError, match="no policy.pt"):
        pio.load_policy(str(tmp_path), EnvParams())
    bad = tmp_path / "bad.pt"
    torch.save({"x": 1}, bad)
    with pytest.raises(ValueError, match="not a swimrl-train policy"):
        pio.load_policy(str(bad), EnvParams())


def test_loaded_policy_is_the_deterministic_mean(pretrained, compose_cfg, tmp_path):
    actor = write_policy(compose_cfg, tmp_path, seed=7)
    loaded = pio.load_policy(str(tmp_path), EnvParams())  # run dir -> policy.pt
    same = pio.load_policy(str(tmp_path / "policy.pt"), EnvParams())  # file
    obs = torch.randn(64, 5)
    td = TensorDict({"observation": obs}, [64])
    lam = loaded(td.clone())["action"]
    assert lam.shape == (64, 1) and lam.abs().max() <= 0.98
    assert torch.equal(lam, same(td.clone())["action"])
    with torch.no_grad():
        assert torch.allclose(lam, 0.98 * torch.tanh(mean_network(actor)(obs)), atol=1e-6)
        with set_exploration_type(ExplorationType.DETERMINISTIC):
            det = actor(td.clone())["action"]
    assert torch.allclose(lam, det, atol=1e-5)
    # float64 observations work with a float32 policy
    lam64 = loaded(TensorDict({"observation": obs.double()}, [64]))["action"]
    assert lam64.dtype == torch.float64 and torch.allclose(lam64.float(), lam, atol=1e-6)


def test_signal_set_mismatch_is_one_clear_line(pretrained, compose_cfg, tmp_path):
    write_policy(compose_cfg, tmp_path, signals="nth_snp")
    params = env_params(compose_cfg(SMALL))  # all five signals
    with pytest.raises(ConfigError) as err:
        pio.load_policy(str(tmp_path), params)
    msg = str(err.value)
    assert "signals=nth_snp" in msg and "signals.names" in msg and "\n" not in msg
    ok = env_params(compose_cfg(SMALL + ["signals=nth_snp"]))
    assert pio.load_policy(str(tmp_path), ok) is not None


def run_eval(cfg) -> dict:
    """``swimrl-eval`` on a composed config (without writing metrics.json)."""
    c = eval_config(cfg)
    return evaluate(c.setup, actor_for(c.strategy, c.policy, c.setup.params), c.strategy.name)


def test_swimrl_eval_with_a_pretrained_policy(pretrained, compose_cfg):
    cfg = compose_cfg(
        SMALL + ["strategy=policy", "policy=pretrained/ku10", "eval.n_flows=2", "eval.n_swimmers=8"]
    )
    a, b = run_eval(cfg), run_eval(cfg)
    assert a["strategy"] == "policy" and a["R_hat_mean"] > 0
    assert a["per_flow"] == b["per_flow"]  # deterministic policy, same flows
    bad = compose_cfg(SMALL + ["strategy=policy", "policy=pretrained/ku10", "signals=nth_snp"])
    with pytest.raises(ConfigError, match="signals=all"):
        run_eval(bad)


def test_compare_pairs_policies_with_the_baselines(pretrained, compose_cfg):
    """``compare.strategies=[sto,policy]``: the policy row is the same numbers as swimrl-eval."""
    size = ["eval.n_flows=2", "eval.n_swimmers=8"]

    def run_compare(over):
        return compare(compare_config(compose_cfg(SMALL + size + over, name="compare")))

    rec = run_compare(["compare.strategies=[sto,policy]",
                       "compare.policies=[pretrained/ku10,pretrained/ku1e7]"])
    assert [r["label"] for r in rec["rows"]] == [
        "sto", "policy(pretrained/ku10)", "policy(pretrained/ku1e7)"]
    alone = run_eval(compose_cfg(SMALL + size + ["strategy=policy", "policy=pretrained/ku10"]))
    assert rec["rows"][1]["per_flow"] == alone["per_flow"]
    sto = run_eval(compose_cfg(SMALL + size + ["strategy=sto"]))
    assert rec["rows"][0]["per_flow"] == sto["per_flow"]
    ratio = sum(alone["per_flow"]) / sum(sto["per_flow"])
    assert rec["rows"][1]["ratio_to_first"] == pytest.approx(ratio, rel=1e-12)
    shared = run_compare(["compare.strategies=[sto,policy]",
                          "compare.policies=[pretrained/ku10,pretrained/ku1e7]",
                          "compare.shared_flows=true"])
    assert [r["label"] for r in shared["rows"]] == [r["label"] for r in rec["rows"]]
    # the two fixture policies have the same weights (seed 0): with common flows and initial
    # conditions their rows are identical, and each is the policy's plain evaluation
    assert shared["rows"][1]["per_flow"] == shared["rows"][2]["per_flow"]
    assert shared["rows"][1]["per_flow"] == pytest.approx(alone["per_flow"], rel=1e-6, abs=0)
    for bad, match in ((["compare.policies=[]"], "compare.policies is empty"),
                       (["compare.policies=[pretrained/nope]"], "nope")):
        with pytest.raises((ValueError, FileNotFoundError), match=match):
            run_compare(["compare.strategies=[sto,policy]", *bad])


def test_gain_scan_gain_one_is_the_policy_and_gain_zero_is_spherical(pretrained, compose_cfg):
    from swimrl.analysis.gain_scan import gain_scan

    size = ["eval.n_flows=2", "eval.n_swimmers=8"]
    rows = gain_scan(gain_scan_config(compose_cfg(
        SMALL + size + ["policy=pretrained/ku10", "gains=[1,0]"], name="gain_scan")))
    alone = run_eval(compose_cfg(SMALL + size + ["strategy=policy", "policy=pretrained/ku10"]))
    assert rows[0]["per_flow"] == alone["per_flow"]
    naive0 = run_eval(compose_cfg(SMALL + size + ["strategy=naive", "strategy.shape_factor=0"]))
    assert rows[1]["per_flow"] == pytest.approx(naive0["per_flow"], rel=1e-6)
    with pytest.raises(ValueError, match="gains=.*allowed"):
        gain_scan_config(compose_cfg(SMALL + ["policy=pretrained/ku10", "gains=[-1]"],
                                     name="gain_scan"))


@pytest.mark.parametrize("min_std", [1e-4, 0.5])
def test_min_std_bounds_sigma_of_the_sampled_actions(min_std):
    """sigma = max(exp(log sigma), min_std): the log-probability of a sampled action is that of
    Lambda_max tanh(u), u ~ N(mu, sigma^2), computed here by hand."""
    actor = tanh_normal_actor(5, action_spec(0.98), init_std=1.0, min_std=min_std)
    scale_module = actor.module[0].module[1]
    with torch.no_grad():
        scale_module.state_independent_scale.fill_(math.log(0.1))
    sigma = max(0.1, min_std)
    td = actor(TensorDict({"observation": torch.randn(256, 5)}, [256]))
    assert torch.allclose(td["scale"], torch.full_like(td["scale"], sigma), rtol=1e-5)
    mu, lam = td["loc"], td["action"]
    u = torch.atanh(lam / 0.98)
    by_hand = (
        torch.distributions.Normal(mu, sigma).log_prob(u)
        - torch.log(0.98 * (1 - torch.tanh(u) ** 2))
    ).sum(-1)
    assert torch.allclose(td["action_log_prob"], by_hand, atol=2e-3)
    # below the bound log sigma gets no gradient
    td["action_log_prob"].sum().backward()
    grad = scale_module.state_independent_scale.grad
    assert (grad.abs().max() == 0) == (min_std > 0.1)
