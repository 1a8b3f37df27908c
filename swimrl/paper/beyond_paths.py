"""Beyond the paper (``docs/beyond/``): Fig. ``beyondTargetPaths``, beside Fig. beyondTarget
(:mod:`.beyond_target`): the paths of the same swimmers (one flow, the same starts and
targets) under each strategy of the target comparisons at the middle distance, drawn in the
frame of each swimmer's start and target (:func:`target_frame`); the evaluation is cached
(:func:`~.evaluations.cached`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.flows.labels import ku_display, ku_name
from swimrl.policies.baselines import StrategyLabel
from swimrl.task import TaskSpec

from .beyond_target import TARGET_KINDS, missing_records, read_target, target_summary
from .evaluations import cache_inputs, cached, eval_setup, record_strategies
from .settings import FiguresConfig
from .style import save

#: Swimmers drawn per strategy in Fig. beyondTargetPaths.
N_PATHS = 6


def target_frame(position: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Positions ``(..., N+1, 2)`` in the frame of each swimmer's start and target: the
    start at the origin and the target at ``(D, 0)``, i.e. ``R^T (x - x_0)`` with ``R``
    the rotation taking ``e_x`` to ``(X - x_0)/|X - x_0|``."""
    start = position[..., :1, :]
    to_target = target[..., None, :] - start
    e = to_target / np.linalg.norm(to_target, axis=-1, keepdims=True)
    d = position - start
    return np.stack([d[..., 0] * e[..., 0] + d[..., 1] * e[..., 1],
                     -d[..., 0] * e[..., 1] + d[..., 1] * e[..., 0]], axis=-1)


def path_actors(rec: dict) -> dict[str, str]:
    """``{kind: actor name}`` drawn in Fig. beyondTargetPaths from one target comparison:
    target-STO, the best constant shape, the displacement policy, the first target-trained
    policy (each where present)."""
    summary = target_summary(rec)
    out = {}
    for kind in TARGET_KINDS:
        if kind in summary:
            label = summary[kind]["label"].split("; ")[0]
            parsed = StrategyLabel.parse(label)
            out[kind] = parsed.arg if parsed.name == "policy" else label
    return out


def build_beyond_target_paths(cfg: FiguresConfig) -> dict:
    """Fig. beyondTargetPaths: per Ku (rows), the paths of :data:`N_PATHS` swimmers of one
    flow (the same starts, targets and flow for every strategy, columns) at the middle
    target distance of the comparisons, in the frame of each swimmer's start and target
    (:func:`target_frame`); a cross where a swimmer arrives."""
    recs = read_target(cfg.beyond)
    if not recs:
        return missing_records(cfg, "target/ku*_D*/comparison.json")
    plt = pyplot()
    middle = {ku: list(by_d)[len(by_d) // 2] for ku, by_d in recs.items()}
    actors_of = {ku: path_actors(recs[ku][dist]) for ku, dist in middle.items()}
    kinds = [kind for kind in TARGET_KINDS  # a column per kind drawn in some row
             if any(kind in actors for actors in actors_of.values())]
    fig, axes = plt.subplots(len(recs), len(kinds), figsize=(3.2 * len(kinds), 3.0 * len(recs)),
                             squeeze=False, layout="constrained")
    out: dict = {}
    for row, (ku, by_d) in enumerate(recs.items()):
        dist, actors = middle[ku], actors_of[ku]
        rec = by_d[dist]
        task = TaskSpec("target", distance=float(dist), arrival_radius=rec["arrival_radius"])
        setup = eval_setup(cfg, ku, 1, N_PATHS, task=task)
        names = list(actors.values())
        a = cached(cfg, f"target_paths_{ku_name(ku)}_D{dist:g}", cache_inputs(cfg, setup, names),
                   lambda setup=setup, names=names: record_strategies(setup, names, "paths"))
        xy = target_frame(a["position"][0], a["target"][0])  # (K, n, N+1, 2)
        arrival = a["arrival_time"][0]  # (K, n), NaN: not arrived
        out[ku_name(ku)] = {"distance": float(dist), "actors": actors, "arrived": {}}
        for col, kind in enumerate(kinds):
            ax = axes[row, col]
            if kind not in actors:
                ax.axis("off")
                ax.text(0.5, 0.5, f"{ku_display(ku)}: {kind}\nnot in the comparison",
                        ha="center", va="center", fontsize=8, transform=ax.transAxes)
                continue
            ax.add_patch(plt.Circle((dist, 0.0), rec["arrival_radius"], color="0.6", alpha=0.4))
            ax.plot([0, dist], [0, 0], ":", color="0.5", lw=0.8)
            ax.plot(0, 0, "r*", ms=8)
            k = names.index(actors[kind])
            for i in range(xy.shape[1]):
                line = ax.plot(xy[k, i, :, 0], xy[k, i, :, 1], lw=0.9)[0]
                if np.isfinite(arrival[k, i]):
                    ax.plot(*xy[k, i, -1], "x", color=line.get_color(), ms=6)
            arrived = int(np.isfinite(arrival[k]).sum())
            out[ku_name(ku)]["arrived"][kind] = arrived
            ax.set_title(f"{ku_display(ku)}, D = {dist:g}: {kind}\n{arrived} of {xy.shape[1]} "
                         "arrived", fontsize=8)
            ax.set_aspect("equal")
            ax.set_xlabel(r"along the target / $\ell_f$")
            if col == 0:
                ax.set_ylabel(r"across / $\ell_f$")
    fig.suptitle(f"the same {N_PATHS} swimmers (starts, targets, one flow of seed {cfg.seed}) "
                 "under each strategy; start *, target disc (arrival radius), x: arrived",
                 fontsize=8)
    path = Path(cfg.out) / "beyondTargetPaths.png"
    save(fig, path)
    return {"path": str(path), **out}
