"""Tables of the 3D study's records beside this script (runs/, compare/); prints the markdown
tables of README.md: ``python summarise.py [runs] [compare]``.

* runs: per training run (``runs/ku<KU>_seed<S>``), the frames, updates and training time of
  ``metrics.json`` (a run without one: its last ``curves.csv`` row, "checkpoint"), the final
  evaluation (10 flows x 200 swimmers, the run's validation seed) and the held-out R-hat of
  ``curves.csv`` (16 flows x 32 swimmers every 2e7 frames; ± SEM over flows at the last).
* compare: per finished comparison (``compare/ku<KU>/comparison.json``: every strategy on the
  same held-out flows and starts), R-hat ± SEM over flows and the ratio to STO (paired per
  flow, ± SEM), the smart rows named by their run's seed.
"""
# ruff: noqa: E501
import csv
import json
import re
import sys
from pathlib import Path

R = Path(__file__).resolve().parent


def _run_key(path: Path) -> tuple[float, int]:
    ku, seed = re.fullmatch(r"ku([^_]+)_seed(\d+)", path.name).groups()
    return float(ku), int(seed)


def _curve(path: Path) -> tuple[list[tuple[int, float, float]], int]:
    """The held-out points ``(frames, R_hat, SEM)`` of ``curves.csv`` and its last frame count."""
    rows = list(csv.DictReader(path.open()))
    points = [(int(r["frames"]), float(r["eval/R_hat"]), float(r["eval/R_hat_sem"]))
              for r in rows if r.get("eval/R_hat")]
    return points, int(rows[-1]["frames"])


def runs() -> None:
    print("| run | frames | updates | training h | frames/s | final R̂ (10 × 200; seed) | held-out R̂ (16 × 32) at 0, 2e7, 4e7, 6e7, 8e7, 1e8 frames |")
    print("|---|---|---|---|---|---|---|")
    for path in sorted((R / "runs").iterdir(), key=_run_key):
        points, last = _curve(path / "curves.csv")
        held = ", ".join(f"{r:.3f}" for _, r, _ in points)
        if points:
            held += f" ± {points[-1][2]:.3f}"
        metrics = path / "metrics.json"
        if metrics.exists():
            m = json.loads(metrics.read_text())
            t = m["training"]
            print(f"| `{path.name}` | {t['frames']:.3e} | {t['updates']} | {t['wall_s'] / 3600:.2f} | "
                  f"{t['frames_per_s']:.2e} | {m['R_hat_mean']:.3f} ± {m['R_hat_sem']:.3f} ({m['seed']}) | {held} |")
        else:
            print(f"| `{path.name}` | {last:.3e} (checkpoint) | | | | | {held} |")


def _label(label: str) -> str:
    run = re.search(r"ku[^_/]+_seed(\d+)", label)
    if label.startswith("policy") and run:
        return f"smart (seed {run.group(1)})"
    naive = re.fullmatch(r"naive\(([+-]?[\d.]+)\)", label)
    if naive:
        return f"naive (Λ = {float(naive.group(1)):g})"
    return "STO" if label == "sto" else label


def compare() -> None:
    paths = sorted((R / "compare").glob("ku*/comparison.json"), key=lambda p: float(p.parent.name[2:]))
    if not paths:
        print("(no finished comparison under compare/)")
        return
    print("| Ku | flows × swimmers (seed) | strategy | R̂ ± SEM | × STO (paired) |")
    print("|---|---|---|---|---|")
    for path in paths:
        d = json.loads(path.read_text())
        ku = f"{d['config']['flow']['kubo']:g}"
        size = f"{d['n_flows']} × {d['n_swimmers']} ({d['seed']})"
        first = d["rows"][0]["label"]
        for row in d["rows"]:
            ratio = (f"{row['ratio_to_first']:.3f} ± {row['ratio_sem']:.3f}"
                     if row["label"] != first else "1")
            print(f"| {ku} | {size} | {_label(row['label'])} | "
                  f"{row['R_hat_mean']:.3f} ± {row['R_hat_sem']:.3f} | {ratio} |")


if __name__ == "__main__":
    parts = sys.argv[1:] or ["runs", "compare"]
    for i, part in enumerate(parts):
        if i:
            print()
        {"runs": runs, "compare": compare}[part]()
