r"""The paper's figures from the shipped policies and the committed records (``swimrl-figures``).

Each figure has a ``fig_<name>(data..., path)`` function that draws it from arrays and returns
what it drew, and a builder (:data:`BUILDERS`) that gathers the arrays: evaluations through
the one rollout loop with a :class:`~swimrl.evaluation.trajectories.TrajectoryRecorder`,
cached under ``cache/`` as ``.npz`` files keyed by a hash of their inputs (the setup, the
policy file's bytes, :data:`CACHE_VERSION`), so a second build only draws.

Units: lengths in ``l_f``, times in ``tau_K``, signals in ``tau_K`` units. Colours: smart
orange, naive (``Lambda = 0.98``) black, STO green (the paper's). Sizes (flows x swimmers,
episode) are in each figure's title.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import textwrap
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from swimrl.env import EnvParams, SwimmerEnv
from swimrl.evaluation.records import read_curves, read_npz, write_npz
from swimrl.evaluation.rollout import EvalSetup, EvalSizes, chunk_seed, evaluate_shared
from swimrl.evaluation.trajectories import TrajectoryRecorder
from swimrl.flows.build import StochasticSpec
from swimrl.flows.stochastic import kubo_label
from swimrl.policies.baselines import StrategySpec
from swimrl.policies.files import load_policy, resolve_policy_file
from swimrl.runtime import Runtime

from .performance import load, summarise
from .policy_maps import binned_mean, snn_extremes
from .signal_ablation import (
    AblationRun,
    ablation_markdown,
    draw_curves,
    draw_ratios,
    read_ablation,
    summarise_sets,
)
from .training_curves import PAPER_EPISODE_FRAMES

#: Bump when a cached array's meaning changes.
CACHE_VERSION = 1
KUS = (0.1, 1.0, 10.0, 1e7)
#: Decisions between video frames (4 tau_K at T_u = 0.1 tau_K: 51 frames over T = 200 tau_K).
FRAME_EVERY = 40
STRATEGIES = ("smart", "naive", "STO")
COLORS = {"smart": "tab:orange", "naive": "k", "STO": "tab:green"}
SIGNAL = {"n_r": 0, "n_theta": 1, "S_nn": 2, "S_np": 3, "omega": 4}
LABEL = {"n_r": r"$n_r$", "n_theta": r"$n_\theta$", "S_nn": r"$S_{nn}\tau_K$",
         "S_np": r"$S_{np}\tau_K$", "omega": r"$\omega\tau_K$"}


def ku_name(kubo: float) -> str:
    """``ku0.1``, ``ku1``, ``ku10``, ``ku1e7``: the shipped policies' names."""
    return "ku" + kubo_label(kubo)


@dataclass(frozen=True)
class DNSFiguresConfig:
    """Where the DNS figure's records are (``dns.*`` of ``conf/figures.yaml``)."""

    store: Path
    """A held-out stored run to replay when ``record`` does not exist yet."""
    record: Path
    """The committed replay record (``.npz``)."""
    transfer: Path
    """Directory searched for ``comparison.json`` (one per held-out realisation)."""
    checks: Path
    """``dns_checks.json`` of ``swimrl-dns-plots`` (pooled PDFs)."""
    policy: str = "pretrained/ku10"
    """The smart policy of (a) and the videos (the paper's video 5: trained at Ku = 10)."""
    trained: str = "pretrained/dns"
    """The policy trained in the DNS: the dotted line of (c) and the maps of (d), (e)."""
    curve: Path | None = None
    """``curves.csv`` of its training run: (f), its evaluation R_hat against frames."""
    n_swimmers: int = 300
    n_traj: int = 4
    decode_n: int | None = 384
    glyph_window: float = 20.0
    glyph_every: float = 2.0


