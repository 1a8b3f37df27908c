"""Beyond the paper (``docs/beyond/``): point-to-point navigation
(``beyondTarget``) and the energy cost of shape (``beyondEnergy``), drawn from the
``comparison.json`` records of ``swimrl-compare`` under ``<beyond>/`` (``figures.beyond``):

* ``target/ku<KU>_D<D>/comparison.json`` (``task=target``, one per Ku and target distance
  ``D``): arrival probability within ``T`` against ``D`` for target-STO, the best constant
  shape, the displacement-trained policy used as it is and the target-trained policies (one
  point per seed), and the arrival-time distribution ``F(t)`` (Kaplan-Meier, censored at
  ``T``: :func:`~swimrl.evaluation.statistics.outcome_statistics`) at the middle distance
  (the median arrival time of the arrived against ``D`` for records without it); beside it
  (``beyondTargetPaths``) the paths of the same swimmers (one flow, the same starts and
  targets) under each of these strategies, drawn in the frame of each swimmer's start and
  target;
* ``energy/ku<KU>/comparison.json`` (``task=displacement``): ``R_hat`` against the energy
  ``E_hat`` per swimmer (:mod:`swimrl.physics.energy`) of every row, the policies coloured by
  the ``reward.energy_weight`` they were trained with (read from their run directory,
  ``..._w<W>_seed<k>``; the protocol's runs are ``w = 0``), and the non-dominated front
  (:func:`pareto_front`); beside it (``beyondEnergyMaps``) the maps of ku_pattern,
  ``<Lambda | S_np, n_theta>`` and ``<Lambda | S_np, omega>``, of the first policy at
  ``w = 0`` and at the largest ``w`` (``figures.n_flows x figures.n_swimmers`` swimmers each,
  cached: :func:`~.mechanism.map_record`).

A figure whose records are missing is reported ``pending`` with the command that makes them.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.flows.labels import ku_display, ku_name, parse_ku_name
from swimrl.policies.baselines import StrategyLabel
from swimrl.task import TaskSpec

from .mechanism import map_mean, map_record
from .records import Evaluation, FiguresConfig, cache_inputs, cached, eval_setup, record_strategies
from .style import COLORS, LABEL, save, shown

_TARGET_DIR = re.compile(r"ku(?P<ku>[^_]+)_D(?P<d>[0-9.]+)")
_WEIGHT = re.compile(r"_w(?P<w>[0-9.eE+-]+)_seed(?P<seed>\d+)")
#: The row kinds of a target comparison, as drawn (colour, marker).
TARGET_KINDS = {"target-STO": (COLORS["STO"], "s"), "best naive": (COLORS["naive"], "v"),
                "displacement policy": ("tab:blue", "D"), "smart (target)": (COLORS["smart"], "o"),
                "smart (warm start)": ("tab:purple", "^")}
#: Kinds with one row per training seed: drawn per seed, summarised by the mean over seeds.
SEEDED_KINDS = ("smart (target)", "smart (warm start)")


def pareto_front(r_hat: np.ndarray, energy: np.ndarray) -> np.ndarray:
    """Indices of the non-dominated points (no other point has ``R_hat >=`` and ``E_hat <=``
    with one of them strict), in increasing ``E_hat``."""
    r, e = np.asarray(r_hat, float), np.asarray(energy, float)
    keep = [i for i in range(r.size)
            if not np.any((r >= r[i]) & (e <= e[i]) & ((r > r[i]) | (e < e[i])))]
    return np.asarray(sorted(keep, key=lambda i: (e[i], -r[i])), dtype=int)


def row_kind(label: str) -> str | None:
    """What a target comparison's row is: ``target-STO``, a constant shape
    (``naive``), the displacement policy (``pretrained/ku*``), a target-trained policy, or
    one trained on the target task from the displacement policy's weights (a run directory
    named ``*_warm_*``, ``train.init_policy``)."""
    parsed = StrategyLabel.parse(label)
    if parsed.name == "sto":
        return "target-STO"
    if parsed.name == "naive":
        return "naive"
    if parsed.name == "policy":
        if "pretrained/" in parsed.arg:
            return "displacement policy"
        return "smart (warm start)" if "_warm_" in parsed.arg else "smart (target)"
    return None


def read_target(root: Path) -> dict[float, dict[float, dict]]:
    """``{Ku: {D: comparison record}}`` from ``root/target/ku*_D*/comparison.json``."""
    out: dict[float, dict[float, dict]] = {}
    for path in sorted(Path(root).glob("target/ku*_D*/comparison.json")):
        m = _TARGET_DIR.fullmatch(path.parent.name)
        ku = parse_ku_name(f"ku{m.group('ku')}") if m else None
        if ku is None:
            continue
        rec = json.loads(path.read_text())
        if rec.get("task") != "target":
            raise ValueError(f"{path}: not a task=target comparison")
        out.setdefault(ku, {})[float(rec["target_distance"])] = rec
    return {k: dict(sorted(v.items())) for k, v in sorted(out.items())}


def target_summary(rec: dict) -> dict[str, dict]:
    """Per row kind: arrival probability (mean, SEM), median arrival time of the arrived
    (``median_time``), and where the record has them (NaN otherwise) the time by which half
    of all swimmers arrived (``half_time``; inf: not within ``T``), the restricted mean
    time to arrival (``rmst``, ``rmst_sem``) and the arrival-time CDF (``cdf_t``, ``cdf``);
    the best constant shape (highest arrival) stands for ``naive``; target-trained policies
    per seed (``values``) and their mean (``sem``, ``rmst_sem``: std over seeds)."""
    out: dict[str, dict] = {}
    naive = [r for r in rec["rows"] if row_kind(r["label"]) == "naive"]
    if naive:
        best = max(naive, key=lambda r: r["arrival_mean"])
        out["best naive"] = {"label": best["label"], **_arrival(best)}
    for r in rec["rows"]:
        kind = row_kind(r["label"])
        if kind in ("target-STO", "displacement policy"):
            out[kind] = {"label": r["label"], **_arrival(r)}
    for seeded in SEEDED_KINDS:
        smart = [r for r in rec["rows"] if row_kind(r["label"]) == seeded]
        if not smart:
            continue
        values = [_arrival(r) for r in smart]

        def spread(key: str, one: str, values=values) -> float:
            x = [v[key] for v in values]
            return float(np.std(x, ddof=1)) if len(x) > 1 else values[0][one]

        out[seeded] = {
            "label": "; ".join(r["label"] for r in smart), "values": values,
            "arrival": float(np.mean([v["arrival"] for v in values])),
            "sem": spread("arrival", "sem"),
            "median_time": _nanmean([v["median_time"] for v in values]),
            "half_time": float(np.mean([v["half_time"] for v in values])),
            "rmst": float(np.mean([v["rmst"] for v in values])),
            "rmst_sem": spread("rmst", "rmst_sem")}
    return out


def _arrival(row: dict) -> dict:
    t = row.get("arrival_time_median")
    out = {"arrival": float(row["arrival_mean"]), "sem": float(row["arrival_sem"]),
           "median_time": float("nan") if t is None else float(t),
           "half_time": float("nan"), "rmst": float("nan"), "rmst_sem": float("nan")}
    if "arrival_cdf_mean" in row:
        half = row["arrival_time_half"]
        out.update(half_time=float("inf") if half is None else float(half),
                   rmst=float(row["arrival_time_rmst_mean"]),
                   rmst_sem=float(row["arrival_time_rmst_sem"]),
                   cdf_t=list(row["arrival_cdf_t"]), cdf=list(row["arrival_cdf_mean"]),
                   cdf_sem=list(row["arrival_cdf_sem"]))
    return out


def _nanmean(values) -> float:
    v = np.asarray(values, float)
    return float(np.nanmean(v)) if np.isfinite(v).any() else float("nan")


def _time_cell(s: dict) -> str:
    """The table's time by which half arrived: ``—`` without it, ``> T`` if not within ``T``
    (smart with several seeds: per seed unless every seed has it)."""
    if "values" in s and len(s["values"]) > 1 and not np.isfinite(s["half_time"]):
        cells = {_time_cell(v) for v in s["values"]}
        if len(cells) == 1:  # every seed without it, or not within T
            return cells.pop()
        return " / ".join(_time_cell(v) for v in s["values"]) + " (per seed)"
    t = s["half_time"]
    return "—" if np.isnan(t) else "> T" if np.isinf(t) else f"{t:.1f}"


def cdf_distance(by_d: dict[float, dict]) -> float:
    """The target distance whose arrival-time CDF Fig. beyondTarget draws: 20 if present,
    else the middle one (as Fig. beyondTargetPaths)."""
    dists = list(by_d)
    return 20.0 if 20.0 in by_d else dists[len(dists) // 2]


def _draw_cdf(ax, summary: dict, dist: float, episode: float | None) -> None:
    """``F(t)`` of every kind at ``dist`` (SEM band over flows; smart: one thin line per
    seed)."""
    for kind, (color, _) in TARGET_KINDS.items():
        if kind not in summary or "cdf" not in summary[kind].get("values", [summary[kind]])[0]:
            continue
        s = summary[kind]
        if kind in SEEDED_KINDS:
            for i, v in enumerate(s["values"]):
                ax.plot(v["cdf_t"], v["cdf"], color=color, lw=0.9,
                        label=kind if i == 0 else None)
        else:
            t, f, e = (np.asarray(s[k]) for k in ("cdf_t", "cdf", "cdf_sem"))
            ax.plot(t, f, color=color, lw=1.4, label=kind)
            ax.fill_between(t, f - e, f + e, color=color, alpha=0.2, lw=0)
    ax.axhline(0.5, color="0.5", ls=":", lw=0.8)
    ax.set_xlim(0, episode)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel(r"time $t/\tau_K$")
    ax.set_ylabel(r"arrived by $t$, $F(t)$")
    ax.set_title(f"D = {dist:g}: arrival-time CDF (all swimmers; censored at T)", fontsize=8)
    ax.legend(fontsize=7)


def _pending(cfg: FiguresConfig, records: str) -> dict:
    """A figure without its ``records`` (a glob under ``figures.beyond``): pending, with where
    the commands that make them are."""
    return {"pending": f"no {records} under {shown(cfg.beyond)} "
                       f"(commands: {shown(cfg.beyond)}/README.md)"}


def build_beyond_target(cfg: FiguresConfig) -> dict:
    """Fig. beyondTarget, one column per Ku: arrival probability against the target
    distance (top); below, the arrival-time CDF ``F(t)`` at :func:`cdf_distance` (every
    swimmer counted, those not arrived censored at ``T``) where the records have it, else
    the median arrival time of the arrived against the distance. A table ``beyondTarget.md``
    beside it (the time by which half arrived and the restricted mean time
    ``E[min(t_arrival, T)]`` where the records have them, ``—`` otherwise)."""
    recs = read_target(cfg.beyond)
    if not recs:
        return _pending(cfg, "target/ku*_D*/comparison.json")
    plt = pyplot()
    fig, axes = plt.subplots(2, len(recs), figsize=(4.2 * len(recs), 6.2), squeeze=False)
    lines, data, drawn = [], {}, {}
    for col, (ku, by_d) in enumerate(recs.items()):
        d = np.asarray(list(by_d))
        summary = {dist: target_summary(rec) for dist, rec in by_d.items()}
        data[ku] = {str(k): v for k, v in summary.items()}
        mid = cdf_distance(by_d)
        cdf = any("cdf" in s.get("values", [s])[0] for s in summary[mid].values())
        drawn[ku] = mid if cdf else None
        for kind, (color, marker) in TARGET_KINDS.items():
            present = [dist for dist in d if kind in summary[dist]]
            if not present:
                continue
            y = [summary[x][kind]["arrival"] for x in present]
            err = [summary[x][kind]["sem"] for x in present]
            t = [summary[x][kind]["median_time"] for x in present]
            axes[0, col].errorbar(present, y, yerr=err, color=color, marker=marker, capsize=3,
                                  label=kind)
            if not cdf:
                axes[1, col].plot(present, t, color=color, marker=marker, label=kind)
            if kind in SEEDED_KINDS:
                for x in present:
                    seeds = [v["arrival"] for v in summary[x][kind]["values"]]
                    axes[0, col].plot([x] * len(seeds), seeds, ".", color=color, alpha=0.5)
        rec0 = next(iter(by_d.values()))
        axes[0, col].set_title(f"{ku_display(ku)}: {rec0['n_flows']} flows x "
                               f"{rec0['n_swimmers']} swimmers, seed {rec0['seed']}", fontsize=9)
        axes[0, col].set_ylabel("arrived within T")
        axes[0, col].set_ylim(0, 1.02)
        axes[0, col].set_xlabel(r"target distance $D/\ell_f$")
        if cdf:
            episode = by_d[mid].get("config", {}).get("episode", {}).get("duration")
            _draw_cdf(axes[1, col], summary[mid], mid, episode)
        else:
            axes[1, col].set_ylabel(r"median arrival time of the arrived / $\tau_K$")
            axes[1, col].set_xlabel(r"target distance $D/\ell_f$")
        axes[0, col].legend(fontsize=7)
        for dist in d:
            for kind, s in summary[dist].items():
                rmst = "—" if np.isnan(s["rmst"]) else f"{s['rmst']:.1f} ± {s['rmst_sem']:.1f}"
                lines.append(f"| {ku_display(ku)} | {dist:g} | {kind} | {s['arrival']:.3f} ± "
                             f"{s['sem']:.3f} | {_time_cell(s)} | {rmst} | "
                             f"{s['median_time']:.1f} | {s['label']} |")
    fig.tight_layout()
    path = Path(cfg.out) / "beyondTarget.png"
    save(fig, path)
    table = ("| Ku | D / ℓ_f | strategy | arrived within T (± SEM over flows; smart, several "
             "seeds: ± std over seeds) | time by which half arrived (τ_K) | "
             "restricted mean time (τ_K) | median arrival time of the arrived (τ_K) | rows |\n"
             "|---|---|---|---|---|---|---|---|\n" + "\n".join(lines) + "\n")
    (Path(cfg.out) / "beyondTarget.md").write_text(table)
    return {"path": str(path), "summary": data, "cdf_distance": drawn}


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
        return _pending(cfg, "target/ku*_D*/comparison.json")
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


def read_energy(root: Path) -> dict[float, dict]:
    """``{Ku: comparison record}`` from ``root/energy/ku*/comparison.json``, with the rows of
    the energy-aware STO family (``root/energy_baselines/ku*/comparison.json``, the same flows
    and starts: seed, sizes and flow keys equal, checked) appended."""
    out = {}
    for path in sorted(Path(root).glob("energy/ku*/comparison.json")):
        ku = parse_ku_name(path.parent.name)
        if ku is not None:
            out[ku] = json.loads(path.read_text())
    for path in sorted(Path(root).glob("energy_baselines/ku*/comparison.json")):
        ku = parse_ku_name(path.parent.name)
        if ku not in out:
            continue
        extra, rec = json.loads(path.read_text()), out[ku]
        same = all(extra[k] == rec[k] for k in ("seed", "n_flows", "n_swimmers"))
        if not same or extra["config"]["flow"] != rec["config"]["flow"]:
            raise ValueError(f"{path}: not the flows of energy/{path.parent.name} (seed, sizes "
                             "and flow keys must be equal)")
        rec["rows"] = rec["rows"] + [r for r in extra["rows"] if r["label"] not in
                                     {x["label"] for x in rec["rows"]}]
    return dict(sorted(out.items()))


def energy_weight(label: str) -> float | None:
    """The ``reward.energy_weight`` a policy row was trained with: ``_w<W>_seed<k>`` in its
    path, 0 for the protocol's runs (``paper_runs``, ``pretrained``); None for baselines."""
    parsed = StrategyLabel.parse(label)
    if parsed.name != "policy":
        return None
    m = _WEIGHT.search(parsed.arg)
    return float(m.group("w")) if m else 0.0


