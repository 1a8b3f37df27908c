r"""Figures of the 3D study (``docs/beyond/three_d.md``), drawn from its records:

* **threeDKu**: ``R_hat`` against Ku for smart (every training seed a point, their mean a
  line), STO and naive (``Lambda = 0.98``), 2D (the protocol's comparisons,
  ``paper_protocol/ku*/comparison.json``) and 3D (``three_d/compare/ku*/comparison.json``)
  side by side, ± SEM over flows;
* **threeDPaths**: trajectories of smart and STO swimmers in the same 3D flows from the same
  starts (two ``swimrl-eval ... eval.record=n`` runs of one seed), projected on the x-y and
  x-z planes, each segment coloured by the shape factor ``Lambda`` held over it;
* **threeDMaps**: the smart policy's ``<Lambda>`` binned over pairs of its signals, from the
  decisions of a trajectory record: the pair of the two signals most correlated with
  ``Lambda`` (``|corr|``, recorded with all seven) and ``(S_np1, n_r)``, the pair STO reads;
* **threeDCurves**: the held-out ``R_hat`` of every 3D training run (``runs/ku*_seed*/
  curves.csv``, ± SEM) against frames, one panel per Ku, with 3D STO and naive of the
  comparison at that Ku (where it exists) as horizontal lines; a run not yet finished is
  drawn as far as its committed checkpoint and labelled so.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from swimrl.analysis.plots import pyplot
from swimrl.analysis.training_curves import draw_curve
from swimrl.flows.labels import ku_name, parse_ku_name
from swimrl.physics.body3d import SIGNAL_NAMES_3D
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.curves import read_curves

from .settings import FiguresConfig
from .style import COLORS, save

#: ``<Lambda>`` of a map bin with fewer decisions is not drawn.
MIN_DECISIONS = 20
#: Bins per axis of the maps (each axis spans the 1st to 99th percentile of its signal).
MAP_BINS = 24
LABEL_3D = {"n_r": r"$n_r$", "S_nn": r"$S_{nn}\tau_K$", "S_np1": r"$S_{np_1}\tau_K$",
            "S_np2": r"$S_{np_2}\tau_K$", "omega_n": r"$\omega_n\tau_K$",
            "omega_p1": r"$\omega_{p_1}\tau_K$", "omega_p2": r"$\omega_{p_2}\tau_K$"}


def read_comparisons(root: Path) -> dict[float, dict]:
    """``{Ku: comparison record}`` of ``root/ku*/comparison.json``."""
    out = {}
    for path in sorted(Path(root).glob("ku*/comparison.json")):
        ku = parse_ku_name(path.parent.name)
        if ku is not None:
            out[ku] = json.loads(path.read_text())
    return dict(sorted(out.items()))


def ku_summary(rec: dict) -> dict[str, dict]:
    """``R_hat`` (mean, SEM over flows) of STO, naive (``+0.98``) and every policy row (the
    training seeds) of a comparison, and the seeds' mean; ``smart / STO`` per seed."""
    rows = {r["label"]: r for r in rec["rows"]}
    sto = rows.get("sto")
    out: dict[str, dict] = {}
    if sto is not None:
        out["STO"] = {"R_hat": sto["R_hat_mean"], "sem": sto["R_hat_sem"]}
    naive = rows.get(StrategyLabel.naive(0.98).label)
    if naive is not None:
        out["naive"] = {"R_hat": naive["R_hat_mean"], "sem": naive["R_hat_sem"]}
    seeds = [r for r in rec["rows"] if StrategyLabel.parse(r["label"]).name == "policy"]
    if seeds:
        values = [r["R_hat_mean"] for r in seeds]
        out["smart"] = {"R_hat": float(np.mean(values)), "seeds": values,
                        "policies": [StrategyLabel.parse(r["label"]).arg for r in seeds],
                        "sem": float(np.sqrt(np.mean([r["R_hat_sem"] ** 2 for r in seeds])))}
        if sto is not None:
            out["smart"]["over_STO"] = [v / sto["R_hat_mean"] for v in values]
    return out


