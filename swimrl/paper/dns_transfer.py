"""The transfer records of Fig. dnsFlow (c): the ``comparison.json`` of ``swimrl-compare``, one
per held-out DNS realisation (``dns.transfer``), read (:func:`read_transfer`) and summarised:
per strategy ``R_hat`` and ``R_hat / R_hat_STO``, the paired ratio of the means over all flows
with its delta-method SEM and each realisation's own ratio with their std over realisations
(:func:`transfer_summary`; start times of one stored run overlap, so their spread would
understate it); the transferred policy against the DNS-trained runs, realisation by
realisation (:func:`trained_ratio`); and their Markdown tables (``dnsFlow_transfer.md``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from swimrl.evaluation.statistics import paired_ratio
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import markdown_table


def transfer_records(root: Path) -> list[Path]:
    """The ``comparison.json`` files under ``root``, one per held-out realisation, in the
    order every transfer reader uses."""
    return sorted(Path(root).rglob(RunLayout(root).comparison.name))


def read_transfer(root: Path) -> dict[str, np.ndarray]:
    """Per-flow ``R_hat`` of each strategy label over every ``comparison.json`` under
    ``root`` (one per held-out realisation), concatenated over realisations:
    ``{label: (flows,)}``, plus ``realisation`` (the index of each flow's record)."""
    per: dict[str, list[np.ndarray]] = {}
    which: list[np.ndarray] = []
    for i, path in enumerate(transfer_records(root)):
        rec = json.loads(path.read_text())
        for row in rec["rows"]:
            per.setdefault(row["label"], []).append(np.asarray(row["per_flow"], dtype=float))
        which.append(np.full(len(rec["rows"][0]["per_flow"]), i))
    if not per:
        return {}
    sizes = {len(v) for v in per.values()}
    if sizes != {len(which)}:
        raise ValueError(f"{root}: the records do not all hold the same strategies")
    out = {k: np.concatenate(v) for k, v in per.items()}
    out["realisation"] = np.concatenate(which)
    return out


def sample_std(x: np.ndarray) -> float:
    """The std with ``ddof = 1``; NaN for fewer than two values."""
    return float(np.std(x, ddof=1)) if np.size(x) > 1 else math.nan


def realisation_ratios(num: np.ndarray, den: np.ndarray, real: np.ndarray) -> np.ndarray:
    """``<num>_i / <den>_i`` for each realisation ``i`` (means over its flows, the same flows
    for both)."""
    return np.array([num[real == i].mean() / den[real == i].mean() for i in np.unique(real)])


def transfer_summary(per: dict[str, np.ndarray], reference: str = "sto") -> dict[str, dict]:
    """Per label: ``R_hat`` (mean and std over flows), the paired ratio of its mean to the
    ``reference``'s over all flows with its delta-method SEM (``ratio``, ``ratio_sem``, as
    ``swimrl-compare``), each realisation's own paired ratio and their std over
    realisations (``ratio_realisation_std``: the bars of Fig. dnsFlow(c))."""
    ref, real = per[reference], per["realisation"]
    out = {}
    for label, r in per.items():
        if label == "realisation":
            continue
        ratio, sem = paired_ratio(r, ref)
        by_real = realisation_ratios(r, ref, real)
        out[label] = {"R_hat": float(r.mean()), "R_hat_std": sample_std(r),
                      "ratio": ratio, "ratio_sem": sem,
                      "ratio_realisations": by_real.tolist(),
                      "ratio_realisation_std": sample_std(by_real),
                      "n_flows": int(r.size), "n_realisations": int(len(by_real))}
    return out


def transfer_markdown(summary: dict[str, dict]) -> str:
    """The transfer table: per strategy R_hat (mean and std over flows), the paired ratio to
    STO over all flows (+- delta-method SEM), each realisation's ratio and their std."""
    rows = []
    for label, s in summary.items():
        per = ", ".join(f"{r:.3f}" for r in s["ratio_realisations"])
        rows.append([label, f"{s['R_hat']:.3f} ± {s['R_hat_std']:.3f}",
                     f"{s['ratio']:.3f} ± {s['ratio_sem']:.3f}", per,
                     f"{s['ratio_realisation_std']:.3f}"])
    n = next(iter(summary.values()))
    head = ["strategy", f"R̂ (mean ± std over {n['n_flows']} flows)",
            "R̂ / R̂_STO (paired, ± SEM)",
            f"per realisation ({n['n_realisations']})", "std over realisations"]
    return markdown_table(head, rows)


def trained_ratio(per: dict[str, np.ndarray], transferred: str,
                  trained: Sequence[str]) -> dict:
    """The transferred policy against the DNS-trained runs, realisation by realisation:
    ``r_{k,i} = <R_hat_transferred>_i / <R_hat_trained_k>_i`` (means over the flows of
    realisation ``i``, the same flows for both), per realisation the mean and std over the
    runs ``k``, and per run its ratio over all flows."""
    real = per["realisation"]
    num = per[transferred]
    runs = np.array([realisation_ratios(num, per[t], real) for t in trained])  # (runs, real.)
    overall = [float(num.mean() / per[t].mean()) for t in trained]
    return {"transferred": transferred, "trained": list(trained),
            "per_realisation": runs.T.tolist(),
            "realisation_mean": runs.mean(0).tolist(),
            "realisation_std_over_runs": [sample_std(c) for c in runs.T],
            "overall": overall, "overall_mean": float(np.mean(overall)),
            "overall_std_over_runs": sample_std(np.asarray(overall))}


def realisation_names(root: Path) -> list[str]:
    """The held-out realisations of :func:`read_transfer` in its order: the directory of
    each ``comparison.json`` under ``root``."""
    return [p.parent.name for p in transfer_records(root)]


def trained_ratio_markdown(r: dict, names: Sequence[str] | None = None) -> str:
    """One row per held-out realisation (``names``, default 1, 2, ...): the ratio for each
    DNS-trained run, mean and std over the runs; last row: all flows."""
    head = ["held-out realisation", *[f"÷ {t}" for t in r["trained"]], "mean", "std over runs"]
    names = list(names) if names else [str(i + 1) for i in range(len(r["per_realisation"]))]
    rows = [[name, *[f"{v:.3f}" for v in per], f"{m:.3f}", f"{sd:.3f}"]
            for name, per, m, sd in zip(names, r["per_realisation"], r["realisation_mean"],
                                        r["realisation_std_over_runs"], strict=True)]
    rows.append(["all flows", *[f"{v:.3f}" for v in r["overall"]], f"{r['overall_mean']:.3f}",
                 f"{r['overall_std_over_runs']:.3f}"])
    return (f"{r['transferred']} / DNS-trained run, per held-out realisation (ratio of the "
            "mean R̂ over the same flows):\n\n" + markdown_table(head, rows))
