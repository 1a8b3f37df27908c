"""Fig. trainingCurves: the held-out R_hat of the protocol's training runs against training
episodes, one panel per Ku (each curve drawn by
:func:`swimrl.analysis.training_curves.draw_curve`).

Each run's periodic held-out evaluation uses its own flows (evaluation seed ``10^6 +``
training seed, :func:`held_out_flows`), the same at every point of that run: the seeds of a
panel are compared on different flows, and the figure says so. Beside each curve a diamond
gives the run's final policy on flows common to every run of its Ku, the protocol's
comparison (:func:`common_flows`)."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from swimrl.analysis.performance import load, summarise
from swimrl.analysis.plots import pyplot
from swimrl.analysis.training_curves import PAPER_EPISODE_FRAMES, draw_curve
from swimrl.flows.labels import ku_display, parse_ku_name
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.curves import read_curves
from swimrl.runs.layout import RunLayout

from .settings import FiguresConfig
from .style import save, shown


def find_curves(root: Path) -> dict[str, Path]:
    """``curves.csv`` files under ``root``, labelled by their run directory; linked run
    directories are followed (``docs/results/paper_runs/ku*_seed*`` are links)."""
    name = RunLayout(root).curves.name
    found = (RunLayout(d).curves for d, _, files in os.walk(root, followlinks=True)
             if name in files)
    return {p.parent.name: p for p in sorted(found)}


def fig_training_curves(curves: dict[str, dict[str, np.ndarray]], path: Path,
                        title: str = "", held_out: dict[str, dict] | None = None,
                        common: dict[str, float] | None = None) -> dict:
    """Held-out ``eval/R_hat`` (+- SEM band where recorded) against training episodes in the
    paper's unit (10 swimmers x 2000 decisions = 2e4 frames), one panel per Ku (label prefix
    ``ku*_``), panels in increasing Ku; ``held_out[label]``: the run's held-out flows
    (:func:`held_out_flows`), named in its legend entry and, where the runs of a panel were
    evaluated on different flows, in the panel's title; ``common[label]``: its final
    policy's R_hat on flows common to every run (a diamond right of its curve). Returns each
    run's last held-out value."""
    plt = pyplot()
    held_out, common = held_out or {}, common or {}
    groups: dict[str, list[str]] = {}
    for label in curves:
        groups.setdefault(label.split("_")[0], []).append(label)
    kus = {g: parse_ku_name(g) for g in groups}  # None where the group is not ku<number>
    order = sorted(groups, key=lambda g: (math.inf if kus[g] is None else kus[g], g))
    fig, axes = plt.subplots(1, max(1, len(order)), figsize=(3.6 * max(1, len(order)), 3.8),
                             squeeze=False)
    out = {}
    for a, ku in zip(axes[0], order, strict=False):
        for k, label in enumerate(sorted(groups[ku])):
            h = held_out.get(label)
            name = label.removeprefix(ku + "_") + (f" (flows of seed {h['seed']})" if h else "")
            x, y = draw_curve(a, curves[label], label=name,
                              frames_per_unit=PAPER_EPISODE_FRAMES, ms=2, lw=0)
            out[label] = float(y[-1])
            if label in common:
                a.plot(x[-1] / PAPER_EPISODE_FRAMES * (1.03 + 0.025 * k), common[label],
                       marker="D", ms=5,
                       color=a.get_lines()[-1].get_color(), mec="k", mew=0.5, ls="none")
        a.set_xlabel("training episodes (of $2\\times10^4$ frames)")
        a.set_ylabel(r"held-out $\hat R$")
        seeds = {held_out[g]["seed"] for g in groups[ku] if g in held_out}
        what = ku if kus[ku] is None else ku_display(kus[ku])
        if len(seeds) > 1:
            what += "\nseeds on different held-out flows"
        a.set_title(what, fontsize=8)
        a.legend(fontsize=6)
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return out


def held_out_flows(run: Path) -> dict | None:
    """The flows of a run's periodic held-out evaluation, from its ``metrics.json``:
    ``{seed, n_flows, n_swimmers}`` (None without one)."""
    metrics = RunLayout(run).metrics
    if not metrics.exists():
        return None
    m = json.loads(metrics.read_text())
    train = (m.get("config") or {}).get("train") or {}
    seed = (m.get("training") or {}).get("eval_seed")
    if seed is None or "eval_flows" not in train:
        return None
    return {"seed": int(seed), "n_flows": int(train["eval_flows"]),
            "n_swimmers": int(train["eval_swimmers"])}


def common_flows(results: Path) -> tuple[dict[str, float], str]:
    """Each protocol run's final policy's R_hat on the protocol's comparison flows (common to
    every run of a Ku), by run directory name, and their sizes as a title says them."""
    out, sizes = {}, set()
    if not Path(results).exists():
        return out, ""
    for rec in load([results]):
        s = summarise(rec)
        sizes.add((s["n_flows"], s["n_swimmers"], s["seed"]))
        for x in s["seeds"]:
            spec = StrategyLabel.parse(x["label"]).arg
            if spec:
                out[Path(spec).parent.name] = float(x["R_hat_mean"])
    text = "; ".join(f"{f} flows x {n} swimmers of test seed {sd}" for f, n, sd in sorted(sizes))
    return out, text


def build_training_curves(cfg: FiguresConfig) -> dict:
    files = find_curves(cfg.curves)
    if not files:
        return {"pending": f"no curves.csv under {cfg.curves}"}
    held = {k: h for k, p in files.items() if (h := held_out_flows(p.parent)) is not None}
    common, sizes = common_flows(cfg.results)
    common = {k: v for k, v in common.items() if k in files}
    flows = sorted({(h["n_flows"], h["n_swimmers"]) for h in held.values()})
    own = ", ".join(f"{f} flows x {n} swimmers" for f, n in flows) or "its own flows"
    title = (f"curves.csv under {shown(cfg.curves)}; band: SEM over flows. Held-out: each run "
             f"on its own {own} (evaluation seed 10^6 + training seed, in the legend), the same "
             "at every point of a run:\nthe seeds of a panel are compared on different flows "
             "(the curves hold no evaluation on common flows)")
    if common:
        title += (f"; diamonds: each run's final policy on common flows ({sizes}, the "
                  "protocol's comparison)")
    out = fig_training_curves({k: read_curves(p) for k, p in files.items()},
                              cfg.out / "trainingCurves.png", title, held, common)
    return {**out, "held_out": held, "common": common}
