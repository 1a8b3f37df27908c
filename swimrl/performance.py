r"""Smart vs STO vs naive across Kubo numbers: the paper's Fig. "smartPerformance"(a).

Reads ``comparison.json`` files written by ``swimrl-compare`` (one per Ku, each with the rows
``sto``, ``naive(+0.98)`` and one ``policy(...)`` row per training seed, all on the same
held-out flows) and writes a Markdown table and a PNG plot of ``R_hat`` against Ku:

    python -m swimrl.performance outputs/results/smart_ku_sweep --out docs/img/smart_performance.png

For every Ku the table gives ``R_hat`` (mean +- SEM over flows, std over flows) of each
strategy, each seed's paired ratios ``R_smart / R_STO`` and ``R_smart / max(R_naive,
R_STO)`` (delta-method SEM, as in ``swimrl-compare``), and the mean and standard deviation
over seeds. The plot shows the mean over flows with error bars of one standard deviation
over flows (as in the paper), smart as the mean over seeds with each seed as a small marker.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from swimrl.compare import paired_ratio


def load(paths: list[Path]) -> list[dict]:
    """``comparison.json`` records (files, or directories searched recursively), sorted by Ku."""
    files: list[Path] = []
    for p in paths:
        p = Path(p)
        if not p.exists():
            raise FileNotFoundError(f"no comparison.json at {p}: the path does not exist")
        files += sorted(p.rglob("comparison.json")) if p.is_dir() else [p]
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
    if "sto" not in rows or "naive(+0.98)" not in rows:
        raise ValueError(f"{rec['_path']}: needs the rows 'sto' and 'naive(+0.98)'")
    sto = np.asarray(rows["sto"]["per_flow"])
    naive = np.asarray(rows["naive(+0.98)"]["per_flow"])
    best = naive if naive.mean() > sto.mean() else sto
    seeds = []
    for label, r in rows.items():
        if not label.startswith("policy(") or any(x in label for x in exclude):
            continue
        per = np.asarray(r["per_flow"])
        seeds.append({"label": label, "R_hat_mean": r["R_hat_mean"], "R_hat_sem": r["R_hat_sem"],
                      "R_hat_std": r["R_hat_std"], "per_flow": per,
                      "vs_sto": paired_ratio(per, sto), "vs_best": paired_ratio(per, best)})
    means = np.asarray([s["R_hat_mean"] for s in seeds])
    return {
        "kubo": float(rec["config"]["flow"]["kubo"]),
        "n_flows": rec["n_flows"],
        "n_swimmers": rec["n_swimmers"],
        "seed": rec["seed"],
        "naive": rows["naive(+0.98)"],
        "sto": rows["sto"],
        "best_baseline": "naive" if best is naive else "STO",
        "seeds": seeds,
        "smart_mean": float(means.mean()) if seeds else math.nan,
        "smart_seed_std": float(means.std(ddof=1)) if len(seeds) > 1 else 0.0,
        "vs_sto_mean": float(np.mean([s["vs_sto"][0] for s in seeds])) if seeds else math.nan,
        "vs_best_mean": float(np.mean([s["vs_best"][0] for s in seeds])) if seeds else math.nan,
    }


def markdown(summaries: list[dict]) -> str:
    """Two tables: R_hat per strategy and seed; paired ratios per seed."""
    out = ["| Ku | flows x swimmers | naive (Λ=0.98) | STO | smart, per seed "
           "| smart, mean ± std over seeds |", "|---|---|---|---|---|---|"]
    for s in summaries:
        seeds = ", ".join(f"{x['R_hat_mean']:.3f}±{x['R_hat_sem']:.3f}" for x in s["seeds"])
        out.append(f"| {s['kubo']:g} | {s['n_flows']} x {s['n_swimmers']} | "
                   f"{s['naive']['R_hat_mean']:.3f}±{s['naive']['R_hat_sem']:.3f} | "
                   f"{s['sto']['R_hat_mean']:.3f}±{s['sto']['R_hat_sem']:.3f} | {seeds} | "
                   f"{s['smart_mean']:.3f} ± {s['smart_seed_std']:.3f} |")
    out += ["", "| Ku | smart / STO, per seed (paired) | mean | smart / max(naive, STO), per seed "
            "| mean | best baseline |", "|---|---|---|---|---|---|"]
    for s in summaries:
        r1 = ", ".join(f"{x['vs_sto'][0]:.3f}±{x['vs_sto'][1]:.3f}" for x in s["seeds"])
        r2 = ", ".join(f"{x['vs_best'][0]:.3f}±{x['vs_best'][1]:.3f}" for x in s["seeds"])
        out.append(f"| {s['kubo']:g} | {r1} | {s['vs_sto_mean']:.3f} | {r2} | "
                   f"{s['vs_best_mean']:.3f} | {s['best_baseline']} |")
    return "\n".join(out) + "\n"


def plot(summaries: list[dict], path: Path) -> None:
    """``R_hat`` against Ku (log axis): naive, STO, smart (mean over seeds and each seed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ku = np.asarray([s["kubo"] for s in summaries])
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    baselines = (("naive", "k", r"naive ($\Lambda=0.98$)"), ("sto", "tab:green", "STO"))
    for key, color, label in baselines:
        ax.errorbar(ku, [s[key]["R_hat_mean"] for s in summaries],
                    yerr=[s[key]["R_hat_std"] for s in summaries], color=color, marker="o",
                    capsize=3, label=label)
    ax.errorbar(ku, [s["smart_mean"] for s in summaries],
                yerr=[np.mean([x["R_hat_std"] for x in s["seeds"]]) for s in summaries],
                color="tab:orange", marker="o", capsize=3, label="smart (mean over seeds)")
    for s in summaries:
        ax.plot([s["kubo"]] * len(s["seeds"]), [x["R_hat_mean"] for x in s["seeds"]], "_",
                color="tab:orange", markersize=10)
    ax.set_xscale("log")
    ax.set_xlabel("Ku")
    ax.set_ylabel(r"$\hat R$")
    ax.set_title("error bars: std over flows; dashes: seeds", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("paths", nargs="+", type=Path, help="comparison.json files or directories")
    ap.add_argument("--out", type=Path, default=None, help="PNG path (default: no plot)")
    ap.add_argument("--md", type=Path, default=None, help="also write the table to this file")
    ap.add_argument("--exclude", action="append", default=[],
                    help="leave out policy rows whose label contains this (repeatable)")
    args = ap.parse_args(argv)
    summaries = [summarise(r, tuple(args.exclude)) for r in load(args.paths)]
    table = markdown(summaries)
    print(table)
    if args.md is not None:
        args.md.parent.mkdir(parents=True, exist_ok=True)
        args.md.write_text(table + "\n")
        print(f"wrote {args.md}")
    if args.out is not None:
        plot(summaries, args.out)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
