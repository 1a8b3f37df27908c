"""Strategies sharing flows (compare.shared_flows): routing, independence, equivalence."""

from __future__ import annotations

import pytest

from swimrl.compare import compare
from swimrl.evaluate import evaluate
from swimrl.shared_eval import evaluate_shared
from swimrl.strategies import build_strategy

from .conftest import SMALL

SIZE = ["eval.n_flows=3", "eval.flows_per_batch=2", "eval.n_swimmers=6"]


def _strategy(compose_cfg, *over):
    cfg = compose_cfg(SMALL + SIZE + list(over))
    return build_strategy(cfg.strategy, float(cfg.episode.shape_factor_max))


def test_one_block_is_the_plain_evaluation(compose_cfg):
    cfg = compose_cfg(SMALL + SIZE + ["strategy=sto"])
    (shared,) = evaluate_shared(cfg, [_strategy(compose_cfg, "strategy=sto")])
    assert shared["per_flow"] == evaluate(cfg)["per_flow"]


def test_blocks_are_independent_and_routed(compose_cfg):
    """Block 0 of [STO, naive] equals block 0 of [STO, STO]: swimmers do not interact, each
    block follows its own strategy, and the flows are the same for every block."""
    cfg = compose_cfg(SMALL + SIZE)
    sto = _strategy(compose_cfg, "strategy=sto")
    naive = _strategy(compose_cfg, "strategy=naive", "strategy.shape_factor=-0.5")
    mixed = evaluate_shared(cfg, [sto, naive])
    same = evaluate_shared(cfg, [sto, sto])
    both_naive = evaluate_shared(cfg, [naive, naive])
    assert mixed[0]["per_flow"] == same[0]["per_flow"]
    assert mixed[1]["per_flow"] == both_naive[1]["per_flow"]
    assert mixed[0]["per_flow"] != mixed[1]["per_flow"]
    assert len(mixed[0]["per_flow"]) == 3


def test_compare_with_shared_flows(compose_cfg):
    over = SMALL + SIZE + ["compare.strategies=[sto,naive]", "compare.shared_flows=true"]
    rec = compare(compose_cfg(over, name="compare"))
    assert rec["shared_flows"] and [r["label"] for r in rec["rows"]] == ["sto", "naive(+0.98)"]
    ref = evaluate_shared(compose_cfg(SMALL + SIZE), [
        _strategy(compose_cfg, "strategy=sto"),
        _strategy(compose_cfg, "strategy=naive", "strategy.shape_factor=0.98")])
    assert rec["rows"][1]["per_flow"] == pytest.approx(ref[1]["per_flow"], rel=0, abs=0)
