"""The swimmers in the stochastic flow: Fig. 1(a) (one prolate and one oblate swimmer over the
vorticity) and Fig. smartPerformance (R_hat against Ku, and the final displacements of smart,
naive and STO at each Ku).

smartPerformance (b-e) draw the one flow of each Ku record (``figures.n_flows = 1``), smart on
top, on common axes; its record's ``derived.panels_b_e`` (:func:`drawn_flow`) and the panels
say where that flow orders the strategies otherwise than (a)'s 100 flows, and in how many of
those flows they are ordered so."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from swimrl.analysis.performance import load, summarise
from swimrl.analysis.plots import pyplot
from swimrl.flows.labels import ku_display, ku_name, parse_ku_name
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.layout import RunLayout
from swimrl.runs.spec import EvalSizes

from .evaluations import (
    KUS,
    RECORD_STRATEGIES,
    Evaluation,
    cache_inputs,
    cached,
    eval_setup,
    flow_summary,
    flow_vorticity,
    ku_evaluation,
    ku_record,
    record_strategies,
)
from .records import extend_record, figure_record, record_sizes
from .settings import FiguresConfig
from .style import COLORS, save, sizes_title


# -- Fig. 1(a): swimmer ----------------------------------------------------------------------
def fig_swimmer(vorticity: np.ndarray, box: float, traj: dict[str, np.ndarray], path: Path,
                title: str = "") -> dict:
    """Trajectories ``{label: (N+1, 2)}`` (absolute, unwrapped) over the periodic vorticity
    field (tiled as far as they go); returns the extent drawn and the path lengths."""
    plt = pyplot()
    pts = np.concatenate(list(traj.values()))
    lo, hi = np.floor(pts.min(0) / box) * box, np.ceil(pts.max(0) / box) * box
    reps = np.maximum(((hi - lo) / box).round().astype(int), 1)
    field = np.tile(vorticity, (reps[1], reps[0]))
    extent = [lo[0], lo[0] + reps[0] * box, lo[1], lo[1] + reps[1] * box]
    fig, ax = plt.subplots(figsize=(5.5, 5))
    vmax = np.abs(vorticity).max()
    im = ax.imshow(field, origin="lower", extent=extent, cmap="RdBu_r", vmin=-vmax, vmax=vmax)
    fig.colorbar(im, ax=ax, shrink=0.8, label=r"vorticity $\omega\tau_K$")
    colors = ["tab:orange", "tab:purple", "k", "tab:green"]
    for (label, x), c in zip(traj.items(), colors, strict=False):
        ax.plot(x[:, 0], x[:, 1], color=c, lw=1.5, label=label)
    first = next(iter(traj.values()))[0]
    ax.plot(*first, "r*", ms=12, label="start")
    pad = 0.05 * (pts.max(0) - pts.min(0)).max() + 0.5
    ax.set_xlim(pts[:, 0].min() - pad, pts[:, 0].max() + pad)
    ax.set_ylim(pts[:, 1].min() - pad, pts[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel(r"$x/\ell_f$")
    ax.set_ylabel(r"$y/\ell_f$")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=8, loc="upper left")
    save(fig, path)
    return {"extent": extent,
            "path_length": {k: float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum())
                            for k, x in traj.items()}}


def build_swimmer(cfg: FiguresConfig) -> dict:
    """Lambda = +0.98 and -0.98 from one point in a frozen flow (Ku = 1e7), 20 tau_K."""
    setup = replace(eval_setup(cfg, 1e7, 1, 1, duration=20.0), sizes=EvalSizes(1, 1, 1, False, 1))
    actors = [StrategyLabel("naive", f"{lam:g}").label for lam in (0.98, -0.98)]

    def compute() -> dict[str, np.ndarray]:
        # one evaluation each on the same seed: same flow, same initial point (CRN)
        pos = [record_strategies(setup, [a], a)["position"][0, 0, 0] for a in actors]
        return {"position": np.stack(pos), "vorticity": flow_vorticity(setup),
                "box": np.asarray(setup.flow.n_grid * setup.flow.spacing)}

    d = cached(cfg, "swimmer", cache_inputs(cfg, setup, actors), compute)
    traj = {r"$\Lambda=+0.98$ (prolate)": d["position"][0],
            r"$\Lambda=-0.98$ (oblate)": d["position"][1]}
    return fig_swimmer(d["vorticity"], float(d["box"]), traj, cfg.out / "swimmer.png",
                       "frozen flow (Ku = $10^7$), T = 20 $\\tau_K$, same start and flow")


# -- Fig. smartPerformance -------------------------------------------------------------------
#: The order (b-e) draw the strategies in: smart last, on top.
DRAW_ORDER = ("naive", "STO", "smart")


def fig_smart_performance(summaries: list[dict], finals: dict[float, np.ndarray], path: Path,
                          title: str = "", notes: dict[float, str] | None = None) -> dict:
    """(a) R_hat vs Ku from ``swimrl-compare`` summaries (error bars: std over flows);
    (b-e) final displacements ``finals[Ku]`` ``(3, S, 2)`` (smart, naive, STO; drawn naive,
    STO, smart on top) on common axes (``lim``: the largest ``|Delta x|, |Delta y|`` of all
    panels, rounded up to 10 l_f), ``notes[Ku]`` under each panel's title."""
    plt = pyplot()
    fig = plt.figure(figsize=(14, 4.8))
    gs = fig.add_gridspec(1, 1 + len(finals), width_ratios=[1.3] + [1] * len(finals))
    ax = fig.add_subplot(gs[0])
    ku = np.asarray([s["kubo"] for s in summaries])
    out: dict = {"kubo": ku.tolist()}
    for key, name in (("naive", "naive"), ("sto", "STO")):
        y = [s[key]["R_hat_mean"] for s in summaries]
        ax.errorbar(ku, y, yerr=[s[key]["R_hat_std"] for s in summaries], color=COLORS[name],
                    marker="o", capsize=3,
                    label=name if name == "STO" else r"naive ($\Lambda=0.98$)")
        out[name] = y
    smart = [s["smart_mean"] for s in summaries]
    smart_std = [np.mean([x["R_hat_std"] for x in s["seeds"]]) for s in summaries]
    ax.errorbar(ku, smart, yerr=smart_std, color=COLORS["smart"], marker="o", capsize=3,
                label="smart (mean of seeds)")
    out["smart"] = smart
    ax.set_xscale("log")
    ax.set_xlabel("Ku")
    ax.set_ylabel(r"$\hat R$")
    n = summaries[0]
    ax.set_title(f"(a) {n['n_flows']} flows x {n['n_swimmers']}; bars: std over flows",
                 fontsize=8)
    ax.legend(fontsize=7)
    out["spread"] = {}
    reach = max((float(np.abs(f).max()) for f in finals.values()), default=1.0)
    lim = 10 * math.ceil(1.05 * reach / 10)
    out["lim"] = lim
    first = None
    for i, (kubo, final) in enumerate(sorted(finals.items())):
        a = fig.add_subplot(gs[i + 1], sharex=first, sharey=first)
        first = first or a
        for name in DRAW_ORDER:
            j = RECORD_STRATEGIES.index(name)
            a.scatter(final[j, :, 0], final[j, :, 1], s=2, color=COLORS[name], alpha=0.5,
                      label=name, rasterized=True, zorder=2 + DRAW_ORDER.index(name))
        a.plot(0, 0, "r*", ms=10, zorder=6)
        a.set_xlim(-lim, lim)
        a.set_ylim(-lim, lim)
        a.set_aspect("equal")
        note = (notes or {}).get(kubo)
        a.set_title(f"({'bcde'[i] if i < 4 else '?'}) {ku_display(kubo)}"
                    + (f"\n{note}" if note else ""), fontsize=7 if note else 9)
        a.set_xlabel(r"$\Delta x/\ell_f$")
        if i == 0:
            a.set_ylabel(r"$\Delta y/\ell_f$")
            handles, labels = a.get_legend_handles_labels()
            order = [labels.index(n) for n in RECORD_STRATEGIES]
            a.legend([handles[k] for k in order], RECORD_STRATEGIES, fontsize=7, markerscale=4,
                     loc="lower right")
        else:
            a.tick_params(labelleft=False)
        out["spread"][kubo] = np.linalg.norm(final, axis=-1).mean(axis=1).tolist()
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return out


