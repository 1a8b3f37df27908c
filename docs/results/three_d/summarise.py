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
import json
import re
import sys
from pathlib import Path

import numpy as np

from swimrl.paper.three_d import read_comparisons, read_runs
from swimrl.policies.baselines import StrategyLabel
from swimrl.runs.curves import read_curves

R = Path(__file__).resolve().parent


def runs() -> None:
    print("| run | frames | updates | training h | frames/s | final R̂ (10 × 200; seed) | held-out R̂ (16 × 32) at 0, 2e7, 4e7, 6e7, 8e7, 1e8 frames |")
    print("|---|---|---|---|---|---|---|")
    for seeds in read_runs(R / "runs").values():
        for path in seeds.values():
            curve = read_curves(path)
            held_out = ~np.isnan(curve["eval/R_hat"])
            held = ", ".join(f"{r:.3f}" for r in curve["eval/R_hat"][held_out])
            if held_out.any():
                held += f" ± {curve['eval/R_hat_sem'][held_out][-1]:.3f}"
            metrics = path / "metrics.json"
            if metrics.exists():
                m = json.loads(metrics.read_text())
                t = m["training"]
                print(f"| `{path.name}` | {t['frames']:.3e} | {t['updates']} | {t['wall_s'] / 3600:.2f} | "
                      f"{t['frames_per_s']:.2e} | {m['R_hat_mean']:.3f} ± {m['R_hat_sem']:.3f} ({m['seed']}) | {held} |")
            else:
                print(f"| `{path.name}` | {int(curve['frames'][-1]):.3e} (checkpoint) | | | | | {held} |")


def _label(text: str) -> str:
    label = StrategyLabel.parse(text)
    if label == StrategyLabel.sto():
        return "STO"
    if label.name == "naive" and label.arg:
        return f"naive (Λ = {float(label.arg):g})"
    run = re.search(r"ku[^_/]+_seed(\d+)", text)
    return f"smart (seed {run.group(1)})" if label.name == "policy" and run else text


def compare() -> None:
    comparisons = read_comparisons(R / "compare")
    if not comparisons:
        print("(no finished comparison under compare/)")
        return
    print("| Ku | flows × swimmers (seed) | strategy | R̂ ± SEM | × STO (paired) |")
    print("|---|---|---|---|---|")
    for ku, d in comparisons.items():
        size = f"{d['n_flows']} × {d['n_swimmers']} ({d['seed']})"
        first = d["rows"][0]["label"]
        for row in d["rows"]:
            ratio = (f"{row['ratio_to_first']:.3f} ± {row['ratio_sem']:.3f}"
                     if row["label"] != first else "1")
            print(f"| {ku:g} | {size} | {_label(row['label'])} | "
                  f"{row['R_hat_mean']:.3f} ± {row['R_hat_sem']:.3f} | {ratio} |")


if __name__ == "__main__":
    parts = sys.argv[1:] or ["runs", "compare"]
    for i, part in enumerate(parts):
        if i:
            print()
        {"runs": runs, "compare": compare}[part]()
