"""Referee items 1-3: the numbers of README.md from the comparison.json records in this folder.

Reads the records written by swimrl-naive-scan / swimrl-compare (``naive_scan/ku*/``,
``swim_speed/vs*/``, ``box/*/``) and writes ``summary.json`` beside this script: per record
each row's R_hat (mean, SEM, std over flows) and the paired comparisons the README quotes
(ratio of means with the delta-method SEM of swimrl.evaluation.statistics.paired_ratio, and
the mean paired per-flow difference with its SEM). Across boxes (different grids draw
different flows) the comparison is unpaired: difference of means, SEMs added in quadrature.

Usage (from the repository root): .venv/bin/python docs/results/referee_items/summarise.py
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def load(path: Path) -> dict:
    d = json.loads(path.read_text())
    rows = {r["label"]: np.asarray(r["per_flow"], dtype=float) for r in d["rows"]}
    return {"record": str(path.relative_to(HERE)), "n_flows": d["n_flows"],
            "n_swimmers": d["n_swimmers"], "seed": d["seed"], "config": d["config"],
            "flow_stats": d.get("flow_stats"), "rows": rows}


def stats(x: np.ndarray) -> dict:
    return {"mean": float(x.mean()), "sem": float(x.std(ddof=1) / math.sqrt(x.size)),
            "std": float(x.std(ddof=1))}


def paired(a: np.ndarray, b: np.ndarray) -> dict:
    r = float(a.mean() / b.mean())
    r_sem = float((a - r * b).std(ddof=1) / math.sqrt(a.size) / b.mean())
    d = a - b
    return {"ratio": r, "ratio_sem": r_sem, "diff": float(d.mean()),
            "diff_sem": float(d.std(ddof=1) / math.sqrt(d.size))}


def naive_scan() -> dict:
    out = {}
    for p in sorted(HERE.glob("naive_scan/ku*/comparison.json")):
        rec = load(p)
        rows = rec["rows"]
        ref = rows["naive(+0.98)"]
        table = {lab: {**stats(v), "vs_0.98": paired(v, ref)} for lab, v in rows.items()}
        best = max(rows, key=lambda k: rows[k].mean())
        # shapes not resolved from the best: paired difference to the best within 2 SEM
        tied = [lab for lab, v in rows.items()
                if lab == best or abs(paired(v, rows[best])["diff"])
                <= 2 * paired(v, rows[best])["diff_sem"]]
        out[p.parent.name] = {"record": rec["record"], "Ku": rec["config"]["flow"]["kubo"],
                              "n_flows": rec["n_flows"], "n_swimmers": rec["n_swimmers"],
                              "seed": rec["seed"], "rows": table, "best": best,
                              "best_vs_0.98": paired(rows[best], ref),
                              "within_2sem_of_best": tied}
    return out


def three_way(rec: dict) -> dict:
    rows = rec["rows"]
    smart = next(lab for lab in rows if lab not in ("sto", "naive(+0.98)", "naive"))
    naive = "naive(+0.98)" if "naive(+0.98)" in rows else "naive"
    return {"record": rec["record"], "n_flows": rec["n_flows"], "n_swimmers": rec["n_swimmers"],
            "seed": rec["seed"], "flow": rec["config"]["flow"],
            "swim_speed": rec["config"]["swimmer"]["swim_speed"],
            "flow_stats": rec["flow_stats"],
            "rows": {lab: stats(v) for lab, v in rows.items()},
            "smart_label": smart,
            "smart_vs_sto": paired(rows[smart], rows["sto"]),
            "smart_vs_naive": paired(rows[smart], rows[naive]),
            "sto_vs_naive": paired(rows["sto"], rows[naive])}


def swim_speed() -> dict:
    recs = [three_way(load(p)) for p in HERE.glob("swim_speed/*/comparison.json")]
    return {f"v_s={r['swim_speed']:g}": r for r in sorted(recs, key=lambda r: r["swim_speed"])}


def box() -> dict:
    out = {}
    for p in sorted(HERE.glob("box/*/comparison.json")):
        rec = load(p)
        rows = rec["rows"]
        smart = next(lab for lab in rows if lab != "sto")
        f = rec["config"]["flow"]
        out[p.parent.name] = {"record": rec["record"], "n_flows": rec["n_flows"],
                              "n_swimmers": rec["n_swimmers"], "seed": rec["seed"],
                              "n_grid": f["n_grid"], "spacing": f["spacing"],
                              "box_over_ell_f": f["n_grid"] * f["spacing"],
                              "flow_stats": rec["flow_stats"],
                              "rows": {lab: stats(v) for lab, v in rows.items()},
                              "smart_vs_sto": paired(rows[smart], rows["sto"])}
    for name, o in out.items():
        # against the default box of the same size (default/ or default_100x200/)
        ref = out.get("default" + ("_100x200" if name.endswith("_100x200") else ""))
        if ref:
            o["reference"] = ref["record"]
            o["vs_default_unpaired"] = {
                lab: {"diff": s["mean"] - ref["rows"][lab]["mean"],
                      "diff_sem": math.hypot(s["sem"], ref["rows"][lab]["sem"]),
                      "rel_percent": 100 * (s["mean"] / ref["rows"][lab]["mean"] - 1),
                      "rel_percent_sem": 100 * math.hypot(s["sem"], ref["rows"][lab]["sem"])
                      / ref["rows"][lab]["mean"]}
                for lab, s in o["rows"].items() if lab in ref["rows"]}
            o["vs_default_unpaired"]["smart_vs_sto_ratio"] = {
                "diff": o["smart_vs_sto"]["ratio"] - ref["smart_vs_sto"]["ratio"],
                "diff_sem": math.hypot(o["smart_vs_sto"]["ratio_sem"],
                                       ref["smart_vs_sto"]["ratio_sem"])}
    return out


def main() -> None:
    summary = {"naive_scan": naive_scan(), "swim_speed": swim_speed(), "box": box()}
    path = HERE / "summary.json"
    path.write_text(json.dumps(summary, indent=1) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
