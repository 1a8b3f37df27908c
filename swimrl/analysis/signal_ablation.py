r"""Fig. ablation (a): smart / STO at Ku = 10 for the paper's signal sets.

The records are the run directories of one multirun (docs/results.md, "Signal ablation"):

    swimrl-train -m seed=0,1,2 signals=all,nr_nth_snp_w,nr_nth_snp,nth_snp,nr_nth_snn_w \
        flow.kubo=10 train.compare_baselines=true ...

Each run holds ``metrics.json`` (its config: signals, training seed, budget),
``comparison.json`` (STO, naive and the policy on the same held-out flows and initial
conditions) and ``curves.csv``. A run's value is the paired ratio
``R_smart / R_STO = sum_f R_smart,f / sum_f R_STO,f`` over the held-out flows ``f`` (the
comparison's ``ratio_to_first``); a signal set's value is the mean over training seeds with
the std over seeds as its bar.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .training_curves import read_curves

#: The paper's signal sets, in the order of Fig. ablation(a) (the last one, without S_np,
#: is its red cross).
SIGNAL_SETS: tuple[tuple[str, ...], ...] = (
    ("n_r", "n_theta", "S_nn", "S_np", "omega"),
    ("n_r", "n_theta", "S_np", "omega"),
    ("n_r", "n_theta", "S_np"),
    ("n_theta", "S_np"),
    ("n_r", "n_theta", "S_nn", "omega"),
)
_ORDER = ("n_r", "n_theta", "S_nn", "S_np", "omega")
_TEX = {"n_r": "n_r", "n_theta": r"n_\theta", "S_nn": "S_{nn}", "S_np": "S_{np}",
        "omega": r"\omega"}
#: frames of one of the paper's training episodes (10 swimmers x 2000 decisions)
EPISODE_FRAMES = 10 * 2000


@dataclass(frozen=True)
class AblationRun:
    """One training run of the multirun and its paired comparison with STO."""

    signals: tuple[str, ...]
    """Observed signals, in :data:`_ORDER`."""
    seed: int
    """Training seed."""
    kubo: float
    frames: int
    """Frames trained."""
    ratio: float
    """``R_smart / R_STO``, paired over the comparison's held-out flows."""
    ratio_sem: float
    smart: float
    sto: float
    curve: dict[str, np.ndarray] | None
    """``curves.csv`` columns (``frames``, ``eval/R_hat``, ...), or None."""


def canonical(signals) -> tuple[str, ...]:
    """``signals`` in the paper's order (n_r, n_theta, S_nn, S_np, omega)."""
    return tuple(s for s in _ORDER if s in set(signals))


def set_label(signals: tuple[str, ...]) -> str:
    """``[n_r, n_theta, S_np]`` in TeX, as the paper's brackets."""
    return "[$" + ", ".join(_TEX[s] for s in canonical(signals)) + "$]"


def read_ablation(root: Path) -> list[AblationRun]:
    """Every run under ``root`` with a ``metrics.json`` and a ``comparison.json``.

    Raises ValueError (one line) where the runs do not form one ablation: different Ku or
    different budgets (the paper's ablation trains every set alike), or a comparison whose
    first row is not STO or that has no policy row."""
    runs = []
    for cmp_path in sorted(Path(root).rglob("comparison.json")):
        metrics_path = cmp_path.parent / "metrics.json"
        if not metrics_path.is_file():
            continue
        cmp = json.loads(cmp_path.read_text())
        cfg = json.loads(metrics_path.read_text())["config"]
        rows = cmp["rows"]
        policy = [r for r in rows if r["label"].startswith("policy")]
        if rows[0]["label"] != "sto" or len(policy) != 1:
            raise ValueError(f"{cmp_path}: expected STO first and one policy row, got "
                             f"{[r['label'] for r in rows]}")
        curve = cmp_path.parent / "curves.csv"
        runs.append(AblationRun(
            signals=canonical(cfg["signals"]["names"]), seed=int(cfg["seed"]),
            kubo=float(cfg["flow"]["kubo"]), frames=int(cfg["train"]["total_frames"]),
            ratio=float(policy[0]["ratio_to_first"]), ratio_sem=float(policy[0]["ratio_sem"]),
            smart=float(policy[0]["R_hat_mean"]), sto=float(rows[0]["R_hat_mean"]),
            curve=read_curves(curve) if curve.is_file() else None))
    for key in ("kubo", "frames"):
        values = sorted({getattr(r, key) for r in runs})
        if len(values) > 1:
            raise ValueError(f"ablation records under {root}: runs differ in {key} ({values}); "
                             "allowed: one value for every run")
    return runs


