"""Pair policies' held-out R̂ with the optimised rule's record on the same flows.

The policies' comparison (``swimrl-compare ... compare.shared_flows=true`` with the same flow
seed and sizes as the rule's record) holds only the policies; STO and the rule are read from
the rule's record, whose STO row came from the same flows and starts. Per policy: R̂ ± SEM,
R̂ / R̂_STO paired over flows (delta-method SEM, ``swimrl.evaluation.statistics.paired_ratio``)
and the paired difference to the rule ``R̂_policy − R̂_rule`` ± SEM over flows.

    python pair_with_rule.py RULE_COMPARISON.json RULE_LABEL POLICY_COMPARISON.json... [--json OUT]

Prints a markdown table (and writes the numbers as JSON with ``--json``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from swimrl.evaluation.statistics import mean_std_sem, paired_difference, paired_ratio


def rows(path: Path) -> dict[str, dict]:
    return {r["label"]: r for r in json.loads(Path(path).read_text())["rows"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rule_comparison", type=Path)
    parser.add_argument("rule_label")
    parser.add_argument("policy_comparisons", type=Path, nargs="+")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    ref = rows(args.rule_comparison)
    sto = np.asarray(ref["sto"]["per_flow"])
    rule = np.asarray(ref[args.rule_label]["per_flow"])
    out = {"sto": float(sto.mean()), "rule": {"label": args.rule_label,
           "R_hat": float(rule.mean()), "ratio_to_sto": paired_ratio(rule, sto)}, "policies": {}}
    rule_sem = mean_std_sem(rule)[2]
    r_rule, r_rule_sem = out["rule"]["ratio_to_sto"]
    lines = ["| strategy | R̂ | × STO (paired) | R̂: policy − rule (paired) |", "|---|---|---|---|",
             f"| {args.rule_label} | {rule.mean():.3f} ± {rule_sem:.3f}"
             f" | {r_rule:.3f} ± {r_rule_sem:.3f} | — |"]
    for path in args.policy_comparisons:
        for label, row in rows(path).items():
            if not label.startswith("policy"):
                continue
            p = np.asarray(row["per_flow"])
            if p.size != sto.size:
                raise SystemExit(f"{path}: {label} has {p.size} flows, the rule's record "
                                 f"{sto.size}")
            ratio, diff = paired_ratio(p, sto), paired_difference(p, rule)
            out["policies"][label] = {"R_hat": float(p.mean()), "R_hat_sem": row["R_hat_sem"],
                                      "ratio_to_sto": ratio, "minus_rule": diff}
            lines.append(f"| {label} | {p.mean():.3f} ± {row['R_hat_sem']:.3f} | {ratio[0]:.3f} ± "
                         f"{ratio[1]:.3f} | {diff[0]:+.3f} ± {diff[1]:.3f} |")
    print("\n".join(lines))
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
