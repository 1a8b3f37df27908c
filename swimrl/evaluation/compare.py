r"""Several strategies on identical flows (``swimrl-compare``, ``swimrl-naive-scan``).

Every strategy is evaluated with the same ``seed``, hence on the same flow realisations and
from the same initial positions and orientations (common random numbers), either one after
the other or, with ``shared_flows``, all in one environment
(:func:`~swimrl.evaluation.rollout.evaluate_shared`). Besides each strategy's ``R_hat``
(mean +- SEM over flows) the record holds the paired ratio of its mean to the first
strategy's, with the delta-method standard error (:mod:`swimrl.evaluation.statistics`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from swimrl.errors import ConfigError
from swimrl.policies.baselines import STRATEGIES, StrategySpec

from .records import summary_line
from .rollout import EvalSetup, actor_for, evaluate, evaluate_shared
from .statistics import paired_ratio


@dataclass(frozen=True)
class Variant:
    """One row of a comparison: a label, a strategy and, for ``policy``, the policy spec."""

    label: str
    strategy: StrategySpec
    policy: str | None = None


@dataclass(frozen=True)
class CompareConfig:
    """``swimrl-compare``: the variants, evaluated on ``setup`` (shared flows or one by one)."""

    setup: EvalSetup
    variants: tuple[Variant, ...]
    shared_flows: bool = False
    overwrite: bool = False


def strategy_variants(
    strategies: Sequence[str],
    naive_shape_factors: Sequence[float] = (0.98,),
    minimal: Sequence[float] = (1.0, 0.0, 0.0, 0.0),
    policies: Sequence[str] = (),
    minimal_fits: Sequence[tuple[str, Sequence[float]]] = (),
) -> tuple[Variant, ...]:
    """Variants of ``compare.strategies``: ``naive`` expands over ``naive_shape_factors``,
    ``minimal`` takes the ``minimal`` coefficients c1..c4, or expands over the labelled
    ``minimal_fits`` where given, and ``policy`` expands over ``policies`` (run dirs,
    checkpoints, ``pretrained/NAME``)."""
    allowed = "a list of 'naive', 'sto', 'minimal', 'policy'"
    labels = [label for label, _ in minimal_fits]
    if minimal_fits and "minimal" not in strategies:
        raise ConfigError(f"compare.minimal_fits has {len(labels)} fits but compare.strategies "
                          f"{list(strategies)} has no 'minimal': allowed only with 'minimal'")
    if len(set(labels)) < len(labels):
        raise ConfigError(f"compare.minimal_fits has run directories of the same name {labels}: "
                          "allowed fits whose directories have distinct names (the row labels)")
    out: list[Variant] = []
    for name in strategies:
        if name == "naive":
            for lam in naive_shape_factors:
                spec = StrategySpec("naive", shape_factor=float(lam))
                out.append(Variant(f"naive({float(lam):+.2f})", spec))
        elif name == "sto":
            out.append(Variant("sto", StrategySpec("sto")))
        elif name == "minimal" and minimal_fits:
            out += [Variant(f"minimal({label})", StrategySpec("minimal", coeffs=tuple(c)))
                    for label, c in minimal_fits]
        elif name == "minimal":
            out.append(Variant("minimal", StrategySpec("minimal", coeffs=tuple(minimal))))
        elif name == "policy":
            if not policies:
                raise ConfigError("compare.strategies has 'policy' but compare.policies is empty: "
                                  "allowed a list of run dirs, checkpoints or pretrained/NAME")
            out += [Variant(f"policy({p})", StrategySpec("policy"), str(p)) for p in policies]
        else:
            raise ConfigError(f"compare.strategies has {name!r}: allowed one of {list(STRATEGIES)}")
    if not out:
        raise ConfigError(f"compare.strategies is empty: allowed {allowed}")
    return tuple(out)


def compare(cfg: CompareConfig) -> dict:
    """Evaluate all variants (every policy loaded first) and return the comparison record."""
    setup = cfg.setup
    actors = [actor_for(v.strategy, v.policy, setup.params) for v in cfg.variants]
    results = []
    if cfg.shared_flows:
        for v, m in zip(cfg.variants, evaluate_shared(setup, actors), strict=True):
            m.update(label=v.label, strategy=v.strategy.name)
            print(f"{v.label}: R_hat = {m['R_hat_mean']:.4f} +- {m['R_hat_sem']:.4f} "
                  "(shared flows)", flush=True)
            results.append(m)
    else:
        for v, actor in zip(cfg.variants, actors, strict=True):
            m = evaluate(setup, actor, v.strategy.name)
            m["label"] = v.label
            print(summary_line(m), flush=True)
            results.append(m)
    ref = np.asarray(results[0]["per_flow"])
    rows = []
    for m in results:
        ratio, ratio_sem = paired_ratio(np.asarray(m["per_flow"]), ref)
        rows.append({"label": m["label"], "R_hat_mean": m["R_hat_mean"],
                     "R_hat_sem": m["R_hat_sem"], "R_hat_std": m["R_hat_std"],
                     "ratio_to_first": ratio, "ratio_sem": ratio_sem, "per_flow": m["per_flow"],
                     "swimmer_substeps_per_s": m["swimmer_substeps_per_s"],
                     "wall_s": m["wall_s"]})
    first = results[0]
    return {
        "shared_flows": bool(cfg.shared_flows),
        "rows": rows,
        "n_flows": first["n_flows"],
        "n_swimmers": first["n_swimmers"],
        "seed": first["seed"],
        "flow_stats": first["flow_stats"],
        "config": setup.record,
    }