@dataclass(frozen=True)
class FiguresConfig:
    """``swimrl-figures``: where, which, and how large (defaults in ``conf/figures.yaml``)."""

    out: Path
    """Directory of the PNGs (``docs/figures``)."""
    cache: Path
    """Directory of the cached evaluation records."""
    runtime: Runtime
    params: EnvParams
    """Swimmer and episode of every evaluation (the robustness sweeps change one field)."""
    flow: StochasticSpec
    """Flow of every evaluation; ``kubo`` is set per figure."""
    only: str | None = None
    """One figure (a key of :data:`BUILDERS`), or None: all."""
    n_flows: int = 1
    """Flows of each Ku record (final positions, trajectories, policy maps)."""
    n_swimmers: int = 1000
    """Swimmers per flow and strategy of each Ku record."""
    n_traj: int = 8
    """Trajectories drawn per strategy."""
    robust_flows: int = 2
    """Flows per point of the robustness sweeps."""
    robust_swimmers: int = 100
    """Swimmers per flow and strategy per point of the robustness sweeps."""
    seed: int = 0
    policies: str = "pretrained"
    """Smart policy at Ku: ``<policies>/ku0.1`` ... ``<policies>/ku1e7`` (a policy spec)."""
    results: Path = Path("docs/results/paper_protocol")
    """``comparison.json`` records of smartPerformance(a)."""
    curves: Path = Path("docs/results/paper_runs")
    """Searched for ``curves.csv`` (trainingCurves)."""
    fits: Path = Path("docs/results/minimal_fits")
    """``ku*/fit.json`` of ``swimrl-fit-minimal`` at each Ku (ablation (b), (c))."""
    ablation: Path = Path("docs/results/ablation")
    """Run directories of the signal-ablation multirun (ablation (a))."""
    dns: DNSFiguresConfig | None = None
    """Records of Fig. dnsFlow and videos 5, 10 (None: not drawn)."""
    progress: bool = True


