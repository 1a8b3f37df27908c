"""Fig. ablation: (a) smart / STO per signal set (:mod:`swimrl.analysis.signal_ablation`),
(b), (c) the minimal model with the coefficients fitted at each Ku (``swimrl-fit-minimal``)."""

from __future__ import annotations

import json
import textwrap
from collections import Counter
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.analysis.signal_ablation import (
    AblationRun,
    ablation_markdown,
    draw_curves,
    draw_ratios,
    read_ablation,
    summarise_sets,
)
from swimrl.atomic import atomic_write_text
from swimrl.flows.labels import ku_display, ku_number
from swimrl.policies.baselines import StrategyLabel

from .records import FiguresConfig, eval_setup, flow_stats, per_flow_record, smart_policy
from .style import COLORS, save, shown


def read_fits(root: Path) -> dict[float, dict]:
    """``fit.json`` of ``swimrl-fit-minimal`` under ``root/ku*/``, keyed by Ku."""
    fits = {}
    for path in sorted(Path(root).glob("ku*/fit.json")):
        rec = json.loads(path.read_text())
        fits[float(rec["config"]["flow"]["kubo"])] = rec
    return dict(sorted(fits.items()))


def minimal_name(fit: dict) -> str:
    """Actor name of the minimal model with a fit's coefficients (``minimal(c1,c2,c3,c4)``)."""
    c = fit["coefficients"]
    return StrategyLabel.minimal_coeffs([c[k] for k in ("c1", "c2", "c3", "c4")]).label


def _draw_minimal(b, c, kus: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray],
                  coeffs: dict[str, np.ndarray], coeff_err: dict[str, np.ndarray]) -> None:
    """(b) R_hat of smart, the minimal model and STO against Ku; (c) c1..c4 against Ku."""
    colors = {**COLORS, "minimal": "tab:purple"}
    for name, y in r.items():
        b.errorbar(kus, y, yerr=err[name], color=colors[name], marker="o", capsize=3, label=name,
                   ls="--" if name == "minimal" else "-")
    b.set_xscale("log")
    b.set_xlabel("Ku")
    b.set_ylabel(r"$\hat R$")
    b.set_title("(b) smart and the minimal model", fontsize=9)
    b.legend(fontsize=7)
    shades = dict(zip(("c1", "c2", "c3", "c4"),
                      ("tab:blue", "tab:red", "tab:brown", "tab:pink"), strict=True))
    for k, y in coeffs.items():
        c.errorbar(kus, y, yerr=coeff_err[k], marker="o", capsize=3, label=f"$c_{k[1]}$",
                   color=shades[k])
    c.axhline(0, color="0.6", lw=0.8)
    c.set_xscale("log")
    c.set_xlabel("Ku")
    c.set_ylabel("fitted coefficient")
    c.set_title("(c) minimal-model coefficients", fontsize=9)
    c.legend(fontsize=7)


def fig_ablation(kus: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray],
                 coeffs: dict[str, np.ndarray], coeff_err: dict[str, np.ndarray], path: Path,
                 title: str = "", runs: list[AblationRun] | None = None) -> dict:
    """(a) smart / STO per signal set (the training multirun's ``runs``, at one Ku; "no
    records" where there are none) and (a') their held-out curves; (b) R_hat of smart, the minimal
    model (fitted at each Ku) and STO against Ku; (c) the fitted c1..c4 against Ku."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.6))
    (a, a2), (b, c) = axes
    out: dict = {}
    if runs:
        summary = summarise_sets(runs)
        draw_ratios(a, summary)
        out["ablation"] = {s["label"]: {"seeds": s["seeds"], "ratios": s["ratios"].tolist(),
                                        "mean": s["mean"], "std": s["std"]} for s in summary}
        out["curves_last"] = draw_curves(a2, runs, summary)
        out["table"] = ablation_markdown(runs, summary)
        kubo, frames = runs[0].kubo, runs[0].frames
        a.set_title(f"(a) signal ablation, {ku_display(kubo)}, {frames / 1e6:g}M frames per run",
                    fontsize=9)
        a2.set_title("(a') the runs' held-out curves (mean, band: std over seeds)", fontsize=9)
    else:
        for ax in (a, a2):
            ax.text(0.5, 0.5, "signal ablation: no records", ha="center", va="center",
                    transform=ax.transAxes)
            ax.set_axis_off()
    _draw_minimal(b, c, kus, r, err, coeffs, coeff_err)
    fig.suptitle("\n".join(textwrap.fill(line, 150) for line in title.splitlines()), fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return {"kubo": kus.tolist(), **{k: np.asarray(v).tolist() for k, v in r.items()},
            **{k: np.asarray(v).tolist() for k, v in coeffs.items()}, **out}


def build_ablation(cfg: FiguresConfig) -> dict:
    """Fig. ablation: (a) from the signal-ablation multirun's records, (b), (c) from the
    committed fits."""
    fits = read_fits(cfg.fits)
    if not fits:
        return {"pending": f"no ku*/fit.json under {cfg.fits}"}
    runs = read_ablation(cfg.ablation) if Path(cfg.ablation).is_dir() else []
    kus = np.array(list(fits))
    names = ("smart", "minimal", "STO")
    per = []
    for kubo, fit in fits.items():
        setup = eval_setup(cfg, kubo, cfg.robust_flows, cfg.robust_swimmers)
        actors = [smart_policy(cfg, kubo), minimal_name(fit), "sto"]
        per.append(per_flow_record(cfg, f"minimal_ku{ku_number(kubo)}", setup, actors))
    r, err = flow_stats(np.stack(per), names)  # per: (Ku, 3, F)
    keys = ("c1", "c2", "c3", "c4")
    coeffs = {k: np.array([f["coefficients"][k] for f in fits.values()]) for k in keys}
    coeff_err = {k: np.array([f.get("flow_sem", f["stderr"])[k] for f in fits.values()])
                 for k in keys}
    n_fit = {f["config"]["eval"]["n_flows"] for f in fits.values()}
    if runs:
        counts = sorted(set(Counter(r.signals for r in runs).values()))
        per_set = "-".join(map(str, sorted({counts[0], counts[-1]})))
        flows, swimmers = runs[0].held_out
        head = (f"(a) {len(runs)} runs under {shown(cfg.ablation)}, {per_set} seed(s) per set; "
                f"smart/STO paired on each run's {flows} held-out flows x {swimmers} swimmers, "
                "bars: std over seeds (one seed: its SEM, open marker)")
    else:
        head = f"(a) pending: no records under {shown(cfg.ablation)}"
    drawn = fig_ablation(
        kus, r, err, coeffs, coeff_err, cfg.out / "ablation.png",
        f"{head}\n(b) shipped smart policies; the minimal model with the coefficients fitted to "
        f"them at each Ku; STO; {cfg.robust_flows} flows x {cfg.robust_swimmers} swimmers, "
        f"bars: std over flows; (c) fits on {'/'.join(map(str, sorted(n_fit)))} flows x 100 "
        "swimmers, bars: SEM over flows", runs=runs)
    if "table" in drawn:
        atomic_write_text(cfg.out / "ablation_signals.md", drawn["table"])
    return drawn
