"""Fig. trainingCurves: the held-out R_hat of the protocol's training runs against training
episodes, one panel per Ku (each curve drawn by
:func:`swimrl.analysis.training_curves.draw_curve`)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.analysis.training_curves import PAPER_EPISODE_FRAMES, draw_curve
from swimrl.flows.labels import ku_display, parse_ku_name
from swimrl.runs.curves import read_curves
from swimrl.runs.layout import RunLayout

from .records import FiguresConfig
from .style import save, shown


def find_curves(root: Path) -> dict[str, Path]:
    """``curves.csv`` files under ``root``, labelled by their run directory; linked run
    directories are followed (``docs/results/paper_runs/ku*_seed*`` are links)."""
    name = RunLayout(root).curves.name
    found = (RunLayout(d).curves for d, _, files in os.walk(root, followlinks=True)
             if name in files)
    return {p.parent.name: p for p in sorted(found)}


def fig_training_curves(curves: dict[str, dict[str, np.ndarray]], path: Path,
                        title: str = "") -> dict:
    """Held-out ``eval/R_hat`` (+- SEM band where recorded) against training episodes in the
    paper's unit (10 swimmers x 2000 decisions = 2e4 frames), one panel per Ku (label prefix
    ``ku*_``), panels in increasing Ku; returns each run's last held-out value."""
    plt = pyplot()
    groups: dict[str, list[str]] = {}
    for label in curves:
        groups.setdefault(label.split("_")[0], []).append(label)
    kus = {g: parse_ku_name(g) for g in groups}  # None where the group is not ku<number>
    order = sorted(groups, key=lambda g: (math.inf if kus[g] is None else kus[g], g))
    fig, axes = plt.subplots(1, max(1, len(order)), figsize=(3.6 * max(1, len(order)), 3.4),
                             squeeze=False)
    out = {}
    for a, ku in zip(axes[0], order, strict=False):
        for label in sorted(groups[ku]):
            _, y = draw_curve(a, curves[label], label=label.removeprefix(ku + "_"),
                              frames_per_unit=PAPER_EPISODE_FRAMES, ms=2, lw=0)
            out[label] = float(y[-1])
        a.set_xlabel("training episodes (of $2\\times10^4$ frames)")
        a.set_ylabel(r"held-out $\hat R$")
        a.set_title(ku if kus[ku] is None else ku_display(kus[ku]), fontsize=9)
        a.legend(fontsize=7)
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return out


def build_training_curves(cfg: FiguresConfig) -> dict:
    files = find_curves(cfg.curves)
    if not files:
        return {"pending": f"no curves.csv under {cfg.curves}"}
    return fig_training_curves({k: read_curves(p) for k, p in files.items()},
                               cfg.out / "trainingCurves.png",
                               f"curves.csv under {shown(cfg.curves)}; held-out: "
                               "the same flows at every point, band: SEM over flows")