def build_three_d_ku(protocol: Path, three_d: Path, path: Path) -> dict:
    """Fig. threeDKu (module docstring) into ``path``; returns the summaries per dimension
    and Ku (``{"2D": {"ku10": ...}, "3D": ...}``), or ``{"pending": ...}`` without 3D
    records."""
    dims = {"2D": read_comparisons(protocol), "3D": read_comparisons(three_d)}
    if not dims["3D"]:
        return {"pending": f"no {Path(three_d) / 'ku*/comparison.json'}"}
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.8), sharey=True)
    out: dict[str, dict] = {}
    for ax, (dim, recs) in zip(axes, dims.items(), strict=True):
        summary = {ku: ku_summary(rec) for ku, rec in recs.items()}
        out[dim] = {ku_name(ku): s for ku, s in summary.items()}
        for name, marker in (("smart", "o"), ("STO", "s"), ("naive", "v")):
            kus = [ku for ku, s in summary.items() if name in s]
            if not kus:
                continue
            y = [summary[ku][name]["R_hat"] for ku in kus]
            err = [summary[ku][name]["sem"] for ku in kus]
            ax.errorbar(kus, y, yerr=err, marker=marker, color=COLORS[name], capsize=2,
                        label=name if name != "smart" else "smart (mean of seeds)")
            if name == "smart":
                for ku in kus:
                    seeds = summary[ku]["smart"]["seeds"]
                    ax.plot([ku] * len(seeds), seeds, ".", color=COLORS["smart"], alpha=0.5)
        ax.set_xscale("log")
        ax.set_xlabel("Ku")
        sizes = {(rec["n_flows"], rec["n_swimmers"]) for rec in recs.values()}
        shown = ", ".join(f"{f} x {s}" for f, s in sorted(sizes))
        ax.set_title(f"{dim}: flows x swimmers {shown}", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(r"$\hat R$ (± SEM over flows)")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    save(fig, path)
    return {"path": str(path), **out}


def _segments(xy: np.ndarray) -> np.ndarray:
    """Consecutive point pairs ``(N, 2, 2)`` of a path ``(N + 1, 2)``."""
    return np.stack((xy[:-1], xy[1:]), axis=1)


def build_three_d_paths(records: dict[str, Path], path: Path, n_paths: int = 3) -> dict:
    """Fig. threeDPaths (module docstring) into ``path`` from trajectory records
    ``{"smart": npz, "STO": npz}`` of the same flows and starts (checked); returns each
    drawn swimmer's ``R_hat`` per strategy."""
    from matplotlib.collections import LineCollection

    data = {name: dict(np.load(p)) for name, p in records.items()}
    starts = [d["position"][..., 0, :] for d in data.values()]
    if any(s.shape != starts[0].shape or not np.allclose(s, starts[0]) for s in starts):
        raise ValueError("threeDPaths: the trajectory records do not start from the same "
                         "positions (evaluate every strategy with the same seed and sizes)")
    plt = pyplot()
    fig, axes = plt.subplots(2, len(data), figsize=(4.2 * len(data), 7.0), squeeze=False,
                             layout="constrained")
    lam_max = float(next(iter(data.values()))["shape_factor_max"])
    norm = plt.Normalize(-lam_max, lam_max)
    out, line = {}, None
    for col, (name, d) in enumerate(data.items()):
        pos, lam = d["position"][0, 0], d["Lambda"][0, 0]      # first flow and strategy block
        k = min(n_paths, pos.shape[0])
        for row, (i, j) in enumerate(((0, 1), (0, 2))):
            ax = axes[row, col]
            for s in range(k):
                xy = pos[s][:, [i, j]] - pos[s][0, [i, j]]
                line = LineCollection(_segments(xy), cmap="coolwarm", norm=norm, lw=1.0)
                line.set_array(lam[s])
                ax.add_collection(line)
                ax.plot(*xy[0], "k.", ms=4)
            ax.autoscale()
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel(f"${'xyz'[i]} - {'xyz'[i]}_0$ ($\\ell_f$)")
            ax.set_ylabel(f"${'xyz'[j]} - {'xyz'[j]}_0$ ($\\ell_f$)")
        r_hat = d["R_hat"][0, 0, :k]
        out[name] = [float(x) for x in r_hat]
        axes[0, col].set_title(f"{name}: $\\hat R$ of the {k} swimmers drawn\n"
                               + ", ".join(f"{x:.2f}" for x in r_hat), fontsize=9)
    bar = fig.colorbar(line, ax=axes, shrink=0.6)
    bar.set_label(r"$\Lambda$", rotation=0, labelpad=10)   # upright: a turned Λ reads as V
    save(fig, path)
    return {"path": str(path), "R_hat": out}


def signal_correlations(signals: np.ndarray, lam: np.ndarray) -> dict[str, float]:
    """Pearson correlation of ``Lambda`` with each 3D signal over all decisions."""
    x, y = signals.reshape(-1, signals.shape[-1]), lam.reshape(-1)
    out = {}
    for k, name in enumerate(SIGNAL_NAMES_3D):
        s = x[:, k]
        sd = s.std() * y.std()
        out[name] = float(((s - s.mean()) * (y - y.mean())).mean() / sd) if sd > 0 else 0.0
    return out


def binned_mean(x: np.ndarray, y: np.ndarray, lam: np.ndarray, bins: int = MAP_BINS,
                min_count: int = MIN_DECISIONS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``<Lambda | x, y>`` on ``bins x bins`` cells spanning the 1st-99th percentiles (NaN
    below ``min_count`` decisions), and the edges of ``x`` and ``y``."""
    ex = np.linspace(*np.percentile(x, [1, 99]), bins + 1)
    ey = np.linspace(*np.percentile(y, [1, 99]), bins + 1)
    total, _, _ = np.histogram2d(x, y, [ex, ey], weights=lam)
    count, _, _ = np.histogram2d(x, y, [ex, ey])
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = total / count
    mean[count < min_count] = np.nan
    return mean, ex, ey


def build_three_d_maps(record: Path, path: Path) -> dict:
    """Fig. threeDMaps (module docstring) into ``path`` from a policy's trajectory record;
    returns the correlations and the pairs drawn."""
    d = np.load(record)
    names = [str(s) for s in d["signal_names"]]
    if names != list(SIGNAL_NAMES_3D):
        raise ValueError(f"{record}: signals {names} are not the 3D set")
    sig, lam = d["signals"], d["Lambda"]
    corr = signal_correlations(sig, lam)
    ranked = sorted(corr, key=lambda k: -abs(corr[k]))
    pairs = [(ranked[0], ranked[1]), ("S_np1", "n_r")]
    if set(pairs[0]) == set(pairs[1]):
        pairs = pairs[:1]
    x = sig.reshape(-1, sig.shape[-1])
    plt = pyplot()
    fig, axes = plt.subplots(1, len(pairs), figsize=(4.6 * len(pairs), 3.8), squeeze=False,
                             layout="constrained")
    lam_max = float(d["shape_factor_max"])
    im = None
    for ax, (a, b) in zip(axes[0], pairs, strict=True):
        mean, ex, ey = binned_mean(x[:, names.index(a)], x[:, names.index(b)], lam.reshape(-1))
        im = ax.pcolormesh(ex, ey, mean.T, cmap="coolwarm", vmin=-lam_max, vmax=lam_max)
        ax.set_xlabel(LABEL_3D[a])
        ax.set_ylabel(LABEL_3D[b])
        ax.set_title(f"corr(Λ, ·): {corr[a]:+.2f}, {corr[b]:+.2f}", fontsize=9)
    fig.colorbar(im, ax=axes, shrink=0.7, label=r"$\langle\Lambda\rangle$")
    fig.suptitle(f"{lam.size} decisions; bins with < {MIN_DECISIONS} left blank", fontsize=8)
    save(fig, path)
    return {"path": str(path), "correlations": corr, "pairs": pairs,
            "decisions": int(lam.size)}


def read_runs(root: Path) -> dict[float, dict[int, Path]]:
    """``{Ku: {seed: run dir}}`` of the run directories ``root/ku<KU>_seed<S>`` holding a
    ``curves.csv``."""
    out: dict[float, dict[int, Path]] = {}
    for path in sorted(Path(root).glob("ku*_seed*/curves.csv")):
        ku_part, _, seed = path.parent.name.rpartition("_seed")
        ku = parse_ku_name(ku_part)
        if ku is not None and seed.isdigit():
            out.setdefault(ku, {})[int(seed)] = path.parent
    return {ku: dict(sorted(runs.items())) for ku, runs in sorted(out.items())}


def build_three_d_curves(runs: Path, compare: Path, path: Path) -> dict:
    """Fig. threeDCurves (module docstring) into ``path``; returns per Ku and seed the frames
    and held-out ``R_hat`` drawn and whether the run is finished (its ``policy.pt`` there),
    or ``{"pending": ...}`` without runs."""
    found = read_runs(runs)
    if not found:
        return {"pending": f"no {Path(runs) / 'ku*_seed*/curves.csv'}"}
    comparisons = read_comparisons(compare)
    plt = pyplot()
    fig, axes = plt.subplots(1, len(found), figsize=(4.6 * len(found), 3.8), sharey=True,
                             squeeze=False)
    out: dict[str, dict] = {}
    for ax, (ku, seeds) in zip(axes[0], found.items(), strict=True):
        out[ku_name(ku)] = {}
        for seed, run in seeds.items():
            finished = (run / "policy.pt").is_file()
            curve = read_curves(run)
            x, y = draw_curve(ax, curve, "eval/R_hat", frames_per_unit=1e6, ms=2,
                              label=f"seed {seed}" + ("" if finished else
                                                      f" (at {curve['frames'][-1]:.2g} frames)"))
            out[ku_name(ku)][f"seed{seed}"] = {"frames": x.tolist(), "R_hat": y.tolist(),
                                               "finished": finished}
        summary = ku_summary(comparisons[ku]) if ku in comparisons else {}
        for name in ("STO", "naive"):
            if name in summary:
                ax.axhline(summary[name]["R_hat"], color=COLORS[name], ls="--", lw=1,
                           label=f"3D {name} (comparison)")
        ax.set_title(f"3D, Ku = {ku:g}", fontsize=9)
        ax.set_xlabel("training frames (millions of decisions)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel(r"held-out $\hat R$ (16 flows x 32 swimmers, ± SEM)")
    fig.tight_layout()
    save(fig, path)
    return {"path": str(path), **out}


# -- swimrl-figures (cfg.three_d: the study's records) -------------------------------------
#: The trajectory records of threeDPaths and threeDMaps, under ``<three_d>/paths/``.
PATH_RECORDS = {"smart": "ku10_policy", "STO": "ku10_sto"}


def _trajectories(cfg: FiguresConfig, name: str) -> Path:
    return Path(cfg.three_d) / "paths" / PATH_RECORDS[name] / "trajectories.npz"


def build_three_d_ku_figure(cfg: FiguresConfig) -> dict:
    """Fig. threeDKu from ``cfg.results`` (2D) and ``<three_d>/compare`` (3D)."""
    return build_three_d_ku(cfg.results, Path(cfg.three_d) / "compare",
                            Path(cfg.out) / "threeDKu.png")


def build_three_d_paths_figure(cfg: FiguresConfig) -> dict:
    """Fig. threeDPaths from ``<three_d>/paths/ku10_policy`` and ``ku10_sto``."""
    records = {name: _trajectories(cfg, name) for name in PATH_RECORDS}
    missing = [str(p) for p in records.values() if not p.is_file()]
    if missing:
        return {"pending": f"no {', '.join(missing)}"}
    return build_three_d_paths(records, Path(cfg.out) / "threeDPaths.png")


def build_three_d_maps_figure(cfg: FiguresConfig) -> dict:
    """Fig. threeDMaps from ``<three_d>/paths/ku10_policy``."""
    record = _trajectories(cfg, "smart")
    if not record.is_file():
        return {"pending": f"no {record}"}
    return build_three_d_maps(record, Path(cfg.out) / "threeDMaps.png")


def build_three_d_curves_figure(cfg: FiguresConfig) -> dict:
    """Fig. threeDCurves from ``<three_d>/runs`` and ``<three_d>/compare``."""
    return build_three_d_curves(Path(cfg.three_d) / "runs", Path(cfg.three_d) / "compare",
                                Path(cfg.out) / "threeDCurves.png")
