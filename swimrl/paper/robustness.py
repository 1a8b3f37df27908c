"""Figs. robustness-noise and robustness: R_hat of smart (trained at the paper's values), naive
and STO at Ku = 10 against the rotational diffusion, the episode duration, the decision interval
and the swimming speed.

Every point is one evaluation of the figure's record (``<records>/robustness-noise.json``,
``robustness.json``; :func:`~.records.figure_record`): ``robust_flows`` x ``robust_swimmers``
per strategy on shared flows; the error bars are the std over flows (the paper's convention),
the ratio panel the paired ratio ``<smart>/<STO>`` with its delta-method SEM."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot

from .evaluations import RECORD_STRATEGIES, Evaluation, eval_setup, per_flow_values, smart_policy
from .records import figure_record, record_sizes
from .settings import FiguresConfig
from .style import COLORS, save, sizes_title

#: The swept parameters of Fig. robustness: (field of EnvParams, field of FiguresConfig
#: holding the values, axis label).
SWEEPS = (("duration", "durations", r"$T/\tau_K$"),
          ("update_interval", "update_intervals", r"$T_u/\tau_K$"),
          ("swim_speed", "swim_speeds", r"$v_s/u_{\rm rms}$"))
KUBO = 10.0


def _draw_sweep(ax, x: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray],
                xlabel: str, reference: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """R_hat of the strategies against a swept parameter on ``ax`` (log x, ticks at ``x``)."""
    for name in RECORD_STRATEGIES:
        ax.errorbar(x, r[name], yerr=err[name], color=COLORS[name], marker="o", capsize=3,
                    label=name)
    if reference is not None:
        ax.plot(*reference, "k:", lw=1, label=r"$\propto T^{-1/2}$")
    _log_ticks(ax, x)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(r"$\hat R$")
    ax.legend(fontsize=7)


def _log_ticks(ax, x: np.ndarray) -> None:
    """Log x axis with ticks at ``x``; symmetric-log, linear below the smallest positive
    value, where ``x`` holds 0."""
    x = np.asarray(x, dtype=float)
    if (x <= 0).any():
        ax.set_xscale("symlog", linthresh=float(x[x > 0].min()) if (x > 0).any() else 1.0)
    else:
        ax.set_xscale("log")
    ax.set_xticks(x, [f"{v:g}" for v in x], rotation=45 if x.size > 4 else 0)
    ax.minorticks_off()


def fig_sweep(x: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray], xlabel: str,
              path: Path, title: str = "",
              ratio: tuple[np.ndarray, np.ndarray] | None = None,
              reference: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """R_hat of the strategies against a swept parameter (error bars: std over flows), and
    with ``ratio`` (values, SEMs) a second panel smart / STO (paired, bars: SEM)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2 if ratio is not None else 1,
                             figsize=(9 if ratio is not None else 4.8, 3.6), squeeze=False)
    _draw_sweep(axes[0, 0], x, r, err, xlabel, reference)
    out = {"x": np.asarray(x).tolist(), **{k: np.asarray(v).tolist() for k, v in r.items()}}
    if ratio is not None:
        b = axes[0, 1]
        q, q_err = (np.asarray(v, dtype=float) for v in ratio)
        b.errorbar(x, q, yerr=q_err, color=COLORS["smart"], marker="o", capsize=3)
        b.axhline(1, color=COLORS["STO"], ls="--", lw=1)
        _log_ticks(b, x)
        b.set_xlim(axes[0, 0].get_xlim())
        b.set_xlabel(xlabel)
        b.set_ylabel(r"$\hat R_{\rm smart}/\hat R_{\rm STO}$ (paired, bars: SEM)")
        out["ratio"], out["ratio_sem"] = q.tolist(), q_err.tolist()
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return out


def sweep_evaluations(cfg: FiguresConfig, key: str, values: tuple[float, ...],
                      kubo: float = KUBO) -> list[Evaluation]:
    """Smart (the shipped policy trained at ``kubo`` with the paper's values), naive and STO
    with ``EnvParams.<key>`` set to each of ``values``: one evaluation each (``key=value``)."""
    actors = {"smart": smart_policy(cfg, kubo), "naive": "naive", "STO": "sto"}
    return [Evaluation(f"{key}={v:g}", "sweep",
                       eval_setup(cfg, kubo, cfg.robust_flows, cfg.robust_swimmers, **{key: v}),
                       actors) for v in values]