# -- cache and evaluations -------------------------------------------------------------------
def _digest(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def cached(cfg: FiguresConfig, name: str, inputs: dict,
           compute: Callable[[], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """``compute()`` once per distinct ``inputs``: stored as ``cache/<name>-<hash>.npz``."""
    text = json.dumps({"v": CACHE_VERSION, **inputs}, sort_keys=True, default=str)
    path = Path(cfg.cache) / f"{name}-{hashlib.sha256(text.encode()).hexdigest()[:12]}.npz"
    if path.exists():
        return read_npz(path)
    data = compute()
    write_npz(data, path)
    return data


def _setup(cfg: FiguresConfig, kubo: float, n_flows: int, n_swimmers: int,
           **params) -> EvalSetup:
    sizes = EvalSizes(n_flows, n_swimmers, n_flows, cfg.progress, n_swimmers)
    return EvalSetup(flow=replace(cfg.flow, kubo=float(kubo)),
                     params=replace(cfg.params, **params) if params else cfg.params,
                     runtime=cfg.runtime, sizes=sizes, seed=cfg.seed, record={})


def _policy(cfg: FiguresConfig, kubo: float) -> str:
    return f"{cfg.policies}/{ku_name(kubo)}"


def _inputs(cfg: FiguresConfig, setup: EvalSetup, actors: list[str]) -> dict:
    files = {a: _digest(resolve_policy_file(a)) for a in actors if "/" in a}
    return {"flow": asdict(setup.flow), "params": asdict(setup.params),
            "sizes": [setup.sizes.n_flows, setup.sizes.n_swimmers], "seed": setup.seed,
            "dtype": str(cfg.runtime.dtype), "actors": actors, "files": files}


def _actor(name: str, params: EnvParams):
    if name == "naive":
        return StrategySpec("naive", shape_factor=0.98)
    if name == "sto":
        return StrategySpec("sto")
    if name.startswith("naive("):
        return StrategySpec("naive", shape_factor=float(name[6:-1]))
    if name.startswith("minimal("):
        return StrategySpec("minimal", coeffs=tuple(float(c) for c in name[8:-1].split(",")))
    return load_policy(name, params)


def record_strategies(setup: EvalSetup, actors: list[str], desc: str,
                      field_every: int = 0) -> dict[str, np.ndarray]:
    """Every decision of every swimmer of ``actors`` (policy specs, ``naive``, ``sto``,
    ``naive(L)``) sharing the flows of ``setup``: the recorder's arrays."""
    rec = TrajectoryRecorder(setup.sizes.n_swimmers, field_every)
    evaluate_shared(setup, [_actor(a, setup.params) for a in actors], desc=desc, recorder=rec)
    return rec.arrays()


def ku_record(cfg: FiguresConfig, kubo: float) -> dict[str, np.ndarray]:
    """Smart (shipped policy), naive and STO at ``kubo`` on shared flows (cached):
    ``final`` ``(3, F S, 2)`` displacements, ``R_hat`` ``(3, F S)``, ``traj`` ``(3, n_traj,
    N+1, 2)`` displacements, smart's ``signals`` ``(F S, N, 5)`` and ``Lambda``, STO's for
    the first ``n_traj`` swimmers of each flow (``sto_signals``, ``sto_Lambda``); for the
    videos, ``cloud`` ``(3, F S, frames, 2)`` displacements and ``traj_abs`` ``(3, n_traj,
    frames, 2)`` unwrapped positions in flow 0 every :data:`FRAME_EVERY` decisions, with that
    flow's ``vorticity`` ``(frames, n/4, n/4)`` and ``box``."""
    setup = _setup(cfg, kubo, cfg.n_flows, cfg.n_swimmers)
    actors = [_policy(cfg, kubo), "naive", "sto"]

    def compute() -> dict[str, np.ndarray]:
        a = record_strategies(setup, actors, f"Ku={kubo:g}", FRAME_EVERY)
        disp = a["position"] - a["position"][..., :1, :]  # (F, K, S, N+1, 2)
        per = np.swapaxes(disp, 0, 1)  # (K, F, S, N+1, 2)
        k, f, s = per.shape[:3]
        nt = min(cfg.n_traj, s)
        return {"final": per[..., -1, :].reshape(k, f * s, 2),
                "R_hat": np.swapaxes(a["R_hat"], 0, 1).reshape(k, f * s),
                "traj": per[:, 0, :nt], "time": a["time"],
                "signals": a["signals"][:, 0].reshape(f * s, *a["signals"].shape[3:]),
                "Lambda": a["Lambda"][:, 0].reshape(f * s, -1),
                "sto_signals": a["signals"][:, 2, :nt].reshape(-1, *a["signals"].shape[3:]),
                "sto_Lambda": a["Lambda"][:, 2, :nt].reshape(f * nt, -1),
                "cloud": per[..., ::FRAME_EVERY, :].reshape(k, f * s, -1, 2),
                "traj_abs": np.swapaxes(a["position"], 0, 1)[:, 0, :nt, ::FRAME_EVERY],
                "vorticity": a["vorticity"], "box": a["box"]}

    inputs = {**_inputs(cfg, setup, actors), "frames": FRAME_EVERY}
    return cached(cfg, f"ku_{ku_name(kubo)}", inputs, compute)


def flow_vorticity(setup: EvalSetup) -> np.ndarray:
    """``omega tau_K`` on the grid, ``(n, n)`` (``[y, x]``), of flow 0 of ``setup`` at
    ``t = 0``: the realisation its evaluation starts in (same seed, same draws)."""
    n_c = min(setup.sizes.flows_per_batch, setup.sizes.n_flows)
    env = SwimmerEnv.build(setup.flow, setup.params, setup.runtime, n_c, 1,
                           chunk_seed(setup.seed, 0))
    env.reset()
    return (env.flow.grid_fields()[0, ..., 4] * env.tau_k).cpu().double().numpy()


def _titles(cfg: FiguresConfig, flows: int, swimmers: int, params: EnvParams) -> str:
    return f"{flows} flow(s) x {swimmers} swimmers, T = {params.duration:g} $\\tau_K$"


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> None:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    _plt().close(fig)


# -- Fig. 1(a): swimmer ----------------------------------------------------------------------
def fig_swimmer(vorticity: np.ndarray, box: float, traj: dict[str, np.ndarray], path: Path,
                title: str = "") -> dict:
    """Trajectories ``{label: (N+1, 2)}`` (absolute, unwrapped) over the periodic vorticity
    field (tiled as far as they go); returns the extent drawn and the path lengths."""
    plt = _plt()
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
    _save(fig, path)
    return {"extent": extent,
            "path_length": {k: float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum())
                            for k, x in traj.items()}}


def build_swimmer(cfg: FiguresConfig) -> dict:
    """Lambda = +0.98 and -0.98 from one point in a frozen flow (Ku = 1e7), 20 tau_K."""
    setup = replace(_setup(cfg, 1e7, 1, 1, duration=20.0), sizes=EvalSizes(1, 1, 1, False, 1))
    actors = ["naive(0.98)", "naive(-0.98)"]

    def compute() -> dict[str, np.ndarray]:
        # one evaluation each on the same seed: same flow, same initial point (CRN)
        pos = [record_strategies(setup, [a], a)["position"][0, 0, 0] for a in actors]
        return {"position": np.stack(pos), "vorticity": flow_vorticity(setup),
                "box": np.asarray(setup.flow.n_grid * setup.flow.spacing)}

    d = cached(cfg, "swimmer", _inputs(cfg, setup, actors), compute)
    traj = {r"$\Lambda=+0.98$ (prolate)": d["position"][0],
            r"$\Lambda=-0.98$ (oblate)": d["position"][1]}
    return fig_swimmer(d["vorticity"], float(d["box"]), traj, cfg.out / "swimmer.png",
                       "frozen flow (Ku = $10^7$), T = 20 $\\tau_K$, same start and flow")


# -- Fig. smartPerformance -------------------------------------------------------------------
def fig_smart_performance(summaries: list[dict], finals: dict[float, np.ndarray], path: Path,
                          title: str = "") -> dict:
    """(a) R_hat vs Ku from ``swimrl-compare`` summaries (error bars: std over flows);
    (b-e) final displacements ``finals[Ku]`` ``(3, S, 2)`` (smart, naive, STO)."""
    plt = _plt()
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
        for j, name in enumerate(STRATEGIES):
            a.scatter(final[j, :, 0], final[j, :, 1], s=2, color=COLORS[name], alpha=0.5,
                      label=name, rasterized=True)
        a.plot(0, 0, "r*", ms=10)
        a.set_aspect("equal")
        a.set_title(f"({'bcde'[i] if i < 4 else '?'}) Ku = {kubo:g}", fontsize=9)
        a.set_xlabel(r"$\Delta x/\ell_f$")
        if i == 0:
            a.set_ylabel(r"$\Delta y/\ell_f$")
            a.legend(fontsize=7, markerscale=4, loc="lower right")
        out["spread"][kubo] = np.linalg.norm(final, axis=-1).mean(axis=1).tolist()
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    _save(fig, path)
    return out


def build_smart_performance(cfg: FiguresConfig) -> dict:
    summaries = [summarise(r) for r in load([cfg.results])]
    finals = {k: ku_record(cfg, k)["final"] for k in KUS}
    return fig_smart_performance(
        summaries, finals, cfg.out / "smartPerformance.png",
        f"(b-e): final positions, {_titles(cfg, cfg.n_flows, cfg.n_swimmers, cfg.params)} "
        "per strategy, shipped policies")


# -- Fig. ku0.1 ------------------------------------------------------------------------------
def fig_ku01(traj: np.ndarray, smart_sig: np.ndarray, smart_lam: np.ndarray,
             sto_sig: np.ndarray, sto_lam: np.ndarray, path: Path, title: str = "") -> dict:
    """(a) trajectories ``traj`` ``(3, n, N+1, 2)`` from the origin; (b) Lambda against
    ``n_theta S_np`` for smart and STO; inset: smart's ``<Lambda | n_theta, S_np>``."""
    plt = _plt()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.6))
    for j, name in enumerate(STRATEGIES):
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
                                 ranges=[(-1, 1), _sym(smart_sig[..., 3])], min_count=5)
    im = ins.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
    ins.set_xlabel(r"$n_\theta$", fontsize=7, labelpad=0)
    ins.set_ylabel(r"$S_{np}\tau_K$", fontsize=7, labelpad=0)
    ins.tick_params(labelsize=6)
    fig.colorbar(im, ax=b, shrink=0.8, label=r"$\langle\Lambda\rangle$ (inset, smart)")
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    _save(fig, path)
    out["inset"] = mean
    return out


