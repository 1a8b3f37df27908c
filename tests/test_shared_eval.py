"""Strategies sharing flows (compare.shared_flows): routing, independence, equivalence."""

from __future__ import annotations

import json

import pytest
import torch

from swimrl.config import compare_config, eval_config, eval_setup
from swimrl.env import build_env
from swimrl.evaluation.compare import compare
from swimrl.evaluation.rollout import evaluate, evaluate_shared
from swimrl.policies.baselines import StrategySpec

from .conftest import SMALL

SIZE = ["eval.n_flows=3", "eval.flows_per_batch=2", "eval.n_swimmers=6"]


def _strategy(compose_cfg, *over) -> StrategySpec:
    return eval_config(compose_cfg(SMALL + SIZE + list(over))).strategy


def test_one_block_is_the_plain_evaluation(compose_cfg):
    c = eval_config(compose_cfg(SMALL + SIZE + ["strategy=sto"]))
    (shared,) = evaluate_shared(c.setup, [_strategy(compose_cfg, "strategy=sto")])
    assert shared["per_flow"] == evaluate(c.setup, c.strategy, "sto")["per_flow"]


def test_blocks_are_independent_and_routed(compose_cfg):
    """Block 0 of [STO, naive] equals block 0 of [STO, STO]: swimmers do not interact, each
    block follows its own strategy, and the flows are the same for every block."""
    setup = eval_setup(compose_cfg(SMALL + SIZE))
    sto = _strategy(compose_cfg, "strategy=sto")
    naive = _strategy(compose_cfg, "strategy=naive", "strategy.shape_factor=-0.5")
    mixed = evaluate_shared(setup, [sto, naive])
    same = evaluate_shared(setup, [sto, sto])
    both_naive = evaluate_shared(setup, [naive, naive])
    assert mixed[0]["per_flow"] == same[0]["per_flow"]
    assert mixed[1]["per_flow"] == both_naive[1]["per_flow"]
    assert mixed[0]["per_flow"] != mixed[1]["per_flow"]
    assert len(mixed[0]["per_flow"]) == 3


def test_blocks_start_from_the_same_initial_conditions(compose_cfg):
    """Common random numbers: every block starts from the initial positions and orientations
    of the plain evaluation, so block j of [STO, naive] is the plain evaluation of its
    strategy, flow by flow (the dynamics has no noise), and the start states coincide."""
    c = eval_config(compose_cfg(SMALL + SIZE))
    sto = _strategy(compose_cfg, "strategy=sto")
    naive = _strategy(compose_cfg, "strategy=naive", "strategy.shape_factor=0.98")
    shared = evaluate_shared(c.setup, [sto, naive])
    runs = ((0, ["strategy=sto"]), (1, ["strategy=naive", "strategy.shape_factor=0.98"]))
    for block, over in runs:
        alone = eval_config(compose_cfg(SMALL + SIZE + over))
        plain = evaluate(alone.setup, alone.strategy, over[0])["per_flow"]
        assert shared[block]["per_flow"] == pytest.approx(plain, rel=1e-6, abs=0)
    env = build_env(c.setup.flow, c.setup.params, c.setup.runtime, 2, 6, 0, ic_blocks=3)
    env.reset()
    start = torch.cat([env.start_pos, env.theta.unsqueeze(-1)], dim=-1).view(2, 3, 2, 3)
    assert torch.equal(start[:, 1], start[:, 0]) and torch.equal(start[:, 2], start[:, 0])
    assert not torch.equal(start[0, 0, 0], start[0, 0, 1])  # swimmers within a block differ


def test_compare_with_shared_flows(compose_cfg):
    over = SMALL + SIZE + ["compare.strategies=[sto,naive]", "compare.shared_flows=true"]
    rec = compare(compare_config(compose_cfg(over, name="compare")))
    assert rec["shared_flows"] and [r["label"] for r in rec["rows"]] == ["sto", "naive(+0.98)"]
    ref = evaluate_shared(eval_setup(compose_cfg(SMALL + SIZE)), [
        _strategy(compose_cfg, "strategy=sto"),
        _strategy(compose_cfg, "strategy=naive", "strategy.shape_factor=0.98")])
    assert rec["rows"][1]["per_flow"] == pytest.approx(ref[1]["per_flow"], rel=0, abs=0)


def test_minimal_expands_over_fitted_coefficients(compose_cfg, tmp_path):
    """compare.minimal_fits: one 'minimal(<run dir>)' row per fit.json, with its c1..c4,
    equal to the minimal model given by compare.minimal."""
    fits = []
    for name, c in (("ku10", (0.9, 0.7, 0.3, 0.05)), ("ku1e7", (0.5, 0.2, 0.1, -0.1))):
        (tmp_path / name).mkdir()
        coeffs = dict(zip(("c1", "c2", "c3", "c4"), c, strict=True))
        (tmp_path / name / "fit.json").write_text(json.dumps({"coefficients": coeffs}))
        fits.append(str(tmp_path / name))
    over = SMALL + SIZE + ["compare.strategies=[minimal]", "compare.shared_flows=true",
                           f"compare.minimal_fits=[{fits[0]},{fits[1]}/fit.json]"]
    rec = compare(compare_config(compose_cfg(over, name="compare")))
    assert [r["label"] for r in rec["rows"]] == ["minimal(ku10)", "minimal(ku1e7)"]
    one = SMALL + SIZE + ["compare.strategies=[minimal,sto]", "compare.shared_flows=true",
                          "compare.minimal={c1:0.9,c2:0.7,c3:0.3,c4:0.05}"]
    ref = compare(compare_config(compose_cfg(one, name="compare")))
    # block 0 of a shared run is independent of the other blocks (test above)
    assert rec["rows"][0]["per_flow"] == ref["rows"][0]["per_flow"]
    assert rec["rows"][1]["per_flow"] != rec["rows"][0]["per_flow"]
