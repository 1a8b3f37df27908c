"""Tables of the three-seed records beside this script (minimal_fits/, robustness/, ablation_b/);
prints the markdown tables of README.md: ``python summarise.py [fits] [robustness] [ablation]``."""
# ruff: noqa: E501, E702
import json
import sys
from pathlib import Path

import numpy as np

R = Path(__file__).resolve().parent
KUS = ["0.1", "1", "10", "1e7"]
SHIPPED = {"0.1": 1, "1": 0, "10": 2, "1e7": 2}
C = ("c1", "c2", "c3", "c4")

def fits():
    print("### minimal fits (20 flows x 500, sample_every 20; ± SEM over flows)\n")
    print("| Ku | seed | c1 | c2 | c3 | c4 | R² | samples |")
    print("|---|---|---|---|---|---|---|---|")
    agg = {}
    for k in KUS:
        for s in (0, 1, 2):
            p = R / f"minimal_fits/ku{k}_seed{s}/fit.json"
            if not p.exists():
                print(f"| {k} | {s} | (missing) |||||"); continue
            f = json.loads(p.read_text())
            c, e = f["coefficients"], f["flow_sem"]
            agg.setdefault(k, []).append([c[x] for x in C])
            tag = f"{s}{' (shipped)' if SHIPPED[k] == s else ''}"
            print(f"| {k} | {tag} | " + " | ".join(f"{c[x]:.3f} ± {e[x]:.3f}" for x in C)
                  + f" | {f['r2']:.3f} | {f['n_samples']} |")
    print("\nmean ± std over the seeds:\n")
    print("| Ku | n seeds | c1 | c2 | c3 | c4 |")
    print("|---|---|---|---|---|---|")
    for k, v in agg.items():
        a = np.array(v)
        sd = a.std(0, ddof=1) if len(a) > 1 else np.zeros(4)
        print(f"| {k} | {len(a)} | " + " | ".join(f"{m:.3f} ± {d:.3f}" for m, d in zip(a.mean(0), sd, strict=False)) + " |")

def robustness():
    print("\n### robustness at Ku = 10 (20 flows x 500 per point; smart/STO paired ± SEM)\n")
    for fig, keys in (("robustness-noise", ["rot_diffusion"]),
                      ("robustness", ["duration", "update_interval", "swim_speed"])):
        for key in keys:
            rows = []
            for s in (0, 1, 2):
                p = R / f"robustness/ku10_seed{s}/{fig}.json"
                if not p.exists():
                    continue
                d = json.loads(p.read_text())["derived"][key]
                rows.append((s, d))
            if not rows:
                continue
            x = rows[0][1]["x"]
            print(f"\n**{key}** = {', '.join(f'{v:g}' for v in x)}\n")
            print("| seed | smart R̂ | STO R̂ | naive R̂ | smart / STO |")
            print("|---|---|---|---|---|")
            for s, d in rows:
                m = d["mean"]
                print(f"| {s}{' (shipped)' if s == 2 else ''} | " + ", ".join(f"{v:.3f}" for v in m["smart"])
                      + " | " + ", ".join(f"{v:.3f}" for v in m["STO"]) + " | "
                      + ", ".join(f"{v:.3f}" for v in m["naive"]) + " | "
                      + ", ".join(f"{v:.3f} ± {e:.3f}" for v, e in zip(d["smart/STO"], d["smart/STO_sem"], strict=False)) + " |")
            if key == "rot_diffusion":
                print("\nsmart change from D_r = 0 (paired per flow, ± SEM over flows):\n")
                for s, _ in rows:
                    rec = json.loads((R / f"robustness/ku10_seed{s}/{fig}.json").read_text())
                    ev = rec["evaluations"]
                    base = np.array(ev["rot_diffusion=0"]["per_flow"]["smart"])
                    out = []
                    for kk in list(ev)[1:]:
                        v = np.array(ev[kk]["per_flow"]["smart"])
                        r = v / base - 1
                        out.append(f"{kk.split('=')[1]}: {100*r.mean():+.1f} ± {100*r.std(ddof=1)/np.sqrt(len(r)):.1f} %")
                    print(f"- seed {s}: " + "; ".join(out))

def ablation():
    print("\n### ablation (b) (20 flows x 500 per strategy; paired ± SEM)\n")
    print("| Ku | seed | smart R̂ | minimal R̂ | STO R̂ | smart / STO | minimal / STO | minimal / smart |")
    print("|---|---|---|---|---|---|---|---|")
    for k in KUS:
        for s in (0, 1, 2):
            p = R / f"ablation_b/ku{k}_seed{s}/ablation.json"
            if not p.exists():
                continue
            d = json.loads(p.read_text())["derived"]["minimal"][f"ku{k}"]
            m, r = d["mean"], d["ratio"]
            print(f"| {k} | {s}{' (shipped)' if SHIPPED[k] == s else ''} | {m['smart']:.3f} | {m['minimal']:.3f} | {m['STO']:.3f} | "
                  + " | ".join(f"{r[x]['value']:.3f} ± {r[x]['sem']:.3f}" for x in ("smart/STO", "minimal/STO", "minimal/smart")) + " |")

for name in (sys.argv[1:] or ["fits", "robustness", "ablation"]):
    globals()[name]()
