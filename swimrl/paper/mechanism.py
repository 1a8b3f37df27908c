r"""What the smart swimmers do: Figs. ku0.1 (Lambda against ``n_theta S_np``), kuInf (Lambda over
``(n_r, S_np, omega)`` and the S_nn statistic) and ku_pattern (the policy maps at each Ku).

They are drawn from the statistics of every decision of ``map_flows`` x ``map_swimmers``
swimmers (>= 4e4 trajectories, 8e7 decisions per Ku) for each of the protocol's training seeds
(:mod:`.map_evaluations`), streamed into histograms as the evaluation runs
(:mod:`.decision_stats`), so that no decision is stored.

The histograms stay in the cache; each figure's record (``<records>/<figure>.json``) holds
per seed the per-flow R_hat, the sample counts, the S_nn statistic, the correlations and the
agreement with STO, and across seeds the correlation of their maps. The maps drawn are the
first seed's. A field added to this code after a record was made is added to that record
(:func:`~.records.extend_record`) from the cached (else re-simulated) evaluation, with how
far the re-simulation's per-flow R_hat lie from the record's; no other field changes.

Fig. kuInf (b), (c) weight each bin's colour by its occupancy (:func:`occupancy_weight`,
:data:`OCCUPANCY_DECADES`): full colour for a bin holding at least the uniform share
(``1 / bins``) of its panel's decisions, fading to white over two decades below it.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.analysis.policy_maps import SIGNAL
from swimrl.flows.labels import ku_display, ku_name

from .decision_stats import (
    MAPS,
    MIN_COUNT,
    SAMPLE_EVERY,
    DecisionRecorder,
    correlation,
    map_mean,
    sign_agreement,
    snn_statistic,
)
from .evaluations import KUS, RECORD_STRATEGIES, Evaluation, flow_summary, ku_evaluation, ku_record
from .map_evaluations import (
    add_sign_agreement,
    map_correlations,
    map_evaluation,
    map_record,
    map_values,
    per_seed,
    seed_evaluations,
)
from .records import extend_record, figure_record, record_sizes
from .settings import FiguresConfig
from .style import COLORS, LABEL, save, sizes_title

#: Fig. kuInf (b), (c): a bin's colour weight is ``1 + log10(share / uniform) / DECADES``
#: clipped to ``[0, 1]`` (``share``: its fraction of the panel's decisions, ``uniform = 1 /
#: bins``), the colour mixed with white by that weight: full colour at the uniform share or
#: above, white at ``10**-DECADES`` of it or below (and where fewer than MIN_COUNT decisions).
OCCUPANCY_DECADES = 2.0


def _seed_line(rec: dict, kubo: float, seeds: tuple[int, ...], key: str,
               percent: bool = False, digits: int = 0) -> str:
    """``seed 0: 81%, seed 1: 83%, ...``: a per-seed value of :func:`per_seed` (``digits``
    after the point of a percentage)."""
    d = per_seed(rec, kubo, seeds)

    def fmt(v) -> str:
        if v is None or not math.isfinite(v):
            return "n/a"
        return f"{100 * v:.{digits}f}%" if percent else f"{v:.2f}"

    return ", ".join(f"seed {s}: {fmt(d[str(s)][key])}" for s in seeds)


# -- Fig. ku0.1 ------------------------------------------------------------------------------
def fig_ku01(traj: np.ndarray, smart: dict[str, np.ndarray], sto_sig: np.ndarray,
             sto_lam: np.ndarray, path: Path, title: str = "") -> dict:
    """(a) trajectories ``traj`` ``(3, n, N+1, 2)`` from the origin; (b) Lambda against
    ``n_theta S_np`` for smart (its :class:`~.decision_stats.DecisionStats` arrays: the sample, the
    correlation and the agreement with STO over all decisions) and STO (recorded
    decisions), the quadrants of STO's sign shaded; inset: smart's
    ``<Lambda | n_theta, S_np>``."""
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.8))
    for j, name in enumerate(RECORD_STRATEGIES):
        for i, x in enumerate(traj[j]):
            a.plot(x[:, 0], x[:, 1], color=COLORS[name], lw=0.8, label=name if i == 0 else None)
    a.plot(0, 0, "r*", ms=10)
    a.set_aspect("equal")
    a.set_xlabel(r"$\Delta x/\ell_f$")
    a.set_ylabel(r"$\Delta y/\ell_f$")
    a.set_title("(a) trajectories from the start point, Ku = 0.1", fontsize=9)
    a.legend(fontsize=8)
    rng = np.random.default_rng(0)
    out = {"corr_smart": correlation(smart), "sign_smart": sign_agreement(smart)}
    sto = {"sig": sto_sig.reshape(-1, 5), "lam": sto_lam.ravel()}
    for name, sig, lam in (("smart", smart["sample_signals"], smart["sample_Lambda"]),
                           ("STO", sto["sig"], sto["lam"])):
        x = sig[:, SIGNAL["n_theta"]] * sig[:, SIGNAL["S_np"]]
        pick = rng.choice(x.size, min(x.size, 20000), replace=False)
        b.scatter(x[pick], lam[pick], s=1, color=COLORS[name], alpha=0.3, label=name,
                  rasterized=True)
    x = sto["sig"][:, SIGNAL["n_theta"]] * sto["sig"][:, SIGNAL["S_np"]]
    out["corr_STO"] = (float(np.corrcoef(x, sto["lam"])[0, 1])
                       if x.std() > 0 and sto["lam"].std() > 0 else float("nan"))
    # the quadrants where sign(Lambda) = sign(Lambda_STO) = -sign(n_theta S_np)
    b.axhline(0, color="0.6", lw=0.5, zorder=0)
    b.axvline(0, color="0.6", lw=0.5, zorder=0)
    xl, yl = b.get_xlim(), b.get_ylim()
    for (x0, x1), (y0, y1) in (((xl[0], 0), (0, yl[1])), ((0, xl[1]), (yl[0], 0))):
        b.fill_between([x0, x1], y0, y1, color=COLORS["STO"], alpha=0.08, lw=0, zorder=0)
    b.set_xlim(xl)
    b.set_ylim(yl)
    b.set_xlabel(r"$n_\theta S_{np}\tau_K$")
    b.set_ylabel(r"$\Lambda$")
    sign = out["sign_smart"]
    agree = (f"; shaded: sign(Λ) = sign(Λ_STO), smart: {100 * sign['fraction']:.1f}% of "
             f"its {sign['agree'] + sign['disagree']:.2g} decisions" if sign else "")
    b.set_title(f"(b) shape factor against $n_\\theta S_{{np}}${agree}", fontsize=8)
    b.legend(fontsize=8, markerscale=8, loc="lower left")
    ins = b.inset_axes([0.63, 0.56, 0.34, 0.34])
    mean, edges = map_mean(smart, "inset")
    im = ins.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
    ins.set_xlabel(r"$n_\theta$", fontsize=7, labelpad=0)
    ins.set_ylabel(r"$S_{np}\tau_K$", fontsize=7, labelpad=0)
    ins.tick_params(labelsize=6)
    fig.colorbar(im, ax=b, shrink=0.8, label=r"$\langle\Lambda\rangle$ (inset, smart)")
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    save(fig, path)
    out["inset"] = mean
    return out


def _ku01_values(cfg: FiguresConfig, ev: Evaluation) -> dict:
    if ev.group == "statistics":
        return map_values(cfg, ev)
    d = ku_record(cfg, ev.kubo)
    sig, lam = d["sto_signals"].reshape(-1, 5), d["sto_Lambda"].ravel()
    x = sig[:, SIGNAL["n_theta"]] * sig[:, SIGNAL["S_np"]]
    corr = float(np.corrcoef(x, lam)[0, 1]) if x.std() > 0 and lam.std() > 0 else math.nan
    per = {n: d["per_flow"][j].tolist() for j, n in enumerate(ev.actors)}
    return {"per_flow": per, "counts": {"sto_decisions": int(lam.size)},
            "derived": {**flow_summary(per, [("smart", "STO")]), "corr_STO": corr}}


def build_ku01(cfg: FiguresConfig) -> dict:
    kubo = 0.1
    stats = seed_evaluations(cfg, kubo)
    traj_ev = replace(ku_evaluation(cfg, kubo), options={"n_traj": cfg.n_traj})
    rec = figure_record(cfg, "ku0.1", [*stats, traj_ev], lambda ev: _ku01_values(cfg, ev),
                        lambda r: {"per_seed": per_seed(r, kubo, cfg.map_seeds)})
    add = add_sign_agreement(cfg, stats)

    def edit(r: dict) -> None:
        add(r)
        r["derived"]["per_seed"] = per_seed(r, kubo, cfg.map_seeds)

    rec = extend_record(cfg, rec, edit)
    d = ku_record(cfg, kubo)
    seed0 = cfg.map_seeds[0]
    mf, ms = record_sizes(rec, "statistics")
    tf, ts = record_sizes(rec, "trajectories")
    agree = _seed_line(rec, kubo, cfg.map_seeds, "sign_agreement_STO", True, 1)
    corr = _seed_line(rec, kubo, cfg.map_seeds, "corr_Lambda_ntheta_Snp")
    duration = rec["params"]["duration"]
    out = fig_ku01(d["traj"], map_record(cfg, stats[0]), d["sto_signals"], d["sto_Lambda"],
                   cfg.out / "ku0.1.png",
                   f"Ku = 0.1; (a) shipped policy ku0.1, {sizes_title(tf, ts, duration)};\n"
                   f"(b) the protocol's run seed {seed0} on {mf} flows x {ms} swimmers "
                   f"(inset: its map; scatter: a sample of its first 10 flows);\n"
                   f"sign(Λ) = sign(Λ_STO) in every decision where STO has a sign: {agree}; "
                   f"corr(Λ, $n_\\theta S_{{np}}$): {corr}")
    out["record"] = str(cfg.records / "ku0.1.json")
    return out


# -- Fig. kuInf and the S_nn statistic -------------------------------------------------------
def occupancy_weight(counts: np.ndarray, decades: float = OCCUPANCY_DECADES,
                     min_count: int = MIN_COUNT) -> np.ndarray:
    """The colour weight of each bin of a map (:data:`OCCUPANCY_DECADES`): ``1 +
    log10(share / uniform) / decades`` clipped to ``[0, 1]``, ``share`` the bin's fraction of
    the map's decisions and ``uniform = 1 / bins``; 0 where fewer than ``min_count``."""
    c = np.asarray(counts, dtype=float)
    share = c / max(c.sum(), 1.0)
    with np.errstate(divide="ignore"):
        w = 1 + np.log10(share * c.size) / decades
    w = np.clip(np.nan_to_num(w, neginf=0.0), 0.0, 1.0)
    w[c < max(1, min_count)] = 0.0
    return w


