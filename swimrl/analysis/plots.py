"""Figures of result records: ``R_hat`` against a constant shape factor and against Ku; and
:func:`pyplot`, the one place the analysis imports ``matplotlib.pyplot`` (and chooses its
non-interactive backend), when a figure is drawn."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from swimrl.flows.labels import ku_display
from swimrl.policies.baselines import StrategyLabel


def pyplot():
    """``matplotlib.pyplot`` on the non-interactive Agg backend, imported when a figure is
    drawn (not when a module is imported)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_naive_scan(record: dict, path) -> None:
    """``R_hat`` (mean +- SEM) against the constant shape factor of naive strategies."""
    plt = pyplot()
    labels = [StrategyLabel.parse(r["label"]) for r in record["rows"]]
    scan = [(label.numbers[0], r) for label, r in zip(labels, record["rows"], strict=True)
            if label.name == "naive" and label.arg]
    if len(scan) < 2:
        return
    lam, rows = [x for x, _ in scan], [r for _, r in scan]
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.errorbar(
        lam,
        [r["R_hat_mean"] for r in rows],
        yerr=[r["R_hat_sem"] for r in rows],
        marker="o",
        capsize=3,
        color="k",
    )
    flow = record["config"]["flow"]
    ax.set_xlabel(r"constant shape factor $\Lambda$")
    ax.set_ylabel(r"$\hat R$")
    ax.set_title(
        f"naive strategies, {ku_display(flow.get('kubo', float('nan')))} "
        f"({record['n_flows']} flows x {record['n_swimmers']})"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_performance(summaries: list[dict], path: Path) -> None:
    """``R_hat`` against Ku (log axis): naive, STO, smart (mean over seeds and each seed)."""
    plt = pyplot()
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
