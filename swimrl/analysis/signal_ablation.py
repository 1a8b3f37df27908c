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

from swimrl.evaluation.statistics import mean_std_sem
from swimrl.flows.labels import ku_display
from swimrl.physics.body2d import SIGNAL_NAMES
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.curves import read_curves
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import markdown_table

from .training_curves import PAPER_EPISODE_FRAMES

#: The paper's signal sets, in the order of Fig. ablation(a) (the last one, without S_np,
#: is its red cross).
SIGNAL_SETS: tuple[tuple[str, ...], ...] = (
    ("n_r", "n_theta", "S_nn", "S_np", "omega"),
    ("n_r", "n_theta", "S_np", "omega"),
    ("n_r", "n_theta", "S_np"),
    ("n_theta", "S_np"),
    ("n_r", "n_theta", "S_nn", "omega"),
)
_TEX = {"n_r": "n_r", "n_theta": r"n_\theta", "S_nn": "S_{nn}", "S_np": "S_{np}",
        "omega": r"\omega"}
#: Curve colours: none of smart orange, STO green, or the red of the set without S_np.
_PALETTE = ("tab:blue", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink",
            "tab:gray")


@dataclass(frozen=True)
class AblationRun:
    """One training run of the multirun and its paired comparison with STO."""

    signals: tuple[str, ...]
    """Observed signals, in the order of :data:`SIGNAL_NAMES`."""
    seed: int
    """Training seed."""
    kubo: float
    frames: int
    """Frames trained."""
    held_out: tuple[int, int]
    """Held-out flows x swimmers of the comparison."""
    ratio: float
    """``R_smart / R_STO``, paired over the comparison's held-out flows."""
    ratio_sem: float
    smart: float
    sto: float
    curve: dict[str, np.ndarray] | None
    """``curves.csv`` columns (``frames``, ``eval/R_hat``, ...) where it has held-out
    evaluations, else None."""


def canonical(signals) -> tuple[str, ...]:
    """``signals`` in the paper's order (n_r, n_theta, S_nn, S_np, omega); raises ValueError
    on a name that is not a signal."""
    unknown = sorted(set(signals) - set(SIGNAL_NAMES))
    if unknown:
        raise ValueError(f"signals {unknown} are invalid: allowed {list(SIGNAL_NAMES)}")
    return tuple(s for s in SIGNAL_NAMES if s in set(signals))


def set_label(signals: tuple[str, ...]) -> str:
    """``[n_r, n_theta, S_np]`` in TeX, as the paper's brackets."""
    return "[$" + ", ".join(_TEX[s] for s in canonical(signals)) + "$]"


def _run(cmp_path: Path) -> AblationRun | None:
    """The run in ``cmp_path.parent``, or None without ``metrics.json``; raises ValueError
    (one line) where the comparison is not this run's."""
    run = RunLayout(cmp_path.parent)
    metrics_path = run.metrics
    if not metrics_path.is_file():
        return None
    cmp = json.loads(cmp_path.read_text())
    metrics = json.loads(metrics_path.read_text())
    rows = cmp.get("rows") or []
    policy = [r for r in rows if StrategyLabel.parse(r["label"]).name == "policy"]
    if not rows or rows[0]["label"] != StrategyLabel("sto").label or len(policy) != 1:
        raise ValueError(f"{cmp_path}: expected STO first and one policy row, got "
                         f"{[r['label'] for r in rows]}")
    if policy[0].get("per_flow") != metrics.get("per_flow"):
        raise ValueError(f"{cmp_path}: its policy row is not the final evaluation in "
                         f"{metrics_path} (per-flow R_hat differ): a stale comparison")
    cfg = metrics["config"]
    curve_path = run.curves
    curve = read_curves(curve_path) if curve_path.is_file() else {}
    has_eval = "eval/R_hat" in curve and np.isfinite(curve["eval/R_hat"]).any()
    return AblationRun(
        signals=canonical(cfg["signals"]["names"]), seed=int(cfg["seed"]),
        kubo=float(cfg["flow"]["kubo"]), frames=int(cfg["train"]["total_frames"]),
        held_out=(int(cmp.get("n_flows", 0)), int(cmp.get("n_swimmers", 0))),
        ratio=float(policy[0]["ratio_to_first"]), ratio_sem=float(policy[0]["ratio_sem"]),
        smart=float(policy[0]["R_hat_mean"]), sto=float(rows[0]["R_hat_mean"]),
        curve=curve if has_eval else None)


def read_ablation(root: Path) -> list[AblationRun]:
    """Every run under ``root`` with a ``metrics.json`` and a ``comparison.json``.

    Raises ValueError (one line) where the runs do not form one ablation: different Ku,
    budgets or held-out sizes (the paper's ablation trains and evaluates every set alike), a
    signal set and seed found twice, or a comparison that is not its run's (first row not
    STO, no policy row, or a policy row other than the run's final evaluation)."""
    name = RunLayout(root).comparison.name
    runs = [r for p in sorted(Path(root).rglob(name)) if (r := _run(p))]
    check_one_ablation(root, runs, {key: {getattr(r, key) for r in runs}
                                    for key in ("kubo", "frames", "held_out")})
    return runs