def sweep_arrays(rec: dict, evaluations: list[Evaluation]) -> dict[str, dict[str, np.ndarray]]:
    """From a record: ``mean``, ``std`` per strategy and ``ratio``, ``ratio_sem`` (smart /
    STO) along the evaluations."""
    d = [rec["evaluations"][ev.key]["derived"] for ev in evaluations]
    return {"mean": {n: np.array([x["mean"][n] for x in d]) for n in RECORD_STRATEGIES},
            "std": {n: np.array([x["std"][n] for x in d]) for n in RECORD_STRATEGIES},
            "ratio": np.array([x["ratio"]["smart/STO"]["value"] for x in d]),
            "ratio_sem": np.array([x["ratio"]["smart/STO"]["sem"] for x in d])}


def _sweep_derived(rec: dict, sweeps: dict[str, list[Evaluation]]) -> dict:
    """The numbers the docs quote, per swept parameter: x, mean and std over flows of each
    strategy, smart / STO (paired) with its SEM."""
    out = {}
    for key, evs in sweeps.items():
        a = sweep_arrays(rec, evs)
        out[key] = {"x": [float(getattr(ev.setup.params, key)) for ev in evs],
                    "mean": {k: v.tolist() for k, v in a["mean"].items()},
                    "std": {k: v.tolist() for k, v in a["std"].items()},
                    "smart/STO": a["ratio"].tolist(), "smart/STO_sem": a["ratio_sem"].tolist()}
    return out


def build_robustness_noise(cfg: FiguresConfig) -> dict:
    evs = sweep_evaluations(cfg, "rot_diffusion", cfg.noise)
    rec = figure_record(cfg, "robustness-noise", evs, lambda ev: per_flow_values(cfg, ev),
                        lambda r: _sweep_derived(r, {"rot_diffusion": evs}))
    a = sweep_arrays(rec, evs)
    flows, swimmers = record_sizes(rec, "sweep")
    out = fig_sweep(np.asarray(cfg.noise), a["mean"], a["std"], r"$D_r\tau_K$",
                    cfg.out / "robustness-noise.png",
                    f"Ku = 10, smart trained at $D_r = 0$; "
                    f"{sizes_title(flows, swimmers, rec['params']['duration'])} per strategy "
                    "and point; bars: std over flows", ratio=(a["ratio"], a["ratio_sem"]))
    out["record"] = str(cfg.records / "robustness-noise.json")
    return out


def build_robustness(cfg: FiguresConfig) -> dict:
    """(a) R_hat vs T (with naive's T^(-1/2) through the trained T), (b) vs T_u, (c) vs v_s."""
    sweeps = {key: sweep_evaluations(cfg, key, getattr(cfg, values))
              for key, values, _ in SWEEPS}
    rec = figure_record(cfg, "robustness", [ev for evs in sweeps.values() for ev in evs],
                        lambda ev: per_flow_values(cfg, ev), lambda r: _sweep_derived(r, sweeps))
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    out: dict = {"record": str(cfg.records / "robustness.json")}
    for ax, (key, values, label), tag in zip(axes, SWEEPS, "abc", strict=True):
        a = sweep_arrays(rec, sweeps[key])
        x = np.asarray(getattr(cfg, values))
        ref = None
        trained = np.flatnonzero(np.isclose(x, cfg.params.duration))
        if key == "duration" and trained.size:
            ref = (x, a["mean"]["naive"][trained[0]] * np.sqrt(cfg.params.duration / x))
        _draw_sweep(ax, x, a["mean"], a["std"], label, ref)
        ax.set_title(f"({tag})", fontsize=9)
        out[key] = {"x": x.tolist(), **{k: v.tolist() for k, v in a["mean"].items()}}
    flows, swimmers = record_sizes(rec, "sweep")
    p = cfg.params
    fig.suptitle(f"Ku = 10, smart trained at T = {p.duration:g}, $T_u$ = {p.update_interval:g} "
                 f"$\\tau_K$, $v_s$ = {p.swim_speed:g} $u_{{\\rm rms}}$; {flows} flows x "
                 f"{swimmers} swimmers per strategy and point; bars: std over flows",
                 fontsize=8)
    fig.tight_layout()
    save(fig, cfg.out / "robustness.png")
    return out
