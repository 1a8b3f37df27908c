"""What the smart swimmers do: Figs. ku0.1 (Lambda against ``n_theta S_np``), kuInf (Lambda over
``(n_r, S_np, omega)`` and the S_nn statistic) and ku_pattern (the policy maps at each Ku)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.analysis.policy_maps import (
    SIGNAL,
    binned_mean,
    lambda_maps,
    snn_extremes,
    symmetric_range,
)
from swimrl.flows.labels import ku_display

from .records import KUS, RECORD_STRATEGIES, FiguresConfig, ku_record
from .style import COLORS, LABEL, save, sizes_title


# -- Fig. ku0.1 ------------------------------------------------------------------------------
def fig_ku01(traj: np.ndarray, smart_sig: np.ndarray, smart_lam: np.ndarray,
             sto_sig: np.ndarray, sto_lam: np.ndarray, path: Path, title: str = "") -> dict:
    """(a) trajectories ``traj`` ``(3, n, N+1, 2)`` from the origin; (b) Lambda against
    ``n_theta S_np`` for smart and STO; inset: smart's ``<Lambda | n_theta, S_np>``."""
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.6))
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
    out = {}
    for name, sig, lam in (("smart", smart_sig, smart_lam), ("STO", sto_sig, sto_lam)):
        x = (sig[..., SIGNAL["n_theta"]] * sig[..., SIGNAL["S_np"]]).ravel()
        y = lam.ravel()
        pick = rng.choice(x.size, min(x.size, 20000), replace=False)
        b.scatter(x[pick], y[pick], s=1, color=COLORS[name], alpha=0.3, label=name,
                  rasterized=True)
        out[f"corr_{name}"] = float(np.corrcoef(x, y)[0, 1]) if x.std() > 0 else float("nan")
    b.set_xlabel(r"$n_\theta S_{np}\tau_K$")
    b.set_ylabel(r"$\Lambda$")
    b.set_title("(b) shape factor against $n_\\theta S_{np}$", fontsize=9)
    b.legend(fontsize=8, markerscale=8, loc="lower left")
    ins = b.inset_axes([0.63, 0.56, 0.34, 0.34])
    mean, edges, _ = binned_mean(smart_lam, [smart_sig[..., 1], smart_sig[..., 3]], bins=24,
                                 ranges=[(-1, 1), symmetric_range(smart_sig[..., 3])],
                                 min_count=5)
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


def build_ku01(cfg: FiguresConfig) -> dict:
    d = ku_record(cfg, 0.1)
    return fig_ku01(d["traj"], d["signals"], d["Lambda"], d["sto_signals"], d["sto_Lambda"],
                    cfg.out / "ku0.1.png",
                    f"Ku = 0.1, shipped policy ku0.1; "
                    f"{sizes_title(cfg.n_flows, cfg.n_swimmers, cfg.params)}")


# -- Fig. kuInf and the S_nn statistic -------------------------------------------------------
def fig_ku_inf(sig: np.ndarray, lam: np.ndarray, path: Path, title: str = "") -> dict:
    """(a) Lambda over (n_r, S_np, omega) (a subsample); (b, c) ``<Lambda | S_np, omega>``
    for ``n_r >= 0.8`` and ``n_r <= -0.8``; the S_nn statistic in the title."""
    plt = pyplot()
    s, lam = sig.reshape(-1, 5), lam.ravel()
    fig = plt.figure(figsize=(14, 4.3))
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    pick = np.random.default_rng(0).choice(lam.size, min(lam.size, 8000), replace=False)
    sc = ax.scatter(s[pick, 0], s[pick, 3], s[pick, 4], c=lam[pick], cmap="coolwarm", vmin=-1,
                    vmax=1, s=2)
    ax.set_xlabel(r"$n_r$")
    ax.set_ylabel(r"$S_{np}\tau_K$")
    ax.set_zlabel(r"$\omega\tau_K$")
    ax.set_title("(a)", fontsize=9)
    fig.colorbar(sc, ax=ax, shrink=0.6, label=r"$\Lambda$", pad=0.1)
    ranges = [symmetric_range(s[:, 3]), symmetric_range(s[:, 4])]
    out = {"snn": snn_extremes(s[:, 2], lam)}
    for i, (label, mask) in enumerate(((r"$n_r \geq 0.8$", s[:, 0] >= 0.8),
                                       (r"$n_r \leq -0.8$", s[:, 0] <= -0.8))):
        a = fig.add_subplot(1, 3, 2 + i)
        mean, edges, _ = binned_mean(lam[mask], [s[mask, 3], s[mask, 4]], bins=30,
                                     ranges=ranges, min_count=5)
        im = a.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
        fig.colorbar(im, ax=a, label=r"$\langle\Lambda\rangle$")
        a.set_xlabel(r"$S_{np}\tau_K$")
        a.set_ylabel(r"$\omega\tau_K$")
        a.set_title(f"({'bc'[i]}) {label}, {int(mask.sum())} decisions", fontsize=9)
        out["bc"[i]] = mean
    st = out["snn"]
    fig.suptitle(f"{title}\nS_nn statistic: P(Λ>0 | lowest 1% of S_nn) = "
                 f"{100 * st['p_pos_given_low']:.0f}%, P(Λ<0 | highest 1%) = "
                 f"{100 * st['p_neg_given_high']:.0f}% (paper: 82%)", fontsize=8)
    fig.tight_layout()
    save(fig, path)
    return out


def build_ku_inf(cfg: FiguresConfig) -> dict:
    d = ku_record(cfg, 1e7)
    return fig_ku_inf(d["signals"], d["Lambda"], cfg.out / "kuInf.png",
                      f"smart, Ku = $10^7$, shipped policy ku1e7; "
                      f"{sizes_title(cfg.n_flows, cfg.n_swimmers, cfg.params)}")


# -- Fig. ku_pattern -------------------------------------------------------------------------
def fig_ku_pattern(records: dict[float, tuple[np.ndarray, np.ndarray]], path: Path,
                   title: str = "") -> dict:
    """``<Lambda | S_np, n_theta>`` (top) and ``<Lambda | S_np, omega>`` (bottom) per Ku."""
    plt = pyplot()
    kus = sorted(records)
    fig, axes = plt.subplots(2, len(kus), figsize=(3.3 * len(kus), 6.4), squeeze=False,
                             layout="constrained")
    out = {}
    for i, kubo in enumerate(kus):
        sig, lam = records[kubo]
        for row, (other, (mean, edges)) in enumerate(lambda_maps(sig, lam).items()):
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
    recs = {}
    for k in KUS:
        d = ku_record(cfg, k)
        recs[k] = (d["signals"], d["Lambda"])
    return fig_ku_pattern(recs, cfg.out / "ku_pattern.png",
                          f"smart (shipped policies); "
                          f"{sizes_title(cfg.n_flows, cfg.n_swimmers, cfg.params)}")
