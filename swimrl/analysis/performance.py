r"""Smart vs STO vs naive across Kubo numbers: the paper's Fig. "smartPerformance"(a).

Reads ``comparison.json`` files written by ``swimrl-compare`` (one per Ku, each with the rows
``sto``, ``naive(+0.98)`` and one ``policy(...)`` row per training seed, all on the same
held-out flows) and writes a Markdown table and a PNG plot of ``R_hat`` against Ku:

    swimrl-performance outputs/results/smart_ku_sweep --out docs/img/smart_performance.png

For every Ku the table gives ``R_hat`` (mean +- SEM over flows, std over flows) of each
strategy, each seed's paired ratios ``R_smart / R_STO`` and ``R_smart / max(R_naive,
R_STO)`` (delta-method SEM, as in ``swimrl-compare``), and the mean and standard deviation
over seeds. The plot shows the mean over flows with error bars of one standard deviation
over flows (as in the paper), smart as the mean over seeds with each seed as a small marker.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from swimrl.evaluation.statistics import mean_std_sem, paired_ratio
from swimrl.flows.labels import ku_number
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import markdown_table

#: The baseline rows every comparison must hold: STO and the paper's naive (Lambda = 0.98).
STO, NAIVE = StrategyLabel("sto").label, StrategyLabel.naive(0.98).label


def load(paths: list[Path]) -> list[dict]:
    """``comparison.json`` records (files, or directories searched recursively), sorted by Ku."""
    files: list[Path] = []
    for p in paths:
        p = Path(p)
        if not p.exists():
            raise FileNotFoundError(f"no comparison.json at {p}: the path does not exist")
        files += sorted(p.rglob(RunLayout(p).comparison.name)) if p.is_dir() else [p]
    if not files:
        raise FileNotFoundError(f"no comparison.json under {[str(p) for p in paths]}")
    recs = [json.loads(f.read_text()) for f in files]
    for f, r in zip(files, recs, strict=True):
        r["_path"] = str(f)
    return sorted(recs, key=lambda r: float(r["config"]["flow"].get("kubo", math.inf)))


def summarise(rec: dict, exclude: tuple[str, ...] = ()) -> dict:
    """Per-Ku summary: baselines, smart seeds, paired ratios and their mean/std over seeds.

    Every ``policy(...)`` row counts as one seed of the smart strategy, except rows whose
    label contains one of the ``exclude`` substrings (e.g. extra policies in the comparison).
    """
    rows = {r["label"]: r for r in rec["rows"]}
    if STO not in rows or NAIVE not in rows:
        raise ValueError(f"{rec['_path']}: needs the rows {STO!r} and {NAIVE!r}")
    sto = np.asarray(rows[STO]["per_flow"])
    naive = np.asarray(rows[NAIVE]["per_flow"])
    best = naive if naive.mean() > sto.mean() else sto
    seeds = []
    for label, r in rows.items():
        if StrategyLabel.parse(label).name != "policy" or any(x in label for x in exclude):
            continue
        per = np.asarray(r["per_flow"])
        seeds.append({"label": label, "R_hat_mean": r["R_hat_mean"], "R_hat_sem": r["R_hat_sem"],
                      "R_hat_std": r["R_hat_std"], "per_flow": per,
                      "vs_sto": paired_ratio(per, sto), "vs_best": paired_ratio(per, best)})
    smart_mean, smart_std, _ = mean_std_sem([s["R_hat_mean"] for s in seeds]) if seeds else (
        math.nan, 0.0, 0.0)
    return {
        "kubo": float(rec["config"]["flow"]["kubo"]),
        "n_flows": rec["n_flows"],
        "n_swimmers": rec["n_swimmers"],
        "seed": rec["seed"],
        "naive": rows[NAIVE],
        "sto": rows[STO],
        "best_baseline": "naive" if best is naive else "STO",
        "seeds": seeds,
        "smart_mean": smart_mean,
        "smart_seed_std": smart_std,
        "vs_sto_mean": float(np.mean([s["vs_sto"][0] for s in seeds])) if seeds else math.nan,
        "vs_best_mean": float(np.mean([s["vs_best"][0] for s in seeds])) if seeds else math.nan,
    }


def markdown(summaries: list[dict]) -> str:
    """Two tables: R_hat per strategy and seed; paired ratios per seed."""
    rows = []
    for s in summaries:
        seeds = ", ".join(f"{x['R_hat_mean']:.3f}±{x['R_hat_sem']:.3f}" for x in s["seeds"])
        rows.append([ku_number(s["kubo"]), f"{s['n_flows']} x {s['n_swimmers']}",
                     f"{s['naive']['R_hat_mean']:.3f}±{s['naive']['R_hat_sem']:.3f}",
                     f"{s['sto']['R_hat_mean']:.3f}±{s['sto']['R_hat_sem']:.3f}", seeds,
                     f"{s['smart_mean']:.3f} ± {s['smart_seed_std']:.3f}"])
    ratios = []
    for s in summaries:
        r1 = ", ".join(f"{x['vs_sto'][0]:.3f}±{x['vs_sto'][1]:.3f}" for x in s["seeds"])
        r2 = ", ".join(f"{x['vs_best'][0]:.3f}±{x['vs_best'][1]:.3f}" for x in s["seeds"])
        ratios.append([ku_number(s["kubo"]), r1, f"{s['vs_sto_mean']:.3f}", r2,
                       f"{s['vs_best_mean']:.3f}", s["best_baseline"]])
    return (markdown_table(["Ku", "flows x swimmers", "naive (Λ=0.98)", "STO", "smart, per seed",
                            "smart, mean ± std over seeds"], rows) + "\n"
            + markdown_table(["Ku", "smart / STO, per seed (paired)", "mean",
                              "smart / max(naive, STO), per seed", "mean", "best baseline"],
                             ratios))
