"""The Ku = 1e7 energy comparison on 100 frozen flows x 200 swimmers, summarised from its
record (``ku1e7/comparison.json``) only: per weight the three seeds' R_hat and E_hat, and,
paired per flow against the mean of the three w = 0 policies, each weight's three-seed mean
ratio of R_hat and of E_hat (mean of the per-flow ratios +- SEM over flows); the seed spread
(pooled std of the seeds' R_hat within a weight); the STO family and the constant shapes.

    python docs/results/beyond/energy_100flows/summarise.py [RECORD] > summary.json
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
WEIGHT = re.compile(r"energy_ku1e7_w(?P<w>[0-9.]+)_seed(?P<s>\d)")
PROTOCOL = re.compile(r"paper_runs/ku1e7_seed(?P<s>\d)")


def weight_of(label: str) -> tuple[str, int] | None:
    m = WEIGHT.search(label)
    if m:
        return m.group("w"), int(m.group("s"))
    m = PROTOCOL.search(label)
    return ("0", int(m.group("s"))) if m else None


def mean_sem(x: np.ndarray) -> tuple[float, float]:
    return float(x.mean()), float(x.std(ddof=1) / np.sqrt(x.size))


def main(path: Path) -> dict:
    rec = json.loads(path.read_text())
    rows = rec["rows"]
    weights: dict[str, dict[int, dict]] = {}
    for r in rows:
        key = weight_of(r["label"])
        if key is not None:
            weights.setdefault(key[0], {})[key[1]] = r
    r0 = np.mean([r["per_flow"] for r in weights["0"].values()], axis=0)
    e0 = np.mean([r["energy_per_flow"] for r in weights["0"].values()], axis=0)
    full = path.resolve()
    shown = str(full.relative_to(HERE)) if full.is_relative_to(HERE) else str(path)
    out: dict = {"record": shown, "n_flows": rec["n_flows"], "n_swimmers": rec["n_swimmers"],
                 "seed": rec["seed"], "weights": {}, "family": [], "naive": []}
    variances = []
    for w in sorted(weights, key=float):
        seeds = weights[w]
        r = np.mean([s["per_flow"] for s in seeds.values()], axis=0)
        e = np.mean([s["energy_per_flow"] for s in seeds.values()], axis=0)
        rr, rr_sem = mean_sem(r / r0 - 1.0)
        er, er_sem = mean_sem(e / e0 - 1.0)
        r_hat = [seeds[k]["R_hat_mean"] for k in sorted(seeds)]
        variances.append(np.var(r_hat, ddof=1))
        out["weights"][w] = {
            "seeds": sorted(seeds),
            "R_hat": r_hat, "R_hat_sem": [seeds[k]["R_hat_sem"] for k in sorted(seeds)],
            "x_STO": [seeds[k]["ratio_to_first"] for k in sorted(seeds)],
            "x_STO_sem": [seeds[k]["ratio_sem"] for k in sorted(seeds)],
            "E_hat": [seeds[k]["energy_mean"] for k in sorted(seeds)],
            "E_hat_sem": [seeds[k]["energy_sem"] for k in sorted(seeds)],
            "R_vs_w0": rr, "R_vs_w0_sem": rr_sem, "E_vs_w0": er, "E_vs_w0_sem": er_sem,
        }
    out["seed_std_pooled"] = float(np.sqrt(np.mean(variances)))
    for r in rows:
        if r["label"].startswith("sto"):
            out["family"].append({k: r[k] for k in ("label", "R_hat_mean", "R_hat_sem",
                                                    "ratio_to_first", "ratio_sem",
                                                    "energy_mean", "energy_sem")})
        elif r["label"].startswith("naive"):
            out["naive"].append({k: r[k] for k in ("label", "R_hat_mean", "R_hat_sem",
                                                   "energy_mean")})
    return out


if __name__ == "__main__":
    record = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "ku1e7" / "comparison.json"
    print(json.dumps(main(record), indent=1))
