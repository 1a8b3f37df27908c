"""Training curves from committed ``curves.csv`` records (written by ``swimrl-train``).

    swimrl-training-curves OUT.png LABEL=RUN_OR_CSV [LABEL=...]
        [--tag eval/R_hat] [--reference LABEL=VALUE ...]

(or ``python -m swimrl.analysis.training_curves ...``).

Each curve is one column of a run's ``curves.csv`` (``frames`` and one column per
TensorBoard tag; empty cells where a tag was not logged) against frames; the periodic
held-out evaluation ``eval/R_hat`` is drawn with its SEM band when ``eval/R_hat_sem`` is
there. :func:`draw_curve` draws one curve, here and in Fig. trainingCurves
(:mod:`swimrl.paper.training`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from swimrl.runs.curves import read_curves

from .plots import pyplot

__all__ = ["PAPER_EPISODE_FRAMES", "draw_curve", "plot_training_curves", "read_curves"]

#: frames of one of the paper's training episodes (10 swimmers x 2000 decisions)
PAPER_EPISODE_FRAMES = 10 * 2000


def draw_curve(ax, curve: dict[str, np.ndarray], tag: str = "eval/R_hat",
               label: str | None = None, frames_per_unit: float = 1e6, ms: float = 3,
               **band) -> tuple[np.ndarray, np.ndarray]:
    """``tag`` of one ``curves.csv`` record against its frames / ``frames_per_unit`` on
    ``ax`` (the cells where it was logged), with a +- SEM band (``band``: its style) where
    ``<tag>_sem`` is recorded; returns the frames and the values drawn."""
    ok = np.isfinite(curve[tag])
    x, y = curve["frames"][ok], curve[tag][ok]
    (line,) = ax.plot(x / frames_per_unit, y, marker="o", ms=ms, label=label)
    if tag + "_sem" in curve:
        s = curve[tag + "_sem"][ok]
        ax.fill_between(x / frames_per_unit, y - s, y + s, color=line.get_color(), alpha=0.2,
                        **band)
    return x, y


def plot_training_curves(
    runs: dict[str, Path],
    out: Path,
    tag: str = "eval/R_hat",
    references: dict[str, float] | None = None,
    title: str | None = None,
    ylabel: str | None = None,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``tag`` against frames for each labelled run (+- SEM band for ``eval/R_hat``) and
    horizontal reference lines; ``ylabel`` (default: held-out R_hat, or the tag) names the
    task's score (``task=vertical``: ``<v_z>/v_s``); returns ``{label: (frames, values)}`` of
    what was drawn."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    drawn = {}
    for label, path in runs.items():
        drawn[label] = draw_curve(ax, read_curves(path), tag, label)
    for i, (label, value) in enumerate((references or {}).items()):
        ax.axhline(value, color=f"C{len(runs) + i}", ls="--", lw=1, label=label)
    ax.set_xlabel("training frames (millions of decisions)")
    ax.set_ylabel(ylabel or (r"held-out $\hat R$" if tag == "eval/R_hat" else tag))
    if title:
        ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return drawn


def _pairs(items: list[str], what: str) -> dict[str, str]:
    out = {}
    for item in items:
        if "=" not in item:
            raise SystemExit(f"error: {what} {item!r} is invalid: allowed LABEL=VALUE")
        label, value = item.rsplit("=", 1)
        out[label] = value
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("runs", nargs="+", help="LABEL=RUN_DIR_OR_CSV")
    ap.add_argument("--tag", default="eval/R_hat")
    ap.add_argument("--reference", nargs="*", default=[], help="LABEL=VALUE")
    ap.add_argument("--title", default=None)
    ap.add_argument("--ylabel", default=None, help="the y axis' label (default: the tag's)")
    args = ap.parse_args(argv)
    runs = {k: Path(v) for k, v in _pairs(args.runs, "run").items()}
    refs = {k: float(v) for k, v in _pairs(args.reference, "--reference").items()}
    plot_training_curves(runs, args.out, args.tag, refs, args.title, args.ylabel)
    print(args.out)


if __name__ == "__main__":
    main()