def _sym(x: np.ndarray, q: float = 0.995) -> tuple[float, float]:
    """Symmetric range covering the central ``q`` of ``|x|``."""
    m = float(np.quantile(np.abs(x), q)) or 1.0
    return (-m, m)


def build_ku01(cfg: FiguresConfig) -> dict:
    d = ku_record(cfg, 0.1)
    return fig_ku01(d["traj"], d["signals"], d["Lambda"], d["sto_signals"], d["sto_Lambda"],
                    cfg.out / "ku0.1.png",
                    f"Ku = 0.1, shipped policy ku0.1; "
                    f"{_titles(cfg, cfg.n_flows, cfg.n_swimmers, cfg.params)}")


# -- Fig. kuInf and the S_nn statistic -------------------------------------------------------
def fig_ku_inf(sig: np.ndarray, lam: np.ndarray, path: Path, title: str = "") -> dict:
    """(a) Lambda over (n_r, S_np, omega) (a subsample); (b, c) ``<Lambda | S_np, omega>``
    for ``n_r >= 0.8`` and ``n_r <= -0.8``; the S_nn statistic in the title."""
    plt = _plt()
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
    ranges = [_sym(s[:, 3]), _sym(s[:, 4])]
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
    _save(fig, path)
    return out


def build_ku_inf(cfg: FiguresConfig) -> dict:
    d = ku_record(cfg, 1e7)
    return fig_ku_inf(d["signals"], d["Lambda"], cfg.out / "kuInf.png",
                      f"smart, Ku = $10^7$, shipped policy ku1e7; "
                      f"{_titles(cfg, cfg.n_flows, cfg.n_swimmers, cfg.params)}")