def summarise(runs: list[AblationRun]) -> list[dict]:
    """Per signal set (paper's sets first, in order): the seeds, their ratios, mean and std
    over seeds (0 for one seed)."""
    sets = {r.signals for r in runs}
    ordered = [s for s in SIGNAL_SETS if s in sets] + sorted(sets - set(SIGNAL_SETS))
    out = []
    for s in ordered:
        mine = sorted((r for r in runs if r.signals == s), key=lambda r: r.seed)
        ratios = np.array([r.ratio for r in mine])
        out.append({"signals": s, "label": set_label(s), "seeds": [r.seed for r in mine],
                    "ratios": ratios, "mean": float(ratios.mean()),
                    "std": float(ratios.std(ddof=1)) if len(ratios) > 1 else 0.0})
    return out


def draw_ratios(ax, summary: list[dict]) -> None:
    """(a) smart / STO per signal set: each seed a dot, the mean with the std over seeds; a
    set without S_np is drawn as the paper's red cross; STO = 1 as the green line."""
    x = np.arange(len(summary))
    for i, s in enumerate(summary):
        no_snp = "S_np" not in s["signals"]
        ax.plot(np.full(len(s["ratios"]), i), s["ratios"], "o", ms=3, color="0.55", zorder=2)
        ax.errorbar(i, s["mean"], yerr=s["std"], marker="x" if no_snp else "o", ms=9,
                    color="tab:red" if no_snp else "tab:orange", capsize=4, mew=2, zorder=3)
    ax.axhline(1.0, color="tab:green", ls="--", lw=1, label="STO")
    ax.set_xticks(x, [s["label"] for s in summary], rotation=25, ha="right", fontsize=7)
    ax.set_xlim(-0.5, len(summary) - 0.5)
    ax.set_ylabel(r"$\hat R_{\rm smart} / \hat R_{\rm STO}$")
    ax.legend(fontsize=7, loc="lower left")


def draw_curves(ax, runs: list[AblationRun], summary: list[dict]) -> dict[str, float]:
    """(a') each set's periodic held-out R_hat against training episodes: mean over seeds
    (on the first seed's evaluation frames), band = std over seeds; returns each set's last
    mean value."""
    last = {}
    for i, s in enumerate(summary):
        curves = [r.curve for r in runs if r.signals == s["signals"] and r.curve is not None]
        if not curves:
            continue
        ok = np.isfinite(curves[0]["eval/R_hat"])
        x = curves[0]["frames"][ok]
        ys = []
        for c in curves:
            good = np.isfinite(c["eval/R_hat"])
            ys.append(np.interp(x, c["frames"][good], c["eval/R_hat"][good]))
        y = np.mean(ys, 0)
        color = "tab:red" if "S_np" not in s["signals"] else f"C{i}"
        ax.plot(x / EPISODE_FRAMES, y, marker="o", ms=2, color=color, label=s["label"])
        if len(ys) > 1:
            e = np.std(ys, 0, ddof=1)
            ax.fill_between(x / EPISODE_FRAMES, y - e, y + e, color=color, alpha=0.15, lw=0)
        last[s["label"]] = float(y[-1])
    ax.set_xlabel("training episodes (of $2\\times10^4$ frames)")
    ax.set_ylabel(r"periodic held-out $\hat R$")
    ax.legend(fontsize=6)
    return last