#: One colour per energy weight (distinct at neighbouring weights).
WEIGHT_COLORS = ("tab:red", "tab:orange", "tab:olive", "tab:purple", "tab:brown", "tab:pink")


def sto_amplitudes(label: str, lam_max: float) -> tuple[float, float] | None:
    """``(a_+, a_-)`` of an STO row: ``sto`` is ``(Lambda_max, Lambda_max)``,
    ``sto(+a,-b)`` is ``(a, b)``; None for any other row."""
    parsed = StrategyLabel.parse(label)
    if parsed.name != "sto":
        return None
    if not parsed.arg:
        return (lam_max, lam_max)
    plus, minus = parsed.numbers
    return (plus, -minus)


def build_beyond_energy(cfg: FiguresConfig) -> dict:
    """Fig. beyondEnergy: ``R_hat`` against ``E_hat`` (± SEM over flows) for every row of
    each Ku's comparison: the constant shapes as points (labelled by ``Lambda``), STO with a
    scanned amplitude ``Lambda = +-a`` as a line in ``a``, STO with unequal prolate / oblate
    amplitudes as points, the policies coloured by their energy weight, the non-dominated front
    dashed."""
    recs = read_energy(cfg.beyond)
    if not recs:
        return _pending(cfg, "energy/ku*/comparison.json")
    plt = pyplot()
    fig, axes = plt.subplots(1, len(recs), figsize=(5.2 * len(recs), 4.2), squeeze=False)
    out = {}
    for a, (ku, rec) in zip(axes[0], recs.items(), strict=True):
        rows = rec["rows"]
        lam_max = float(rec["config"]["swimmer"]["shape_factor_max"])
        r = np.asarray([x["R_hat_mean"] for x in rows])
        e = np.asarray([x["energy_mean"] for x in rows])
        weights = [energy_weight(x["label"]) for x in rows]
        palette = {w: WEIGHT_COLORS[i % len(WEIGHT_COLORS)]
                   for i, w in enumerate(sorted({w for w in weights if w is not None}))}
        naive = [i for i, x in enumerate(rows) if StrategyLabel.parse(x["label"]).name == "naive"]
        if naive:
            a.plot(e[naive], r[naive], "v", color=COLORS["naive"], ms=4, ls="none",
                   label="constant Λ")
            for i in naive:
                a.annotate(f"{StrategyLabel.parse(rows[i]['label']).numbers[0]:+.2f}",
                           (e[i], r[i]), fontsize=5, xytext=(2, -6), textcoords="offset points")
        amps = {i: sto_amplitudes(x["label"], lam_max) for i, x in enumerate(rows)}
        sym = sorted((i for i, p in amps.items() if p is not None and p[0] == p[1]),
                     key=lambda i: amps[i][0])
        if len(sym) > 1:
            a.plot(e[sym], r[sym], "-s", color=COLORS["STO"], ms=3, lw=0.8,
                   label="STO, Λ = ±a (a scanned)")
            for i in sym:
                a.annotate(f"{amps[i][0]:g}", (e[i], r[i]), fontsize=5, xytext=(2, 2),
                           textcoords="offset points")
        for i, p in amps.items():
            x = rows[i]
            if p is None:
                continue
            if p == (lam_max, lam_max):
                a.errorbar(e[i], r[i], xerr=x["energy_sem"], yerr=x["R_hat_sem"], marker="s",
                           color=COLORS["STO"], label="STO", capsize=2, ms=5)
            elif p[0] != p[1]:
                a.plot(e[i], r[i], "D", color="tab:cyan", ms=4, label="STO, +a₊ / −a₋")
                a.annotate(f"{p[0]:g}/{p[1]:g}", (e[i], r[i]), fontsize=5, xytext=(2, 2),
                           textcoords="offset points")
        for i, x in enumerate(rows):
            w = weights[i]
            if w is not None:
                a.errorbar(e[i], r[i], xerr=x["energy_sem"], yerr=x["R_hat_sem"], marker="o",
                           color=palette[w], capsize=2, ms=5, ls="none",
                           label=f"smart, w = {w:g}")
        front = pareto_front(r, e)
        order = front[np.argsort(e[front])]
        a.plot(e[order], r[order], "--", color="0.5", lw=0.8, zorder=0, label="front")
        handles, labels = a.get_legend_handles_labels()
        unique = dict(zip(labels, handles, strict=True))
        a.legend(unique.values(), unique.keys(), fontsize=6)
        a.set_xlabel(r"$\hat E$ (work against drag / $6\pi\mu a v_s^2 T$)")
        a.set_ylabel(r"$\hat R$")
        a.set_title(f"{ku_display(ku)}: {rec['n_flows']} flows x {rec['n_swimmers']} swimmers,"
                    f" seed {rec['seed']}", fontsize=9)
        out[ku] = {"front": [rows[i]["label"] for i in order]}
    fig.tight_layout()
    path = Path(cfg.out) / "beyondEnergy.png"
    save(fig, path)
    maps = energy_map_policies(recs)
    if maps:
        fig_energy_maps(cfg, maps, Path(cfg.out) / "beyondEnergyMaps.png")
    return {"path": str(path), **{ku_name(k): v for k, v in out.items()},
            "maps": {f"{ku_name(ku)}_w{w:g}": p for (ku, w), p in maps.items()}}


