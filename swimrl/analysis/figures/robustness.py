"""Figs. robustness-noise and robustness: R_hat of smart (trained at the paper's values), naive
and STO at Ku = 10 against the rotational diffusion, the episode duration, the decision interval
and the swimming speed."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot

from .records import (
    RECORD_STRATEGIES,
    FiguresConfig,
    eval_setup,
    flow_stats,
    per_flow_record,
    smart_policy,
)
from .style import COLORS, save, sizes_title


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
    ax.set_xscale("log")
    ax.set_xticks(x, [f"{v:g}" for v in x])
    ax.minorticks_off()


def fig_sweep(x: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray], xlabel: str,
              path: Path, title: str = "", ratio: bool = False,
              reference: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """R_hat of the strategies against a swept parameter (error bars: std over flows), and
    with ``ratio`` a second panel smart / STO."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2 if ratio else 1, figsize=(9 if ratio else 4.8, 3.6),
                             squeeze=False)
    _draw_sweep(axes[0, 0], x, r, err, xlabel, reference)
    out = {"x": np.asarray(x).tolist(), **{k: np.asarray(v).tolist() for k, v in r.items()}}
    if ratio:
        b = axes[0, 1]
        q = np.asarray(r["smart"]) / np.asarray(r["STO"])
        b.plot(x, q, color=COLORS["smart"], marker="o")
        b.axhline(1, color=COLORS["STO"], ls="--", lw=1)
        _log_ticks(b, x)
        b.set_xlabel(xlabel)
        b.set_ylabel(r"$\hat R_{\rm smart}/\hat R_{\rm STO}$")
        out["ratio"] = q.tolist()
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return out


def sweep_record(cfg: FiguresConfig, name: str, values: list[float], key: str,
                 kubo: float = 10.0) -> dict[str, np.ndarray]:
    """Per-flow R_hat ``(len(values), 3, F)`` of smart (trained at the paper's values), naive
    and STO with ``EnvParams.<key>`` set to each value (cached)."""
    out = []
    for v in values:
        setup = eval_setup(cfg, kubo, cfg.robust_flows, cfg.robust_swimmers, **{key: v})
        actors = [smart_policy(cfg, kubo), "naive", "sto"]
        out.append(per_flow_record(cfg, f"{name}_{key}{v:g}", setup, actors))
    return {"per_flow": np.stack(out)}


def build_robustness_noise(cfg: FiguresConfig) -> dict:
    d_r = [1e-4, 1e-3, 1e-2, 1e-1]
    per = sweep_record(cfg, "noise", d_r, "rot_diffusion")["per_flow"]
    mean, std = flow_stats(per)
    return fig_sweep(np.asarray(d_r), mean, std, r"$D_r\tau_K$",
                     cfg.out / "robustness-noise.png",
                     f"Ku = 10, smart trained at $D_r = 0$; "
                     f"{sizes_title(cfg.robust_flows, cfg.robust_swimmers, cfg.params)}; "
                     "bars: std over flows", ratio=True)


def build_robustness(cfg: FiguresConfig) -> dict:
    """(a) R_hat vs T (with naive's T^(-1/2) through T = 200), (b) vs T_u, (c) vs v_s."""
    sweeps = (("duration", [50.0, 100.0, 200.0, 400.0], r"$T/\tau_K$"),
              ("update_interval", [0.05, 0.1, 0.2, 0.5], r"$T_u/\tau_K$"),
              ("swim_speed", [0.354, 0.707, 1.414], r"$v_s/u_{\rm rms}$"))
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    out = {}
    for ax, (key, values, label), tag in zip(axes, sweeps, "abc", strict=True):
        per = sweep_record(cfg, "robust", values, key)["per_flow"]
        mean, std = flow_stats(per)
        x = np.asarray(values)
        ref = (x, mean["naive"][2] * np.sqrt(200.0 / x)) if key == "duration" else None
        _draw_sweep(ax, x, mean, std, label, ref)
        ax.set_title(f"({tag})", fontsize=9)
        out[key] = {"x": values, **{k: v.tolist() for k, v in mean.items()}}
    fig.suptitle(f"Ku = 10, smart trained at T = 200, $T_u$ = 0.1 $\\tau_K$, $v_s$ = 0.707 "
                 f"$u_{{\\rm rms}}$; {cfg.robust_flows} flows x {cfg.robust_swimmers} swimmers "
                 "per point; bars: std over flows", fontsize=8)
    fig.tight_layout()
    save(fig, cfg.out / "robustness.png")
    return out