def _ku_values(cfg: FiguresConfig, ev: Evaluation) -> dict:
    """A Ku record's entry of smartPerformance's record: per-flow R_hat, and each strategy's
    mean distance from the start at T (``mean_distance``, l_f)."""
    d = ku_record(cfg, ev.kubo)
    per = {n: d["per_flow"][j].tolist() for j, n in enumerate(ev.actors)}
    dist = np.linalg.norm(d["final"], axis=-1).mean(axis=1)
    return {"per_flow": per,
            "derived": {**flow_summary(per, [("smart", "STO"), ("smart", "naive")]),
                        "mean_distance": {n: float(dist[j]) for j, n in enumerate(ev.actors)}}}


def protocol_summary(summaries: list[dict]) -> dict:
    """The numbers of (a) per Ku, from the protocol's comparisons (:func:`summarise`)."""
    out = {}
    for s in summaries:
        out[ku_name(s["kubo"])] = {
            "n_flows": s["n_flows"], "n_swimmers": s["n_swimmers"], "seed": s["seed"],
            **{name: {"mean": s[key]["R_hat_mean"], "std": s[key]["R_hat_std"]}
               for key, name in (("naive", "naive"), ("sto", "STO"))},
            "smart_seeds": [{"label": x["label"], "mean": x["R_hat_mean"], "std": x["R_hat_std"],
                             "smart/STO": list(x["vs_sto"])} for x in s["seeds"]],
            "smart_mean": s["smart_mean"], "smart_seed_std": s["smart_seed_std"]}
    return out