def check_one_ablation(root: Path, runs: list[AblationRun], shared: dict[str, set]) -> None:
    """ValueError (one line naming ``root``) unless every value set of ``shared`` (what all
    runs must have in common: Ku, budget, held-out sizes) has one value and every signal set
    and seed occurs once in ``runs``."""
    for key, values in shared.items():
        if len(values) > 1:
            raise ValueError(f"ablation records under {root}: runs differ in {key} "
                             f"({sorted(values)}); allowed: one value for every run")
    seen = set()
    for r in runs:
        if (r.signals, r.seed) in seen:
            raise ValueError(f"ablation records under {root}: signals {list(r.signals)} with "
                             f"seed {r.seed} found twice; allowed: one run per set and seed")
        seen.add((r.signals, r.seed))


def summarise_sets(runs: list[AblationRun]) -> list[dict]:
    """Per signal set (paper's sets first, in order): the seeds, their ratios, the mean and
    std over seeds, and for a single seed its own paired SEM (``sem_one``)."""
    sets = {r.signals for r in runs}
    ordered = [s for s in SIGNAL_SETS if s in sets] + sorted(sets - set(SIGNAL_SETS))
    out = []
    for s in ordered:
        mine = sorted((r for r in runs if r.signals == s), key=lambda r: r.seed)
        ratios = np.array([r.ratio for r in mine])
        mean, std, _ = mean_std_sem(ratios)
        out.append({"signals": s, "label": set_label(s), "seeds": [r.seed for r in mine],
                    "n": len(mine), "ratios": ratios, "mean": mean, "std": std,
                    "sem_one": mine[0].ratio_sem if len(mine) == 1 else None})
    return out


def ablation_markdown(runs: list[AblationRun], summary: list[dict]) -> str:
    """The table of Fig. ablation (a): per signal set, each seed's smart and STO R_hat and
    paired ratio, and the mean and std over seeds of the ratio."""
    flows, swimmers = runs[0].held_out
    intro = (f"{ku_display(runs[0].kubo)}, {runs[0].frames / 1e6:g}M frames per run; each run's "
             f"smart and STO on its {flows} held-out flows x {swimmers} swimmers (evaluation "
             "seed 1000000 + seed)\n\n")
    head = ["signals", "seeds", "smart R̂ per seed", "STO R̂ per seed",
            "smart / STO per seed (paired ± SEM)", "mean ± std over seeds"]
    rows = []
    for s in summary:
        mine = sorted((r for r in runs if r.signals == s["signals"]), key=lambda r: r.seed)
        rows.append([", ".join(s["signals"]), ", ".join(map(str, s["seeds"])),
                     ", ".join(f"{r.smart:.3f}" for r in mine),
                     ", ".join(f"{r.sto:.3f}" for r in mine),
                     ", ".join(f"{r.ratio:.3f} ± {r.ratio_sem:.3f}" for r in mine),
                     f"**{s['mean']:.3f} ± {s['std']:.3f}**"])
    return intro + markdown_table(head, rows)


def draw_ratios(ax, summary: list[dict]) -> None:
    """(a) smart / STO per signal set: each seed a dot, the mean with the std over seeds (a
    single seed: its paired SEM, open marker); a set without S_np is drawn as the paper's red
    cross; STO = 1 as the green line."""
    x = np.arange(len(summary))
    for i, s in enumerate(summary):
        no_snp = "S_np" not in s["signals"]
        one = s["n"] == 1
        ax.plot(np.full(s["n"], i), s["ratios"], "o", ms=3, color="0.55", zorder=2)
        ax.errorbar(i, s["mean"], yerr=s["sem_one"] if one else s["std"],
                    marker="x" if no_snp else "o", ms=9, mew=2, capsize=4, zorder=3,
                    color="tab:red" if no_snp else "tab:orange",
                    mfc="none" if one and not no_snp else None)
    ax.axhline(1.0, color="tab:green", ls="--", lw=1, label="STO")
    ax.set_xticks(x, [f"{s['label']}\n({s['n']} seed{'s' * (s['n'] > 1)})" for s in summary],
                  rotation=25, ha="right", fontsize=7)
    ax.set_xlim(-0.5, len(summary) - 0.5)
    ax.set_ylabel(r"$\hat R_{\rm smart} / \hat R_{\rm STO}$")
    ax.legend(fontsize=7, loc="lower left")


def draw_curves(ax, runs: list[AblationRun], summary: list[dict]) -> dict[str, float]:
    """(a') each set's periodic held-out R_hat against training episodes (of the paper's
    2e4 frames): mean over the seeds at the evaluation frames they all have, band = std over
    seeds; returns each set's last mean value."""
    last = {}
    for i, s in enumerate(summary):
        curves = [r.curve for r in runs if r.signals == s["signals"] and r.curve is not None]
        if not curves:
            continue
        evals = [{int(f): y for f, y in zip(c["frames"], c["eval/R_hat"], strict=True)
                  if np.isfinite(y)} for c in curves]
        x = np.array(sorted(set.intersection(*(set(e) for e in evals))))
        if x.size == 0:
            continue
        ys = np.array([[e[f] for f in x] for e in evals])
        y = ys.mean(0)
        color = "tab:red" if "S_np" not in s["signals"] else _PALETTE[i % len(_PALETTE)]
        ax.plot(x / PAPER_EPISODE_FRAMES, y, marker="o", ms=2, color=color, label=s["label"])
        if len(ys) > 1:
            e = ys.std(0, ddof=1)
            ax.fill_between(x / PAPER_EPISODE_FRAMES, y - e, y + e, color=color, alpha=0.15,
                            lw=0)
        last[s["label"]] = float(y[-1])
    ax.set_xlabel("training episodes (of $2\\times10^4$ frames)")
    ax.set_ylabel(r"periodic held-out $\hat R$")
    ax.legend(fontsize=6)
    return last