def occupancy_rule(bins: int, decades: float = OCCUPANCY_DECADES,
                   min_count: int = MIN_COUNT) -> dict:
    """The colour rule of Fig. kuInf (b), (c) as its record states it."""
    return {"weight": f"clip(1 + log10(share * {bins * bins}) / {decades:g}, 0, 1); colour "
                      "= weight * colormap(<Lambda>) + (1 - weight) * white",
            "share": "the bin's fraction of the panel's decisions",
            "full_colour_share": 1 / bins**2, "white_share": 10**-decades / bins**2,
            "min_count": min_count}


def _draw_weighted(fig, ax, mean: np.ndarray, weight: np.ndarray, edges: list[np.ndarray]):
    """``mean`` ``(x, y)`` in coolwarm on ``[-1, 1]`` mixed with white by ``weight``."""
    from matplotlib import cm, colors

    cmap, norm = pyplot().get_cmap("coolwarm"), colors.Normalize(-1, 1)
    rgb = cmap(norm(np.nan_to_num(mean)))[..., :3]
    w = np.where(np.isfinite(mean), weight, 0.0)[..., None]
    rgb = w * rgb + (1 - w) * 1.0
    ax.imshow(np.swapaxes(rgb, 0, 1), origin="lower", aspect="auto", interpolation="nearest",
              extent=[edges[0][0], edges[0][-1], edges[1][0], edges[1][-1]])
    return fig.colorbar(cm.ScalarMappable(norm, cmap), ax=ax,
                        label=r"$\langle\Lambda\rangle$ (full colour)")


