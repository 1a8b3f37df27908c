"""Beyond the paper (``docs/beyond/``): the energy cost of shape, Fig. ``beyondEnergy``, drawn
from the ``comparison.json`` records of ``swimrl-compare`` under ``<beyond>/``
(``figures.beyond``):

* ``energy/ku<KU>/comparison.json`` (``task=displacement``): ``R_hat`` against the energy
  ``E_hat`` per swimmer (:mod:`swimrl.physics.energy`) of every row, the policies coloured by
  the ``reward.energy_weight`` they were trained with (read from their run directory,
  ``..._w<W>_seed<k>``; the protocol's runs are ``w = 0``), and the non-dominated front
  (:func:`pareto_front`); beside it (``beyondEnergyMaps``) the maps of ku_pattern,
  ``<Lambda | S_np, n_theta>`` and ``<Lambda | S_np, omega>``, of the first policy at
  ``w = 0`` and at the largest ``w`` (``figures.n_flows x figures.n_swimmers`` swimmers each,
  cached: :func:`~.map_evaluations.map_record`).

Without its records the figure is reported ``pending`` with the command that makes them
(:func:`~.beyond_target.missing_records`).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.flows.labels import ku_display, ku_name, parse_ku_name
from swimrl.policies.baselines import StrategyLabel

from .beyond_target import missing_records
from .decision_stats import map_mean
from .evaluations import Evaluation, eval_setup
from .map_evaluations import map_record
from .settings import FiguresConfig
from .style import COLORS, LABEL, save

_WEIGHT = re.compile(r"_w(?P<w>[0-9.eE+-]+)_seed(?P<seed>\d+)")


def pareto_front(r_hat: np.ndarray, energy: np.ndarray) -> np.ndarray:
    """Indices of the non-dominated points (no other point has ``R_hat >=`` and ``E_hat <=``
    with one of them strict), in increasing ``E_hat``."""
    r, e = np.asarray(r_hat, float), np.asarray(energy, float)
    keep = [i for i in range(r.size)
            if not np.any((r >= r[i]) & (e <= e[i]) & ((r > r[i]) | (e < e[i])))]
    return np.asarray(sorted(keep, key=lambda i: (e[i], -r[i])), dtype=int)


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
        return missing_records(cfg, "energy/ku*/comparison.json")
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