# -- Fig. ku_pattern -------------------------------------------------------------------------
def fig_ku_pattern(records: dict[float, tuple[np.ndarray, np.ndarray]], path: Path,
                   title: str = "") -> dict:
    """``<Lambda | S_np, n_theta>`` (top) and ``<Lambda | S_np, omega>`` (bottom) per Ku."""
    plt = _plt()
    kus = sorted(records)
    fig, axes = plt.subplots(2, len(kus), figsize=(3.3 * len(kus), 6.4), squeeze=False,
                             layout="constrained")
    out = {}
    for i, kubo in enumerate(kus):
        sig, lam = records[kubo]
        s = sig.reshape(-1, 5)
        for row, (other, rng) in enumerate((("n_theta", (-1, 1)), ("omega", _sym(s[:, 4])))):
            a = axes[row, i]
            mean, edges, _ = binned_mean(lam, [s[:, 3], s[:, SIGNAL[other]]], bins=30,
                                         ranges=[_sym(s[:, 3]), rng], min_count=5)
            im = a.pcolormesh(edges[0], edges[1], mean.T, cmap="coolwarm", vmin=-1, vmax=1)
            a.set_xlabel(LABEL["S_np"])
            a.set_ylabel(LABEL[other])
            a.set_title(f"({'abcdefgh'[row * 4 + i] if len(kus) == 4 else ''}) "
                        f"Ku = {kubo:g}", fontsize=9)
            out[(kubo, other)] = mean
    fig.colorbar(im, ax=axes, shrink=0.6, label=r"$\langle\Lambda\rangle$")
    fig.suptitle(title, fontsize=8)
    _save(fig, path)
    return out


def build_ku_pattern(cfg: FiguresConfig) -> dict:
    recs = {}
    for k in KUS:
        d = ku_record(cfg, k)
        recs[k] = (d["signals"], d["Lambda"])
    return fig_ku_pattern(recs, cfg.out / "ku_pattern.png",
                          f"smart (shipped policies); "
                          f"{_titles(cfg, cfg.n_flows, cfg.n_swimmers, cfg.params)}")


def _shown(path: Path) -> str:
    """``path`` relative to the working directory where it lies below it."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


# -- Fig. trainingCurves ---------------------------------------------------------------------
def find_curves(root: Path) -> dict[str, Path]:
    """``curves.csv`` files under ``root``, labelled by their run directory; linked run
    directories are followed (``docs/results/paper_runs/ku*_seed*`` are links)."""
    found = (Path(d) / "curves.csv" for d, _, files in os.walk(root, followlinks=True)
             if "curves.csv" in files)
    return {p.parent.name: p for p in sorted(found)}


def _ku_value(group: str) -> float:
    """``"ku1e7"`` -> 1e7 (``inf`` where the group is not ``ku<number>``)."""
    try:
        return float(group.removeprefix("ku"))
    except ValueError:
        return math.inf


def fig_training_curves(curves: dict[str, dict[str, np.ndarray]], path: Path,
                        title: str = "") -> dict:
    """Held-out ``eval/R_hat`` (+- SEM band where recorded) against training episodes in the
    paper's unit (10 swimmers x 2000 decisions = 2e4 frames), one panel per Ku (label prefix
    ``ku*_``), panels in increasing Ku; returns each run's last held-out value."""
    plt = _plt()
    groups: dict[str, list[str]] = {}
    for label in curves:
        groups.setdefault(label.split("_")[0], []).append(label)
    order = sorted(groups, key=lambda g: (_ku_value(g), g))
    fig, axes = plt.subplots(1, max(1, len(order)), figsize=(3.6 * max(1, len(order)), 3.4),
                             squeeze=False)
    out = {}
    for a, ku in zip(axes[0], order, strict=False):
        for label in sorted(groups[ku]):
            c = curves[label]
            ok = np.isfinite(c["eval/R_hat"])
            x, y = c["frames"][ok] / PAPER_EPISODE_FRAMES, c["eval/R_hat"][ok]
            (line,) = a.plot(x, y, marker="o", ms=2, label=label.removeprefix(ku + "_"))
            if "eval/R_hat_sem" in c:
                e = c["eval/R_hat_sem"][ok]
                a.fill_between(x, y - e, y + e, color=line.get_color(), alpha=0.2, lw=0)
            out[label] = float(y[-1])
        a.set_xlabel("training episodes (of $2\\times10^4$ frames)")
        a.set_ylabel(r"held-out $\hat R$")
        kv = _ku_value(ku)
        a.set_title(f"Ku = {kv:g}" if math.isfinite(kv) else ku, fontsize=9)
        a.legend(fontsize=7)
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    _save(fig, path)
    return out


def build_training_curves(cfg: FiguresConfig) -> dict:
    files = find_curves(cfg.curves)
    if not files:
        return {"pending": f"no curves.csv under {cfg.curves}"}
    return fig_training_curves({k: read_curves(p) for k, p in files.items()},
                               cfg.out / "trainingCurves.png",
                               f"curves.csv under {_shown(cfg.curves)}; held-out: "
                               "the same flows at every point, band: SEM over flows")