def fig_ku_inf(smart: dict[str, np.ndarray], path: Path, title: str = "",
               statistic: str = "", sample: str = "") -> dict:
    """(a) Lambda over (n_r, S_np, omega) (the sample; ``sample``: where it comes from, in
    its title); (b, c) ``<Lambda | S_np, omega>`` for ``n_r >= 0.8`` and ``n_r <= -0.8``,
    each bin's colour weighted by its occupancy (:func:`occupancy_weight`); the S_nn
    statistic (``statistic``: as the record states it per seed; default: of ``smart``)
    under the title."""
    from matplotlib.ticker import MaxNLocator

    plt = pyplot()
    s, lam = smart["sample_signals"].reshape(-1, 5), smart["sample_Lambda"].ravel()
    fig = plt.figure(figsize=(15, 5.4))
    grid = fig.add_gridspec(1, 3, width_ratios=[1.1, 1, 1], left=0.01, right=0.97, top=0.8,
                            bottom=0.12, wspace=0.22)
    ax = fig.add_subplot(grid[0], projection="3d")
    n_drawn = min(lam.size, 8000)
    pick = np.random.default_rng(0).choice(lam.size, n_drawn, replace=False)
    sc = ax.scatter(s[pick, 0], s[pick, 3], s[pick, 4], c=lam[pick], cmap="coolwarm", vmin=-1,
                    vmax=1, s=2)
    ax.set_box_aspect(None, zoom=0.9)  # room for the z label inside the figure
    ax.set_xticks([-1, 0, 1])
    for axis in (ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))
    ax.set_xlabel(r"$n_r$", labelpad=0)
    ax.set_ylabel(r"$S_{np}\tau_K$", labelpad=0)
    ax.set_zlabel(r"$\omega\tau_K$", labelpad=0)
    ax.tick_params(labelsize=7, pad=0)
    ax.set_title(f"(a) {n_drawn} decisions at random of a sample of {lam.size}"
                 + (f"\n{sample}" if sample else ""), fontsize=8)
    fig.colorbar(sc, ax=ax, shrink=0.55, label=r"$\Lambda$", pad=0.04)
    out = {"snn": snn_statistic(smart), "a": {"drawn": n_drawn, "sample": int(lam.size)},
           "occupancy": {}}
    for i, (label, name) in enumerate(((r"$n_r \geq 0.8$", "omega_nr_pos"),
                                       (r"$n_r \leq -0.8$", "omega_nr_neg"))):
        a = fig.add_subplot(grid[1 + i])
        mean, edges = map_mean(smart, name)
        counts = np.asarray(smart[f"map_{name}_count"])
        weight = occupancy_weight(counts)
        _draw_weighted(fig, a, mean, weight, edges)
        a.set_xlabel(r"$S_{np}\tau_K$")
        a.set_ylabel(r"$\omega\tau_K$")
        # two significant digits: the exact count follows chaotic float32 trajectories and
        # differs between machines (docs/reliability.md); the record holds the total count
        n = int(counts.sum())
        full = float(counts[weight >= 1].sum() / max(n, 1))
        faint = float(counts[weight < 0.5].sum() / max(n, 1))
        a.set_title(f"({'bc'[i]}) {label}, {n:.2g} decisions; full colour: bins holding "
                    f"≥ 1/{counts.size}\nof them (together {100 * full:.0f}%); under half "
                    f"colour: bins holding {100 * faint:.1f}%", fontsize=8)
        out["bc"[i]] = mean
        out["occupancy"]["bc"[i]] = {"full_colour": full, "under_half": faint,
                                     "weight": weight}
    if not statistic:
        st = out["snn"]
        statistic = (f"P(Λ>0 | lowest 1% of S_nn) = {100 * st['p_pos_given_low']:.0f}%, "
                     f"P(Λ<0 | highest 1%) = {100 * st['p_neg_given_high']:.0f}%")
    rule = (f"(b), (c): a bin's colour fades to white with its share of the panel's decisions: "
            f"weight = clip(1 + log10(share x bins) / {OCCUPANCY_DECADES:g}, 0, 1), full at "
            f"the uniform share, white at 1/{10**OCCUPANCY_DECADES:g} of it or with < "
            f"{MIN_COUNT} decisions")
    fig.suptitle(f"{title}\nS_nn statistic: {statistic} (paper: 82%)\n{rule}", fontsize=8)
    save(fig, path)
    return out


