"""The DNS transfer per training seed (three_seeds/README.md, section 4).

Reads ``seed*/comparison.json`` beside this file (one per held-out DNS realisation, every
strategy on the same flows) and prints, as JSON: per row (STO, naive, the minimal models of the
twelve fits, the twelve protocol policies, the DNS-trained runs) R_hat pooled over every flow
of every realisation and ``<R>/<R_STO>`` paired over those flows (± delta-method SEM), each
realisation's own ratio and their std; per training Ku the mean and std over the three seeds of
the pooled ratio (smart and minimal); the paired ratio Ku = 10 / Ku = 1e7 per seed.

Usage:  python summarise.py > summary.json      (python summarise.py --md: the tables)
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from swimrl.evaluation.statistics import paired_ratio
from swimrl.paper.seeds import SEEDED_ROW, pooled_rows

HERE = Path(__file__).resolve().parent


def main() -> dict:
    names, rows = pooled_rows(HERE.parent)
    sto = rows["sto"]
    out: dict = {"realisations": names,
                 "n_flows": int(sum(v.size for v in sto)), "rows": {}, "by_ku": {}}
    for label, per in rows.items():
        a, b = np.concatenate(per), np.concatenate(sto)
        ratio, sem = paired_ratio(a, b)
        each = [float(x.mean() / y.mean()) for x, y in zip(per, sto, strict=True)]
        out["rows"][label] = {"R_hat": float(a.mean()), "ratio": ratio, "ratio_sem": sem,
                              "per_realisation": each,
                              "std_over_realisations": float(np.std(each, ddof=1))
                              if len(each) > 1 else 0.0}
    by: dict[tuple[str, str], dict[int, float]] = {}
    for label, r in out["rows"].items():
        m = SEEDED_ROW.fullmatch(label)
        if m:
            by.setdefault((m.group(1), m.group(2)), {})[int(m.group(3))] = r["ratio"]
    for (kind, ku), seeds in sorted(by.items()):
        v = np.array([seeds[s] for s in sorted(seeds)])
        out["by_ku"].setdefault(ku, {})[kind] = {
            "seeds": sorted(seeds), "ratios": v.tolist(), "mean": float(v.mean()),
            "std": float(v.std(ddof=1)) if v.size > 1 else 0.0}
    out["ku10_over_ku1e7"] = {}
    for s in range(3):
        a = f"policy(docs/results/paper_runs/ku10_seed{s})"
        b = f"policy(docs/results/paper_runs/ku1e7_seed{s})"
        if a in rows and b in rows:
            r, e = paired_ratio(np.concatenate(rows[a]), np.concatenate(rows[b]))
            out["ku10_over_ku1e7"][str(s)] = {"ratio": r, "sem": e}
    return out


def markdown(out: dict) -> str:
    """The per-seed table (smart and minimal / STO per training Ku and seed, and their mean
    ± std over seeds) and the rows of the DNS-trained runs."""
    kus = ("ku0.1", "ku1", "ku10", "ku1e7")
    lines = ["| trained at | kind | seed 0 | seed 1 | seed 2 | mean ± std over seeds |",
             "|---|---|---|---|---|---|"]
    for ku in kus:
        for kind in ("policy", "minimal"):
            d = out["by_ku"][ku][kind]
            cells = []
            for s in d["seeds"]:
                prefix = "policy(docs/results/paper_runs/" if kind == "policy" else "minimal("
                row = out["rows"][f"{prefix}{ku}_seed{s})"]
                cells.append(f"{row['ratio']:.3f} ± {row['ratio_sem']:.3f}")
            lines.append(f"| {ku} | {'smart' if kind == 'policy' else 'minimal'} | "
                         + " | ".join(cells) + f" | {d['mean']:.3f} ± {d['std']:.3f} |")
    lines += ["", "| row | R̂ | R̂ / R̂_STO (paired) | per realisation | std over realisations |",
              "|---|---|---|---|---|"]
    for label, r in out["rows"].items():
        if not SEEDED_ROW.fullmatch(label):
            lines.append(f"| {label} | {r['R_hat']:.3f} | {r['ratio']:.3f} ± {r['ratio_sem']:.3f}"
                         f" | {', '.join(f'{x:.3f}' for x in r['per_realisation'])}"
                         f" | {r['std_over_realisations']:.3f} |")
    lines += ["", "Ku = 10 / Ku = 1e7 policy of the same seed (paired): " + ", ".join(
        f"seed {s} {v['ratio']:.3f} ± {v['sem']:.3f}" for s, v in out["ku10_over_ku1e7"].items())]
    return "\n".join(lines)


if __name__ == "__main__":
    import sys

    result = main()
    print(markdown(result) if "--md" in sys.argv[1:] else json.dumps(result, indent=1))