# -- robustness ------------------------------------------------------------------------------
def _draw_sweep(ax, x: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray],
                xlabel: str, reference: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """R_hat of the strategies against a swept parameter on ``ax`` (log x, ticks at ``x``)."""
    for name in STRATEGIES:
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
    plt = _plt()
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
    _save(fig, path)
    return out


def sweep_record(cfg: FiguresConfig, name: str, values: list[float], key: str,
                 kubo: float = 10.0) -> dict[str, np.ndarray]:
    """Per-flow R_hat ``(len(values), 3, F)`` of smart (trained at the paper's values), naive
    and STO with ``EnvParams.<key>`` set to each value (cached)."""
    out = []
    for v in values:
        setup = _setup(cfg, kubo, cfg.robust_flows, cfg.robust_swimmers, **{key: v})
        actors = [_policy(cfg, kubo), "naive", "sto"]
        out.append(per_flow_record(cfg, f"{name}_{key}{v:g}", setup, actors))
    return {"per_flow": np.stack(out)}


def per_flow_record(cfg: FiguresConfig, name: str, setup: EvalSetup,
                    actors: list[str]) -> np.ndarray:
    """Per-flow R_hat ``(len(actors), F)`` of ``actors`` on the shared flows of ``setup``
    (cached under ``name``)."""
    def compute() -> dict[str, np.ndarray]:
        plain = replace(setup, sizes=replace(setup.sizes, record=0))
        metrics = evaluate_shared(plain, [_actor(a, plain.params) for a in actors],
                                  desc="robustness")
        return {"per_flow": np.asarray([m["per_flow"] for m in metrics])}

    return cached(cfg, name, _inputs(cfg, setup, actors), compute)["per_flow"]


def _stats(per: np.ndarray, names: tuple[str, ...] = STRATEGIES) -> tuple[dict, dict]:
    """Mean and std over flows (last axis) of ``per`` ``(..., len(names), F)``, by name."""
    mean = {n: per[:, j].mean(-1) for j, n in enumerate(names)}
    std = {n: per[:, j].std(-1, ddof=1) if per.shape[-1] > 1 else 0 * per[:, j, 0]
           for j, n in enumerate(names)}
    return mean, std


def build_robustness_noise(cfg: FiguresConfig) -> dict:
    d_r = [1e-4, 1e-3, 1e-2, 1e-1]
    per = sweep_record(cfg, "noise", d_r, "rot_diffusion")["per_flow"]
    mean, std = _stats(per)
    return fig_sweep(np.asarray(d_r), mean, std, r"$D_r\tau_K$",
                     cfg.out / "robustness-noise.png",
                     f"Ku = 10, smart trained at $D_r = 0$; "
                     f"{_titles(cfg, cfg.robust_flows, cfg.robust_swimmers, cfg.params)}; "
                     "bars: std over flows", ratio=True)


def build_robustness(cfg: FiguresConfig) -> dict:
    """(a) R_hat vs T (with naive's T^(-1/2) through T = 200), (b) vs T_u, (c) vs v_s."""
    sweeps = (("duration", [50.0, 100.0, 200.0, 400.0], r"$T/\tau_K$"),
              ("update_interval", [0.05, 0.1, 0.2, 0.5], r"$T_u/\tau_K$"),
              ("swim_speed", [0.354, 0.707, 1.414], r"$v_s/u_{\rm rms}$"))
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    out = {}
    for ax, (key, values, label), tag in zip(axes, sweeps, "abc", strict=True):
        per = sweep_record(cfg, "robust", values, key)["per_flow"]
        mean, std = _stats(per)
        x = np.asarray(values)
        ref = (x, mean["naive"][2] * np.sqrt(200.0 / x)) if key == "duration" else None
        _draw_sweep(ax, x, mean, std, label, ref)
        ax.set_title(f"({tag})", fontsize=9)
        out[key] = {"x": values, **{k: v.tolist() for k, v in mean.items()}}
    fig.suptitle(f"Ku = 10, smart trained at T = 200, $T_u$ = 0.1 $\\tau_K$, $v_s$ = 0.707 "
                 f"$u_{{\\rm rms}}$; {cfg.robust_flows} flows x {cfg.robust_swimmers} swimmers "
                 "per point; bars: std over flows", fontsize=8)
    fig.tight_layout()
    _save(fig, cfg.out / "robustness.png")
    return out