def sample_statement(cfg: FiguresConfig, ev: Evaluation) -> tuple[str, dict]:
    """Where the sample of an evaluation's decisions (Fig. kuInf (a)) comes from: a title
    line and the record's entry."""
    sz, params = ev.setup.sizes, ev.setup.params
    flows = min(sz.flows_per_batch, sz.n_flows)
    keep = DecisionRecorder.sample_swimmers(params.n_decisions, flows, sz.n_swimmers)
    per_swimmer = math.ceil(params.n_decisions / SAMPLE_EVERY)
    return (f"(every {SAMPLE_EVERY}th decision of swimmers 1-{keep} of flows 1-{flows})",
            {"policy": ev.actors["smart"], "flows": flows, "swimmers_per_flow": keep,
             "every": SAMPLE_EVERY, "sample": keep * flows * per_swimmer, "drawn":
             min(keep * flows * per_swimmer, 8000)})


def build_ku_inf(cfg: FiguresConfig) -> dict:
    kubo = 1e7
    stats = seed_evaluations(cfg, kubo)
    rec = figure_record(cfg, "kuInf", stats, lambda ev: map_values(cfg, ev),
                        lambda r: {"per_seed": per_seed(r, kubo, cfg.map_seeds)})
    line, entry = sample_statement(cfg, stats[0])
    bins = MAPS["omega_nr_pos"][3]

    def drawn(r: dict) -> None:
        r["derived"]["drawn"] = {"seed": cfg.map_seeds[0], "a": entry,
                                 "bc_colour": occupancy_rule(bins)}

    rec = extend_record(cfg, rec, drawn)
    flows, swimmers = record_sizes(rec, "statistics")
    low = _seed_line(rec, kubo, cfg.map_seeds, "p_pos_given_low", True)
    high = _seed_line(rec, kubo, cfg.map_seeds, "p_neg_given_high", True)
    n = rec["evaluations"][stats[0].key]["counts"]["decisions"]
    out = fig_ku_inf(map_record(cfg, stats[0]), cfg.out / "kuInf.png",
                     f"smart, Ku = $10^7$: the protocol's run seed {cfg.map_seeds[0]} "
                     f"({stats[0].actors['smart']}) drawn; "
                     f"{sizes_title(flows, swimmers, rec['params']['duration'])} "
                     f"({n:.2g} decisions) per seed",
                     f"P(Λ>0 | lowest 1% of S_nn) {low}; P(Λ<0 | highest 1%) {high}", line)
    out["record"] = str(cfg.records / "kuInf.json")
    return out


