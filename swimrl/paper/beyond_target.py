"""Beyond the paper (``docs/beyond/``): point-to-point navigation, Fig. ``beyondTarget``, drawn
from the ``comparison.json`` records of ``swimrl-compare`` under ``<beyond>/``
(``figures.beyond``):

* ``target/ku<KU>_D<D>/comparison.json`` (``task=target``, one per Ku and target distance
  ``D``): arrival probability within ``T`` against ``D`` for target-STO, the best constant
  shape, the displacement-trained policy used as it is and the target-trained policies (one
  point per seed), and the arrival-time distribution ``F(t)`` (Kaplan-Meier, censored at
  ``T``: :func:`~swimrl.evaluation.statistics.outcome_statistics`) at the middle distance
  (the median arrival time of the arrived against ``D`` for records without it).

The paths of the same swimmers under each strategy beside it are :mod:`.beyond_paths`, the
energy cost of shape :mod:`.beyond_energy`. A figure whose records are missing is reported
``pending`` with the command that makes them (:func:`missing_records`).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.flows.labels import ku_display, parse_ku_name
from swimrl.policies.baselines import StrategyLabel

from .settings import FiguresConfig
from .style import COLORS, save, shown

_TARGET_DIR = re.compile(r"ku(?P<ku>[^_]+)_D(?P<d>[0-9.]+)")
#: The row kinds of a target comparison, as drawn (colour, marker).
TARGET_KINDS = {"target-STO": (COLORS["STO"], "s"), "best naive": (COLORS["naive"], "v"),
                "displacement policy": ("tab:blue", "D"), "smart (target)": (COLORS["smart"], "o"),
                "smart (warm start)": ("tab:purple", "^")}
#: Kinds with one row per training seed: drawn per seed, summarised by the mean over seeds.
SEEDED_KINDS = ("smart (target)", "smart (warm start)")


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


def missing_records(cfg: FiguresConfig, records: str) -> dict:
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
        return missing_records(cfg, "target/ku*_D*/comparison.json")
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
