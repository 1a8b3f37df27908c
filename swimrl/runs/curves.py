"""Training curves of a run: the TensorBoard scalars that matter, as one CSV.

One row per logged step (frames), one column per tag; a step logged twice (a resumed run
repeats the updates after its last checkpoint) keeps the value written last. The CSV is
small enough to commit next to the run's policy, so training-curve figures can be drawn
from a fresh clone without the event files; a run resumed from such a committed record (its
checkpoint and ``curves.csv``, no event files) passes the CSV's rows up to its checkpoint as
``base`` to :func:`write_curves`, so its curve stays whole.

    swimrl-curves RUN_DIR [--out RUN_DIR/curves.csv]     # or: python -m swimrl.runs.curves
"""

from __future__ import annotations

import argparse
import csv
import io
import math
from pathlib import Path

import numpy as np

from swimrl.runs.atomic import atomic_write_text
from swimrl.runs.layout import RunLayout

#: Tags exported by default (see the monitoring table of docs/training.md).
CURVE_TAGS = (
    "eval/R_hat",
    "eval/R_hat_sem",
    "eval/energy",
    "eval/shape_change",
    "eval/arrival",
    "train/R_hat",
    "train/episodes",
    "policy/std",
    "policy/abs_action_mean",
    "train/kl_approx",
    "train/clip_fraction",
    "train/explained_variance",
    "train/loss_critic",
    "train/lr_actor",
    "train/lr_critic",
    "time/frames_per_s",
)


def read_curves(path: Path) -> dict[str, np.ndarray]:
    """Columns of a ``curves.csv`` (``swimrl-train``; a run directory or the file) as float
    arrays, NaN where a cell is empty."""
    path = Path(path)
    if path.is_dir():
        path = RunLayout(path).curves
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        return {}
    return {k: np.array([float(r[k]) if r[k] else np.nan for r in rows]) for k in rows[0]}


def read_scalars(run_dir: Path, tags=CURVE_TAGS) -> dict[int, dict[str, float]]:
    """``{frames: {tag: value}}`` from every event file under ``run_dir/tb`` (by wall time,
    so the last write of a step wins)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = []
    for path in sorted(RunLayout(run_dir).tb.rglob("events.out.tfevents.*")):
        acc = EventAccumulator(str(path), size_guidance={"scalars": 0})
        acc.Reload()
        for tag in set(acc.Tags()["scalars"]) & set(tags):
            events += [(e.wall_time, e.step, tag, e.value) for e in acc.Scalars(tag)]
    rows: dict[int, dict[str, float]] = {}
    for _, step, tag, value in sorted(events):
        rows.setdefault(int(step), {})[tag] = float(value)
    return rows


def read_curves_csv(path: Path) -> dict[int, dict[str, float]]:
    """``{frames: {tag: value}}`` of a ``curves.csv`` (empty cells left out): the rows of
    :func:`swimrl.runs.curves.read_curves`."""
    cols = read_curves(path)
    tags = [t for t in cols if t != "frames"]
    return {int(f): {t: float(cols[t][i]) for t in tags if np.isfinite(cols[t][i])}
            for i, f in enumerate(cols.get("frames", []))}


def write_curves(run_dir: Path, out: Path | None = None, tags=CURVE_TAGS,
                 base: dict[int, dict[str, float]] | None = None) -> Path:
    """Write ``curves.csv`` (``frames`` then one column per tag; empty where not logged):
    the event files' rows over ``base`` (rows logged before a resume whose event files are
    gone; a step in both keeps the event files' row)."""
    out = Path(out) if out is not None else RunLayout(run_dir).curves
    rows = {**(base or {}), **read_scalars(Path(run_dir), tags)}
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(["frames", *tags])
    for step in sorted(rows):
        vals = [rows[step].get(t) for t in tags]
        w.writerow([step] + ["" if v is None or not math.isfinite(v) else f"{v:.6g}"
                             for v in vals])
    return atomic_write_text(out, buf.getvalue())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    print(write_curves(args.run_dir, args.out))


if __name__ == "__main__":
    main()