# -- Fig. ku_pattern -------------------------------------------------------------------------
def fig_ku_pattern(records: dict[float, dict[str, np.ndarray]], path: Path,
                   title: str = "") -> dict:
    """``<Lambda | S_np, n_theta>`` (top) and ``<Lambda | S_np, omega>`` (bottom) per Ku, from
    each Ku's :class:`~.decision_stats.DecisionStats` arrays."""
    plt = pyplot()
    kus = sorted(records)
    fig, axes = plt.subplots(2, len(kus), figsize=(3.3 * len(kus), 6.4), squeeze=False,
                             layout="constrained")
    out = {}
    for i, kubo in enumerate(kus):
        for row, other in enumerate(("n_theta", "omega")):
            mean, edges = map_mean(records[kubo], other)
            a = axes[row, i]
            im = a.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
            a.set_xlabel(LABEL["S_np"])
            a.set_ylabel(LABEL[other])
            a.set_title(f"({'abcdefgh'[row * 4 + i] if len(kus) == 4 else ''}) "
                        f"{ku_display(kubo)}", fontsize=9)
            out[(kubo, other)] = mean
    fig.colorbar(im, ax=axes, shrink=0.6, label=r"$\langle\Lambda\rangle$")
    fig.suptitle(title, fontsize=8)
    save(fig, path)
    return out


def build_ku_pattern(cfg: FiguresConfig) -> dict:
    evs = [ev for k in KUS for ev in seed_evaluations(cfg, k)]

    def derive(r: dict) -> dict:
        return {ku_name(k): {"per_seed": per_seed(r, k, cfg.map_seeds),
                             "map_correlation": map_correlations(cfg, k)} for k in KUS}

    rec = figure_record(cfg, "ku_pattern", evs, lambda ev: map_values(cfg, ev), derive)
    flows, swimmers = record_sizes(rec, "statistics")
    seed0 = cfg.map_seeds[0]
    corr = "; ".join(
        f"{ku_display(k)}: " + ", ".join(f"{v:.2f}" for v in
                                          rec["derived"][ku_name(k)]["map_correlation"]
                                          ["omega"].values() if v is not None)
        for k in KUS)
    out = fig_ku_pattern({k: map_record(cfg, map_evaluation(cfg, k, seed0)) for k in KUS},
                         cfg.out / "ku_pattern.png",
                         f"smart, the protocol's runs seed {seed0}; "
                         f"{sizes_title(flows, swimmers, rec['params']['duration'])} per Ku;\n"
                         f"correlation of the seeds' <Λ|S_np, ω> maps (pairs of seeds "
                         f"{', '.join(map(str, cfg.map_seeds))}): {corr}")
    out["record"] = str(cfg.records / "ku_pattern.json")
    return out
