"""The swimmers in the stochastic flow: Fig. 1(a) (one prolate and one oblate swimmer over the
vorticity) and Fig. smartPerformance (R_hat against Ku, and the final displacements of smart,
naive and STO at each Ku)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from swimrl.analysis.performance import load, summarise
from swimrl.analysis.plots import pyplot
from swimrl.flows.labels import ku_display, ku_name
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.layout import RunLayout
from swimrl.runs.spec import EvalSizes

from .records import (
    KUS,
    RECORD_STRATEGIES,
    Evaluation,
    FiguresConfig,
    cache_inputs,
    cached,
    eval_setup,
    figure_record,
    flow_summary,
    flow_vorticity,
    ku_evaluation,
    ku_record,
    record_sizes,
    record_strategies,
)
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
def fig_smart_performance(summaries: list[dict], finals: dict[float, np.ndarray], path: Path,
                          title: str = "") -> dict:
    """(a) R_hat vs Ku from ``swimrl-compare`` summaries (error bars: std over flows);
    (b-e) final displacements ``finals[Ku]`` ``(3, S, 2)`` (smart, naive, STO)."""
    plt = pyplot()
    fig = plt.figure(figsize=(13, 3.8))
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
    for i, (kubo, final) in enumerate(sorted(finals.items())):
        a = fig.add_subplot(gs[i + 1])
        for j, name in enumerate(RECORD_STRATEGIES):
            a.scatter(final[j, :, 0], final[j, :, 1], s=2, color=COLORS[name], alpha=0.5,
                      label=name, rasterized=True)
        a.plot(0, 0, "r*", ms=10)
        a.set_aspect("equal")
        a.set_title(f"({'bcde'[i] if i < 4 else '?'}) {ku_display(kubo)}", fontsize=9)
        a.set_xlabel(r"$\Delta x/\ell_f$")
        if i == 0:
            a.set_ylabel(r"$\Delta y/\ell_f$")
            a.legend(fontsize=7, markerscale=4, loc="lower right")
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


def build_smart_performance(cfg: FiguresConfig) -> dict:
    """(a) from the protocol's comparisons (``results``), (b-e) from the Ku records; the
    numbers of both in ``<records>/smartPerformance.json``."""
    files = sorted(Path(cfg.results).rglob(RunLayout(cfg.results).comparison.name))
    summaries = [summarise(r) for r in load([cfg.results])]
    evs = [ku_evaluation(cfg, k) for k in KUS]
    rec = figure_record(cfg, "smartPerformance", evs, lambda ev: _ku_values(cfg, ev),
                        lambda r: {"protocol": protocol_summary(summaries)}, sources=files)
    finals = {k: ku_record(cfg, k)["final"] for k in KUS}
    flows, swimmers = record_sizes(rec, "trajectories")
    out = fig_smart_performance(
        summaries, finals, cfg.out / "smartPerformance.png",
        f"(b-e): final positions, {sizes_title(flows, swimmers, rec['params']['duration'])} "
        "per strategy, shipped policies")
    out["record"] = str(cfg.records / "smartPerformance.json")
    return out
