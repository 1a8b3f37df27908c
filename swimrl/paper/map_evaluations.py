"""The evaluations of the mechanism statistics (Figs. ku0.1, kuInf, ku_pattern): at each Ku,
for each of the protocol's training seeds (``<curves>/ku<KU>_seed<k>/policy.pt``,
``figures.map_seeds``), every decision of ``map_flows`` x ``map_swimmers`` swimmers
(:func:`map_evaluation`, group ``statistics``) streamed into the histograms of
:mod:`.decision_stats` and cached (:func:`map_record`); each evaluation's entry of a record
(:func:`map_values`: per-flow R_hat, the counts, the S_nn statistic, the correlations, the
agreement with STO), the numbers across seeds (:func:`per_seed`, :func:`map_correlations`),
and the :func:`~.records.extend_record` edit that adds the agreement with STO to a record
made before it was kept (:func:`add_sign_agreement`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from swimrl.evaluation.rollout import evaluate_shared
from swimrl.flows.labels import ku_name

from .decision_stats import (
    MAPS,
    SAMPLE_EVERY,
    SAMPLE_SIZE,
    SNN_BINS,
    DecisionRecorder,
    correlation,
    map_correlation,
    sign_agreement,
    snn_statistic,
)
from .evaluations import (
    Evaluation,
    actor,
    cache_inputs,
    cached,
    eval_setup,
    flow_summary,
    run_policy,
)
from .settings import FiguresConfig


def map_evaluation(cfg: FiguresConfig, kubo: float, seed: int) -> Evaluation:
    """The protocol's run at ``kubo``, training seed ``seed``, on ``map_flows`` x
    ``map_swimmers`` (group ``statistics``)."""
    return Evaluation(f"{ku_name(kubo)}_seed{seed}", "statistics",
                      eval_setup(cfg, kubo, cfg.map_flows, cfg.map_swimmers),
                      {"smart": run_policy(cfg, kubo, seed)})


def map_record(cfg: FiguresConfig, ev: Evaluation) -> dict[str, np.ndarray]:
    """The :class:`~.decision_stats.DecisionStats` arrays of ``ev``'s smart swimmers and their
    ``per_flow`` R_hat (cached)."""
    policy = ev.actors["smart"]

    def compute() -> dict[str, np.ndarray]:
        rec = DecisionRecorder()
        (m,) = evaluate_shared(ev.setup, [actor(policy, ev.setup.params)],
                               desc=f"{ev.key} decisions", recorder=rec)
        return {**rec.stats.arrays(), "per_flow": np.asarray(m["per_flow"])}

    return cached(cfg, f"decisions_{ev.key}",
                  {**cache_inputs(cfg, ev.setup, [policy]), "maps": repr(MAPS),
                   "snn_bins": SNN_BINS, "sample": [SAMPLE_EVERY, SAMPLE_SIZE],
                   "counts": ["sign_STO"]}, compute)


def map_values(cfg: FiguresConfig, ev: Evaluation) -> dict:
    """A statistics evaluation's entry of a record: per-flow R_hat, the counts, the S_nn
    statistic, the correlation of Lambda with ``n_theta S_np`` and the mean ``|Lambda|``."""
    a = map_record(cfg, ev)
    n = int(a["moments"][0])
    return {"per_flow": {"smart": a["per_flow"].tolist()},
            "counts": {"trajectories": ev.setup.sizes.n_flows * ev.setup.sizes.n_swimmers,
                       "decisions": n},
            "derived": {**flow_summary({"smart": a["per_flow"]}), "snn": snn_statistic(a),
                        "corr_Lambda_ntheta_Snp": correlation(a),
                        "mean_abs_Lambda": float(a["moments"][6] / max(n, 1)),
                        "sign_STO": sign_agreement(a)}}


def add_sign_agreement(cfg: FiguresConfig, evaluations: list[Evaluation]) -> Callable[[dict],
                                                                                        None]:
    """An :func:`~.records.extend_record` edit: :func:`sign_agreement` into each statistics
    evaluation of a record made before it was kept (``derived.sign_STO``, from the cached or
    re-simulated evaluation, with ``resimulated``: the largest difference of its per-flow
    R_hat from the record's and whether its decision count is the record's)."""
    def edit(rec: dict) -> None:
        for ev in evaluations:
            e = rec["evaluations"][ev.key]
            if e["derived"].get("sign_STO") is not None:
                continue
            a = map_record(cfg, ev)
            diff = np.abs(np.asarray(a["per_flow"]) - np.asarray(e["per_flow"]["smart"]))
            e["derived"]["sign_STO"] = {
                **sign_agreement(a),
                "resimulated": {"per_flow_max_abs_diff": float(diff.max()),
                                "same_decisions": int(a["moments"][0])
                                == e["counts"]["decisions"]}}

    return edit


def seed_evaluations(cfg: FiguresConfig, kubo: float) -> list[Evaluation]:
    return [map_evaluation(cfg, kubo, s) for s in cfg.map_seeds]


def per_seed(rec: dict, kubo: float, seeds: tuple[int, ...]) -> dict:
    """Per seed the S_nn statistic, the correlation and the counts of a record's statistics
    evaluations at ``kubo``, with the mean and std over seeds."""
    out: dict = {}
    for s in seeds:
        e = rec["evaluations"][f"{ku_name(kubo)}_seed{s}"]
        out[str(s)] = {"p_pos_given_low": e["derived"]["snn"]["p_pos_given_low"],
                       "p_neg_given_high": e["derived"]["snn"]["p_neg_given_high"],
                       "corr_Lambda_ntheta_Snp": e["derived"]["corr_Lambda_ntheta_Snp"],
                       "R_hat": e["derived"]["mean"]["smart"], **e["counts"]}
    keys = ["p_pos_given_low", "p_neg_given_high", "corr_Lambda_ntheta_Snp", "R_hat"]
    signs = [rec["evaluations"][f"{ku_name(kubo)}_seed{s}"]["derived"].get("sign_STO")
             for s in seeds]
    if all(signs):  # records made before the agreement with STO was kept have none
        for s, sign in zip(seeds, signs, strict=True):
            out[str(s)]["sign_agreement_STO"] = sign["fraction"]
        keys.append("sign_agreement_STO")
    for key in keys:
        v = np.array([out[str(s)][key] for s in seeds], dtype=float)
        out[f"{key}_mean"] = float(v.mean())
        out[f"{key}_std"] = float(v.std(ddof=1)) if v.size > 1 else 0.0
    return out


def map_correlations(cfg: FiguresConfig, kubo: float) -> dict[str, dict[str, float]]:
    """Correlation of the seeds' maps (``n_theta``, ``omega``) at ``kubo``, pair by pair."""
    arrays = {s: map_record(cfg, map_evaluation(cfg, kubo, s)) for s in cfg.map_seeds}
    seeds = list(arrays)
    return {name: {f"{a}-{b}": map_correlation(arrays[a], arrays[b], name)
                   for i, a in enumerate(seeds) for b in seeds[i + 1:]}
            for name in ("n_theta", "omega")}