def drawn_flow(rec: dict, summaries: list[dict]) -> dict:
    """What (b-e) draw against (a), for the record (``derived.panels_b_e``): per Ku the R_hat
    of the one flow drawn (the Ku record's), the strategies in its order and in the order of
    (a)'s means, and for each pair of strategies in how many of (a)'s flows the first lies
    above the second (smart: per seed)."""
    out: dict = {
        "flow": "flow 0 of evaluation seed 0: the only flow of each Ku record "
                "(figures.n_flows = 1), not one of (a)'s flows; smart = the shipped policy",
        "rule": "no flow is chosen: where the drawn flow orders two strategies otherwise than "
                "(a)'s means, the panel says so, with in how many of (a)'s flows they are "
                "ordered as in the drawn flow",
    }
    for s in summaries:
        key = ku_name(s["kubo"])
        if key not in rec["evaluations"]:
            continue
        drawn = {n: v[0] for n, v in rec["evaluations"][key]["per_flow"].items()}
        per = {"naive": [np.asarray(s["naive"]["per_flow"], dtype=float)],
               "STO": [np.asarray(s["sto"]["per_flow"], dtype=float)],
               "smart": [np.asarray(x["per_flow"], dtype=float) for x in s["seeds"]]}
        means = {"smart": s["smart_mean"], "naive": float(per["naive"][0].mean()),
                 "STO": float(per["STO"][0].mean())}
        above = {f"{x}>{y}": [int((p > q).sum()) for p in per[x] for q in per[y]]
                 for x, y in (("smart", "STO"), ("smart", "naive"), ("STO", "naive"))}
        out[key] = {"drawn": drawn, "order_drawn": sorted(drawn, key=lambda n: -drawn[n]),
                    "order_protocol": sorted(means, key=lambda n: -means[n]),
                    "protocol_flows": int(per["STO"][0].size), "protocol_above": above}
    return out


def panel_notes(panels: dict) -> dict[float, str]:
    """The lines under each of (b-e)'s titles: the drawn flow's R_hat, and each pair of
    strategies it orders otherwise than (a)'s means, with in how many of (a)'s flows they
    are ordered so."""
    notes = {}
    for key, d in panels.items():
        if not isinstance(d, dict):
            continue
        r, drawn, mean = d["drawn"], d["order_drawn"], d["order_protocol"]
        lines = ["$\\hat R$ of this flow:", ", ".join(f"{n} {r[n]:.3f}" for n in drawn)]
        for i, x in enumerate(drawn):
            for y in drawn[i + 1:]:
                if mean.index(x) > mean.index(y):  # x above y here, below in (a)'s means
                    pair = f"{x}>{y}" if f"{x}>{y}" in d["protocol_above"] else f"{y}>{x}"
                    n = d["protocol_above"][pair]
                    if pair != f"{x}>{y}":
                        n = [d["protocol_flows"] - k for k in n]
                    lines += [f"{x} > {y} here, as in {'/'.join(map(str, n))}",
                              f"of (a)'s {d['protocol_flows']} flows"]
        notes[parse_ku_name(key)] = "\n".join(lines)
    return notes


def build_smart_performance(cfg: FiguresConfig) -> dict:
    """(a) from the protocol's comparisons (``results``), (b-e) from the Ku records; the
    numbers of both in ``<records>/smartPerformance.json`` (with ``derived.panels_b_e``:
    :func:`drawn_flow`)."""
    files = sorted(Path(cfg.results).rglob(RunLayout(cfg.results).comparison.name))
    summaries = [summarise(r) for r in load([cfg.results])]
    evs = [ku_evaluation(cfg, k) for k in KUS]
    rec = figure_record(cfg, "smartPerformance", evs, lambda ev: _ku_values(cfg, ev),
                        lambda r: {"protocol": protocol_summary(summaries)}, sources=files)
    rec = extend_record(cfg, rec, lambda r: r["derived"].update(
        panels_b_e=drawn_flow(r, summaries)))
    finals = {k: ku_record(cfg, k)["final"] for k in KUS}
    flows, swimmers = record_sizes(rec, "trajectories")
    out = fig_smart_performance(
        summaries, finals, cfg.out / "smartPerformance.png",
        f"(b-e): final positions, {sizes_title(flows, swimmers, rec['params']['duration'])} "
        "per strategy, shipped policies; one flow per Ku (flow 0 of the test seed, not one of "
        "(a)'s); common axes; smart drawn on top",
        panel_notes(rec["derived"]["panels_b_e"]))
    out["record"] = str(cfg.records / "smartPerformance.json")
    return out
