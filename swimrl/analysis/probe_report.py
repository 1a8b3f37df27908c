"""The mechanism probe's outputs (:mod:`.mechanism_probe`): its record as a Markdown table
and as a figure (bars of corr(Λ, STO) and corr(Λ, Λ*) per strategy, and the mean tumbling
rates)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from swimrl.analysis.mechanism_probe import PROBE_STATES, RATES
from swimrl.runs.records import markdown_table


def _fmt(value, sem=None, digits: int = 2) -> str:
    if value is None:
        return "n/a"
    text = f"{value:.{digits}f}"
    if float(text) == 0:
        text = text.lstrip("-")  # no "-0.00"
    return text + (f" ± {sem:.{digits}f}" if sem is not None else "")


def markdown(record: dict) -> str:
    """The record's rows as a Markdown table (± SEM: independent samples for ``gaussian``,
    over flows for ``flows``)."""
    head = ["strategy", "D", "flow", "states", "aligned", "corr(Λ, STO)", "corr(Λ, Λ*)",
            "corr(STO, Λ*)", "⟨\\|ṅ\\|⟩ τ_K at Λ = 0", "at own Λ", "at STO", "at Λ*", "R̂"]
    cells = []
    for r in record["rows"]:
        t = r["tumbling"]
        cells.append([
            r["label"], f"{r['dimension']}D", r["flow_label"] or "-", r["states"],
            str(r["n_aligned"]),
            _fmt(r["corr_sto"], r["corr_sto_sem"]), _fmt(r["corr_star"], r["corr_star_sem"]),
            _fmt(r["corr_sto_star"]),
            *(_fmt(t[k]["mean"], t[k]["sem"], 3) for k in RATES),
            _fmt(r.get("R_hat_mean"), r.get("R_hat_sem"), 3) if "R_hat_mean" in r else "-",
        ])
    return markdown_table(head, cells)


def _short(label: str) -> str:
    """A policy's row label for an axis: ``policy(docs/.../ku10_seed0/policy.pt)`` ->
    ``ku10_seed0``, ``policy(pretrained/ku10)`` -> ``pretrained/ku10``."""
    if not label.startswith("policy(") or not label.endswith(")"):
        return label
    parts = [p for p in label[len("policy("):-1].split("/") if p and p != "policy.pt"]
    if len(parts) >= 2 and parts[-2] == "pretrained":
        return "/".join(parts[-2:])
    return parts[-1] if parts else label


def plot_probe(record: dict, path: Path) -> None:
    """One row of two panels per kind of states: corr(Λ, STO) and corr(Λ, Λ*) of each
    strategy (bars, ± SEM), and the mean tumbling rate at Λ = 0, the strategy's, STO's and
    Λ*."""
    from swimrl.analysis.plots import pyplot

    plt = pyplot()
    kinds = [k for k in PROBE_STATES if any(r["states"] == k for r in record["rows"])]
    n = max(len([r for r in record["rows"] if r["states"] == k]) for k in kinds)
    width = max(7.0, 0.45 * n + 3.0)
    fig, axes = plt.subplots(len(kinds), 2, figsize=(2 * width, 3.6 * len(kinds)),
                             squeeze=False)
    for (ax_c, ax_t), kind in zip(axes, kinds, strict=True):
        rows = [r for r in record["rows"] if r["states"] == kind]
        x = np.arange(len(rows))
        labels = [_short(r["label"]) for r in rows]

        def val(v):
            return np.nan if v is None else v

        for off, key, color, name in ((-0.2, "corr_sto", "tab:green", "corr(Λ, STO)"),
                                      (0.2, "corr_star", "tab:purple", "corr(Λ, Λ*)")):
            ax_c.bar(x + off, [val(r[key]) for r in rows], 0.4, color=color, label=name,
                     yerr=[val(r[f"{key}_sem"]) if r[f"{key}_sem"] is not None else 0
                           for r in rows], capsize=2)
        ax_c.axhline(0, color="k", lw=0.5)
        ax_c.set_ylim(min(-0.1, ax_c.get_ylim()[0]), 1.25)
        ax_c.set_ylabel("correlation")
        for off, key, color, name in ((-0.3, "zero", "0.6", "Λ = 0"),
                                      (-0.1, "subject", "tab:orange", "own Λ"),
                                      (0.1, "sto", "tab:green", "STO"),
                                      (0.3, "star", "tab:purple", "Λ*")):
            t = [r["tumbling"][key] for r in rows]
            ax_t.bar(x + off, [val(v["mean"]) for v in t], 0.2, color=color, label=name,
                     yerr=[v["sem"] or 0 for v in t], capsize=1.5)
        ax_t.set_ylabel(r"mean $|\dot{\boldsymbol{n}}|\,\tau_K$")
        ax_t.set_ylim(0, 1.3 * ax_t.get_ylim()[1])
        for ax in (ax_c, ax_t):
            ax.set_xticks(x)
            ax.set_xticklabels(labels, rotation=45, ha="right", fontsize=7)
            ax.legend(fontsize=7, ncol=4, loc="upper center")
            ax.set_title(f"{kind} states, n_r > {record['n_r_min']:g}", fontsize=9)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