def build_videos(cfg: FiguresConfig) -> dict:
    """Supplemental videos 1-4 (trajectories) and 6-9 (clouds) into ``<out>/../videos``, and
    5 and 10 in the DNS from its replay record."""
    from .dns_figures import dns_record
    from .videos import video_cloud, video_trajectories

    out, where = {}, Path(cfg.out).parent / "videos"
    for i, kubo in enumerate(KUS):
        rec = ku_record(cfg, kubo)
        out[i + 1] = video_trajectories(rec, kubo, where / f"video{i + 1}_{ku_name(kubo)}.mp4")
        out[i + 6] = video_cloud(rec, kubo, where / f"video{i + 6}_{ku_name(kubo)}_cloud.mp4")
    rec, why = (None, "no dns.* records configured") if cfg.dns is None else dns_record(cfg,
                                                                                      cfg.dns)
    if rec is None:
        out["pending"] = f"videos 5, 10: {why}"
    else:
        out[5] = video_trajectories(rec, "DNS", where / "video5_dns.mp4", unit="L")
        out[10] = video_cloud(rec, "DNS", where / "video10_dns_cloud.mp4", unit="L")
    return out


def build_dns_flow(cfg: FiguresConfig) -> dict:
    """Fig. dnsFlow (:mod:`swimrl.analysis.dns_figures`)."""
    from .dns_figures import build_dns_flow as build

    if cfg.dns is None:
        return {"pending": "no dns.* records configured"}
    return build(cfg, cfg.dns)


# -- Fig. ablation (b), (c): the minimal model across Ku ----------------------------------------
def read_fits(root: Path) -> dict[float, dict]:
    """``fit.json`` of ``swimrl-fit-minimal`` under ``root/ku*/``, keyed by Ku."""
    fits = {}
    for path in sorted(Path(root).glob("ku*/fit.json")):
        rec = json.loads(path.read_text())
        fits[float(rec["config"]["flow"]["kubo"])] = rec
    return dict(sorted(fits.items()))


def minimal_name(fit: dict) -> str:
    """Actor name of the minimal model with a fit's coefficients."""
    c = fit["coefficients"]
    return "minimal(" + ",".join(f"{c[k]:.6g}" for k in ("c1", "c2", "c3", "c4")) + ")"


def _draw_minimal(b, c, kus: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray],
                  coeffs: dict[str, np.ndarray], coeff_err: dict[str, np.ndarray]) -> None:
    """(b) R_hat of smart, the minimal model and STO against Ku; (c) c1..c4 against Ku."""
    colors = {**COLORS, "minimal": "tab:purple"}
    for name, y in r.items():
        b.errorbar(kus, y, yerr=err[name], color=colors[name], marker="o", capsize=3, label=name,
                   ls="--" if name == "minimal" else "-")
    b.set_xscale("log")
    b.set_xlabel("Ku")
    b.set_ylabel(r"$\hat R$")
    b.set_title("(b) smart and the minimal model", fontsize=9)
    b.legend(fontsize=7)
    shades = dict(zip(("c1", "c2", "c3", "c4"),
                      ("tab:blue", "tab:red", "tab:brown", "tab:pink"), strict=True))
    for k, y in coeffs.items():
        c.errorbar(kus, y, yerr=coeff_err[k], marker="o", capsize=3, label=f"$c_{k[1]}$",
                   color=shades[k])
    c.axhline(0, color="0.6", lw=0.8)
    c.set_xscale("log")
    c.set_xlabel("Ku")
    c.set_ylabel("fitted coefficient")
    c.set_title("(c) minimal-model coefficients", fontsize=9)
    c.legend(fontsize=7)


def fig_ablation(kus: np.ndarray, r: dict[str, np.ndarray], err: dict[str, np.ndarray],
                 coeffs: dict[str, np.ndarray], coeff_err: dict[str, np.ndarray], path: Path,
                 title: str = "", runs: list[AblationRun] | None = None) -> dict:
    """(a) smart / STO per signal set (the training multirun's ``runs``, at one Ku; "no
    records" where there are none) and (a') their held-out curves; (b) R_hat of smart, the minimal
    model (fitted at each Ku) and STO against Ku; (c) the fitted c1..c4 against Ku."""
    plt = _plt()
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.6))
    (a, a2), (b, c) = axes
    out: dict = {}
    if runs:
        summary = summarise_sets(runs)
        draw_ratios(a, summary)
        out["ablation"] = {s["label"]: {"seeds": s["seeds"], "ratios": s["ratios"].tolist(),
                                        "mean": s["mean"], "std": s["std"]} for s in summary}
        out["curves_last"] = draw_curves(a2, runs, summary)
        out["table"] = ablation_markdown(runs, summary)
        kubo, frames = runs[0].kubo, runs[0].frames
        a.set_title(f"(a) signal ablation, Ku = {kubo:g}, {frames / 1e6:g}M frames per run",
                    fontsize=9)
        a2.set_title("(a') the runs' held-out curves (mean, band: std over seeds)", fontsize=9)
    else:
        for ax in (a, a2):
            ax.text(0.5, 0.5, "signal ablation: no records", ha="center", va="center",
                    transform=ax.transAxes)
            ax.set_axis_off()
    _draw_minimal(b, c, kus, r, err, coeffs, coeff_err)
    fig.suptitle("\n".join(textwrap.fill(line, 150) for line in title.splitlines()), fontsize=8)
    fig.tight_layout()
    _save(fig, path)
    return {"kubo": kus.tolist(), **{k: np.asarray(v).tolist() for k, v in r.items()},
            **{k: np.asarray(v).tolist() for k, v in coeffs.items()}, **out}


