r"""Several strategies on identical flows (``swimrl-compare``, ``swimrl-naive-scan``).

Every strategy is evaluated with the same ``seed``, hence on the same flow realisations and
from the same initial positions and orientations (common random numbers), either one after
the other or, with ``shared_flows``, all in one environment
(:func:`~swimrl.evaluation.rollout.evaluate_shared`). Besides each strategy's ``R_hat``
(mean +- SEM over flows) the record holds the paired ratio of its mean to the first
strategy's, with the delta-method standard error (:mod:`swimrl.evaluation.statistics`).

A long comparison (the paper's 100 flows x 1000 swimmers) is resumable: after every chunk
of ``eval.flows_per_batch`` flows the results so far go to ``comparison.partial.json``;
``compare.resume=true`` continues from it, simulating only the chunks not yet done, and the
final record is the uninterrupted one's (chunk ``c`` depends only on ``(seed, c)``). The
partial file names what it was computed for (the resolved config without the keys that do
not change results, the rows and a digest of every policy's parameters); a resume that
differs is refused. A preemption signal stops it after the chunk in flight
(:mod:`.jobs`).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from swimrl.conf_values import yaml_value
from swimrl.errors import BadFileError, ConfigError, as_bool
from swimrl.policies.baselines import STRATEGIES, StrategyLabel, StrategySpec
from swimrl.policies.steering import parse_table
from swimrl.runs.jobs import EvaluationInterruptedError, Preemption
from swimrl.runs.policy_files import resolve_policy_file, sha256_file
from swimrl.runs.records import summary_line, write_json
from swimrl.runs.spec import RunSpec

from .rollout import Actor, actor_for, check_chunks, evaluate_shared, flow_chunks
from .statistics import paired_difference, paired_ratio

#: Outcome keys a comparison row carries over from its strategy's metrics (where present).
ROW_OUTCOMES = ("energy_mean", "energy_sem", "energy_std", "energy_per_flow",
                "shape_change_mean", "shape_change_sem", "shape_change_std",
                "shape_change_per_flow", "swimming_mean", "swimming_sem", "swimming_std",
                "swimming_per_flow", "arrival_mean",
                "arrival_sem", "arrival_std", "arrival_per_flow", "final_distance_mean",
                "final_distance_sem", "final_distance_std", "final_distance_per_flow",
                "arrival_time_mean", "arrival_time_median", "n_arrived", "arrival_cdf_t",
                "arrival_cdf_mean", "arrival_cdf_sem", "arrival_time_rmst_mean",
                "arrival_time_rmst_sem", "arrival_time_half", "arrival_time_quartile",
                "trapped_mean", "trapped_sem", "trapped_std", "trapped_per_flow")

#: Config keys that do not change a comparison's results (left out of a partial's identity).
NOT_IDENTITY = (("overwrite",), ("threads",), ("eval", "progress"), ("compare", "resume"))


@dataclass(frozen=True)
class Variant:
    """One row of a comparison: a label, a strategy and, for ``policy``, the policy spec."""

    label: str
    strategy: StrategySpec
    policy: str | None = None


@dataclass(frozen=True)
class CompareConfig:
    """``swimrl-compare``: the variants, evaluated on ``setup`` (shared flows or one by one).
    The defaults are read from ``conf/compare.yaml`` (``overwrite``: ``conf/evaluate.yaml``;
    :mod:`swimrl.conf_values`).

    Parameters
    ----------
    setup
        Flow, swimmer and episode parameters, runtime, sizes and seed of the evaluation.
    variants
        The strategies (:func:`strategy_variants` expands ``compare.*`` into them); the
        first is the reference of the ratios.
    shared_flows
        All variants in one environment, each its own block of swimmers per flow, from the
        same starts (``compare.shared_flows``).
    overwrite, resume
        Replace a finished comparison; continue from ``comparison.partial.json``.
    """

    setup: RunSpec
    variants: tuple[Variant, ...]
    shared_flows: bool = yaml_value("compare", "compare.shared_flows")
    overwrite: bool = yaml_value("evaluate", "overwrite")
    resume: bool = yaml_value("compare", "compare.resume")

    def __post_init__(self) -> None:
        for v in self.variants:
            v.strategy.check_bound(self.setup.params.shape_factor_max)
            v.strategy.check_dimension(self.setup.dimension)
            v.strategy.check_actuation(self.setup.params.actuation)
        as_bool("compare.shared_flows", self.shared_flows)
        as_bool("overwrite", self.overwrite)
        as_bool("compare.resume", self.resume)


def strategy_variants(
    strategies: Sequence[str],
    naive_shape_factors: Sequence[float] = yaml_value("compare", "compare.naive_shape_factors"),
    minimal: Sequence[float] = tuple(yaml_value("compare", f"compare.minimal.c{i}")
                                     for i in (1, 2, 3, 4)),
    policies: Sequence[str] = yaml_value("compare", "compare.policies"),
    minimal_fits: Sequence[tuple[str, Sequence[float]]] = yaml_value(
        "compare", "compare.minimal_fits"),
    sto_amplitudes: Sequence[Sequence[float]] = yaml_value("compare", "compare.sto_amplitudes"),
    optimised_presets: Sequence[tuple[str, Sequence[float]]] = yaml_value(
        "compare", "compare.optimised_presets"),
    tables: Sequence[str] = yaml_value("compare", "compare.tables"),
    hand_rule_threshold: float = yaml_value("compare", "compare.hand_rule_threshold"),
) -> tuple[Variant, ...]:
    """Variants of ``compare.strategies`` (the keyword defaults: read from ``conf/compare.yaml``):
    ``naive`` expands over ``naive_shape_factors``, ``minimal`` takes the ``minimal``
    coefficients c1..c4, or expands over the labelled ``minimal_fits`` where given, and
    ``policy`` expands over ``policies`` (run dirs, checkpoints, ``pretrained/NAME``), ``sto``
    over the pairs ``(a_+, a_-)`` of ``sto_amplitudes`` where given (the energy-aware family,
    :class:`~swimrl.policies.baselines.ShortTimeOptimal`), ``optimised`` over the labelled
    coefficients ``optimised_presets`` (``compare.optimised_presets``: preset names, resolved
    for the flow's dimension by :func:`~swimrl.policies.optimised.preset_coefficients`);
    with ``actuation=steer``, ``hand_rule`` (vorticity edge ``hand_rule_threshold``) and
    ``table`` over the 12-letter ``tables``
    (:mod:`~swimrl.policies.steering`)."""
    allowed = "a list of 'naive', 'sto', 'minimal', 'optimised', 'policy'"
    labels = [label for label, _ in minimal_fits]
    if minimal_fits and "minimal" not in strategies:
        raise ConfigError(f"compare.minimal_fits has {len(labels)} fits but compare.strategies "
                          f"{list(strategies)} has no 'minimal': allowed only with 'minimal'")
    if optimised_presets and "optimised" not in strategies:
        raise ConfigError(f"compare.optimised_presets has {len(optimised_presets)} presets but "
                          f"compare.strategies {list(strategies)} has no 'optimised': allowed "
                          "only with 'optimised'")
    if len(set(labels)) < len(labels):
        raise ConfigError(f"compare.minimal_fits has run directories of the same name {labels}: "
                          "allowed fits whose directories have distinct names (the row labels)")
    out: list[Variant] = []
    for name in strategies:
        if name == "naive":
            for lam in naive_shape_factors:
                spec = StrategySpec("naive", shape_factor=float(lam))
                out.append(Variant(StrategyLabel.naive(lam).label, spec))
        elif name == "sto" and sto_amplitudes:
            for pair in sto_amplitudes:
                spec = StrategySpec("sto", amplitudes=tuple(pair))
                out.append(Variant(StrategyLabel.sto(spec.amplitudes).label, spec))
        elif name == "sto":
            out.append(Variant(StrategyLabel("sto").label, StrategySpec("sto")))
        elif name == "minimal" and minimal_fits:
            out += [Variant(StrategyLabel.minimal(label).label,
                            StrategySpec("minimal", coeffs=tuple(c)))
                    for label, c in minimal_fits]
        elif name == "minimal":
            out.append(Variant(StrategyLabel.minimal().label,
                               StrategySpec("minimal", coeffs=tuple(minimal))))
        elif name == "optimised":
            if not optimised_presets:
                raise ConfigError("compare.strategies has 'optimised' but "
                                  "compare.optimised_presets is empty: allowed a list of "
                                  "presets of swimrl.policies.optimised.PRESETS")
            out += [Variant(StrategyLabel("optimised", str(label)).label,
                            StrategySpec("optimised", coeffs=tuple(c)))
                    for label, c in optimised_presets]
        elif name == "hand_rule":
            spec = StrategySpec("hand_rule", threshold=float(hand_rule_threshold))
            out.append(Variant(StrategyLabel("hand_rule").label, spec))
        elif name == "table":
            if not tables:
                raise ConfigError("compare.strategies has 'table' but compare.tables is empty: "
                                  "allowed a list of 12-letter tables (r, u, l, d)")
            out += [Variant(StrategyLabel("table", str(t)).label,
                            StrategySpec("table", table=parse_table(t))) for t in tables]
        elif name == "policy":
            if not policies:
                raise ConfigError("compare.strategies has 'policy' but compare.policies is empty: "
                                  "allowed a list of run dirs, checkpoints or pretrained/NAME")
            out += [Variant(StrategyLabel.policy(p).label, StrategySpec("policy"), str(p))
                    for p in policies]
        else:
            raise ConfigError(f"compare.strategies has {name!r}: allowed one of {list(STRATEGIES)}")
    if not out:
        raise ConfigError(f"compare.strategies is empty: allowed {allowed}")
    return tuple(out)


def _digest(actor: Actor) -> str:
    """sha256 of a policy's parameters and buffers; a baseline's spec (its name, shape factor
    and coefficients) as text."""
    if not isinstance(actor, torch.nn.Module):
        return repr(actor)
    h = hashlib.sha256()
    for name, t in sorted(actor.state_dict().items()):
        h.update(name.encode())
        h.update(t.detach().cpu().contiguous().numpy().tobytes())
    return h.hexdigest()


def identity(cfg: CompareConfig, actors: Sequence[Actor]) -> dict:
    """What a comparison's results depend on: the resolved config less
    :data:`NOT_IDENTITY`, the row labels and the policies' digests (JSON-plain)."""
    record = json.loads(json.dumps(cfg.setup.record))
    for path in NOT_IDENTITY:
        node = record
        for key in path[:-1]:
            node = node.get(key, {})
        node.pop(path[-1], None)
    return {"config": record, "rows": [v.label for v in cfg.variants],
            "digests": [_digest(a) for a in actors]}


def load_partial(path: Path, expected: dict) -> dict:
    """The chunk results of ``path`` (a run directory's ``comparison.partial.json``,
    :attr:`~swimrl.runs.layout.RunLayout.comparison_partial`), refused (ConfigError) unless
    they were computed for ``expected`` (:func:`identity`)."""
    try:
        saved = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadFileError(f"{path}: not readable JSON ({exc}); allowed: a partial comparison "
                           "written by swimrl-compare, or overwrite=true to start again") from exc
    if not isinstance(saved, dict) or saved.get("identity") != expected:
        diff = _first_difference(saved.get("identity", {}) if isinstance(saved, dict)
                                 else saved, expected)
        raise ConfigError(f"compare.resume=true: {path} was computed for another comparison "
                          f"({diff}); allowed: the same config, rows and policies, or "
                          "overwrite=true to start again")
    return saved


def _first_difference(a: object, b: object, key: str = "") -> str:
    """``key: saved A, now B`` for the first nested entry where ``a`` and ``b`` differ."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b), key=str):
            if a.get(k) != b.get(k):
                return _first_difference(a.get(k), b.get(k), f"{key}.{k}" if key else str(k))
    return f"{key or 'identity'}: saved {a!r}, now {b!r}"


def compare(cfg: CompareConfig, partial: Path | None = None,
            preemption: Preemption | None = None) -> dict:
    """Evaluate all variants (every policy loaded first) and return the comparison record;
    with ``partial`` (a run directory's ``comparison.partial.json``) the chunk results are
    saved there as they come and, with ``cfg.resume``, the ones already there are reused. A
    ``preemption`` requested (a signal, :mod:`.jobs`) stops the comparison before the next
    decision of the chunk in flight, whose work is dropped, once ``partial`` holds the
    finished chunks (:meth:`~.jobs.Preemption.stop`: exit status
    :data:`~.jobs.PREEMPTED_EXIT`), unless no chunk is left to do.

    Parameters
    ----------
    cfg
        The comparison (``swimrl.config.compare_config`` maps ``swimrl-compare``'s config
        onto it).
    partial
        A run directory's ``comparison.partial.json``, or None.
    preemption
        Set by a signal handler to stop between chunks, or None.

    Returns
    -------
    dict
        The comparison record (``comparison.json``): one row per variant with ``R_hat`` per
        flow, its mean +- SEM and ``ratio_to_first`` paired over flows.
    """
    setup = cfg.setup
    actors = [actor_for(v.strategy, v.policy, setup.params) for v in cfg.variants]
    n = len(actors)
    groups = [list(range(n))] if cfg.shared_flows else [[i] for i in range(n)]
    state = {"identity": identity(cfg, actors), "done": [[] for _ in groups]}
    if partial is not None and cfg.resume and Path(partial).exists():
        state = load_partial(partial, state["identity"])
        try:
            if not (isinstance(state.get("done"), list) and len(state["done"]) == len(groups)):
                raise ValueError(f"not one chunk list per group of strategies ({len(groups)})")
            for g, done in zip(groups, state["done"], strict=True):
                check_chunks(done, flow_chunks(setup.sizes), len(g))
        except ValueError as exc:
            raise BadFileError(f"{partial}: {exc}; allowed: a partial comparison written by "
                               "swimrl-compare, or overwrite=true to start again") from exc
        print(f"resuming {partial}: "
              + ", ".join(f"{len(d)} chunk(s) of {'+'.join(cfg.variants[i].label for i in g)}"
                          for d, g in zip(state["done"], groups, strict=True)), flush=True)
    elif partial is not None and cfg.resume:
        print(f"compare.resume=true: no {partial}, starting from the first chunk", flush=True)
    results: list[dict] = [{} for _ in range(n)]
    n_chunks = len(flow_chunks(setup.sizes))

    def stop_if_preempted() -> None:
        """Once preempted: the partial record (re)written, then stop, unless all is done."""
        left = sum(n_chunks - len(done) for done in state["done"])
        if partial is not None and preemption is not None and preemption.requested and left:
            write_json(state, partial)
            preemption.stop(f"with {left} flow chunk(s) of {n_chunks * len(groups)} left: "
                            f"partial record written to {partial}; continue with "
                            "compare.resume=true")

    for g, done in zip(groups, state["done"], strict=True):

        def keep(chunk: dict, done: list = done) -> None:
            done.append(chunk)
            write_json(state, partial)
            stop_if_preempted()

        stop_if_preempted()

        labels = [cfg.variants[i].label for i in g]
        try:
            metrics = evaluate_shared(setup, [actors[i] for i in g], desc=" + ".join(labels),
                                      done=list(done), on_chunk=None if partial is None else keep,
                                      preemption=preemption if partial is not None else None)
        except EvaluationInterruptedError:
            stop_if_preempted()
            raise
        for i, m in zip(g, metrics, strict=True):
            m.update(label=cfg.variants[i].label, strategy=cfg.variants[i].strategy.name)
            results[i] = m
            line = (f"{m['label']}: R_hat = {m['R_hat_mean']:.4f} +- {m['R_hat_sem']:.4f} "
                    "(shared flows)") if cfg.shared_flows else summary_line(m)
            print(line, flush=True)
    ref = np.asarray(results[0]["per_flow"])
    rows = []
    for variant, m in zip(cfg.variants, results, strict=True):
        ratio, ratio_sem = paired_ratio(np.asarray(m["per_flow"]), ref)
        rows.append({"label": m["label"], "R_hat_mean": m["R_hat_mean"],
                     "R_hat_sem": m["R_hat_sem"], "R_hat_std": m["R_hat_std"],
                     "ratio_to_first": ratio, "ratio_sem": ratio_sem, "per_flow": m["per_flow"],
                     **{k: m[k] for k in ROW_OUTCOMES if k in m},
                     "swimmer_substeps_per_s": m["swimmer_substeps_per_s"],
                     "wall_s": m["wall_s"]})
        if variant.policy is not None:  # which exact file the row evaluated
            rows[-1].update(policy=variant.policy,
                            policy_sha256=sha256_file(resolve_policy_file(variant.policy)))
        if "arrival_per_flow" in m:
            diff, diff_sem = paired_difference(m["arrival_per_flow"],
                                               results[0]["arrival_per_flow"])
            rows[-1].update(arrival_minus_first=diff, arrival_minus_first_sem=diff_sem)
    first = results[0]
    return {
        "task": first["task"],
        **{k: first[k] for k in ("target_distance", "arrival_radius") if k in first},
        "shared_flows": bool(cfg.shared_flows),
        "rows": rows,
        "n_flows": first["n_flows"],
        "n_swimmers": first["n_swimmers"],
        "seed": first["seed"],
        "flow_stats": first["flow_stats"],
        "config": setup.record,
    }