def energy_map_policies(recs: dict[float, dict]) -> dict[tuple[float, float], str]:
    """``{(Ku, w): policy spec}``: per Ku, the first policy row at ``w = 0`` and at the
    largest ``w`` (both only where a ``w > 0`` row exists)."""
    out = {}
    for ku, rec in recs.items():
        policies: dict[float, str] = {}
        for row in rec["rows"]:
            w = energy_weight(row["label"])
            if w is not None:
                policies.setdefault(w, StrategyLabel.parse(row["label"]).arg)
        if 0.0 in policies and max(policies) > 0:
            out[(ku, 0.0)] = policies[0.0]
            out[(ku, max(policies))] = policies[max(policies)]
    return out


def fig_energy_maps(cfg: FiguresConfig, policies: dict[tuple[float, float], str],
                    path: Path) -> None:
    """The ku_pattern maps of each ``(Ku, w)`` policy, one column each."""
    plt = pyplot()
    keys = sorted(policies)
    fig, axes = plt.subplots(2, len(keys), figsize=(3.3 * len(keys), 6.4), squeeze=False,
                             layout="constrained")
    im = None
    for i, (ku, w) in enumerate(keys):
        setup = eval_setup(cfg, ku, cfg.n_flows, cfg.n_swimmers)
        ev = Evaluation(f"energy_{ku_name(ku)}_w{w:g}", "statistics", setup,
                        {"smart": policies[(ku, w)]})
        a = map_record(cfg, ev)
        for row, other in enumerate(("n_theta", "omega")):
            mean, edges = map_mean(a, other)
            ax = axes[row, i]
            im = ax.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
            ax.set_xlabel(LABEL["S_np"])
            ax.set_ylabel(LABEL[other])
            ax.set_title(f"{ku_display(ku)}, w = {w:g}", fontsize=9)
    fig.colorbar(im, ax=axes, shrink=0.6, label=r"$\langle\Lambda\rangle$")
    fig.suptitle(f"policies trained without (w = 0) and with the largest energy cost; "
                 f"{cfg.n_flows} flow(s) x {cfg.n_swimmers} swimmers each", fontsize=8)
    save(fig, path)