def build_ablation(cfg: FiguresConfig) -> dict:
    """Fig. ablation: (a) from the signal-ablation multirun's records, (b), (c) from the
    committed fits."""
    fits = read_fits(cfg.fits)
    if not fits:
        return {"pending": f"no ku*/fit.json under {cfg.fits}"}
    runs = read_ablation(cfg.ablation) if Path(cfg.ablation).is_dir() else []
    kus = np.array(list(fits))
    names = ("smart", "minimal", "STO")
    per = []
    for kubo, fit in fits.items():
        setup = _setup(cfg, kubo, cfg.robust_flows, cfg.robust_swimmers)
        actors = [_policy(cfg, kubo), minimal_name(fit), "sto"]
        per.append(per_flow_record(cfg, f"minimal_ku{kubo:g}", setup, actors))
    r, err = _stats(np.stack(per), names)  # per: (Ku, 3, F)
    keys = ("c1", "c2", "c3", "c4")
    coeffs = {k: np.array([f["coefficients"][k] for f in fits.values()]) for k in keys}
    coeff_err = {k: np.array([f.get("flow_sem", f["stderr"])[k] for f in fits.values()])
                 for k in keys}
    n_fit = {f["config"]["eval"]["n_flows"] for f in fits.values()}
    if runs:
        counts = sorted(set(Counter(r.signals for r in runs).values()))
        per_set = "-".join(map(str, sorted({counts[0], counts[-1]})))
        flows, swimmers = runs[0].held_out
        head = (f"(a) {len(runs)} runs under {_shown(cfg.ablation)}, {per_set} seed(s) per set; "
                f"smart/STO paired on each run's {flows} held-out flows x {swimmers} swimmers, "
                "bars: std over seeds (one seed: its SEM, open marker)")
    else:
        head = f"(a) pending: no records under {_shown(cfg.ablation)}"
    drawn = fig_ablation(
        kus, r, err, coeffs, coeff_err, cfg.out / "ablation.png",
        f"{head}\n(b) shipped smart policies; the minimal model with the coefficients fitted to "
        f"them at each Ku; STO; {cfg.robust_flows} flows x {cfg.robust_swimmers} swimmers, "
        f"bars: std over flows; (c) fits on {'/'.join(map(str, sorted(n_fit)))} flows x 100 "
        "swimmers, bars: SEM over flows", runs=runs)
    if "table" in drawn:
        (cfg.out / "ablation_signals.md").write_text(drawn["table"])
    return drawn


#: Figure name -> builder, in build order.
BUILDERS: dict[str, Callable[[FiguresConfig], dict]] = {
    "swimmer": build_swimmer,
    "smartPerformance": build_smart_performance,
    "ku0.1": build_ku01,
    "kuInf": build_ku_inf,
    "ku_pattern": build_ku_pattern,
    "trainingCurves": build_training_curves,
    "ablation": build_ablation,
    "robustness-noise": build_robustness_noise,
    "robustness": build_robustness,
    "dnsFlow": build_dns_flow,
    "videos": build_videos,
}


def build_figures(cfg: FiguresConfig, log: Callable[[str], None] = print) -> dict[str, dict]:
    """Every figure (or ``cfg.only``); returns each builder's data and wall time."""
    names = [cfg.only] if cfg.only else list(BUILDERS)
    out = {}
    for name in names:
        t0 = time.perf_counter()
        out[name] = BUILDERS[name](cfg)
        wall = time.perf_counter() - t0
        out[name]["wall_s"] = wall
        log(f"{name}: {wall:.0f} s" + (f" ({out[name]['pending']})" if "pending" in out[name]
                                       else ""))
    return out
