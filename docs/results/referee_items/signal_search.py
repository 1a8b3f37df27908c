"""Referee item 4: the paper's search over "all three-signal combinations" (Sec. IV.C).

The paper: "we analyzed correlations between the learned control Lambda and all three-signal
combinations, identifying n_r, S_np, and omega as the dominant contributors to the policy"
(at Ku = 1e7; the measure is not stated). Here the measure is the fraction of the variance of
Lambda explained by its mean in cells of the subset's signals, cross-fitted between two
groups of flows (``swimrl.analysis.signal_relevance``: R^2_A, 10 quantile intervals per
signal), for every subset of one to four of the five signals.

Reads trajectories.npz records written by ``swimrl-eval ... strategy=policy eval.record=N``
(every decision of N swimmers per flow: the five signals and the action Lambda) and writes
one JSON: per record the R^2 of each subset, the number of decisions and the two flow groups
(the first and the second half of the flows), and the fraction of decisions with
sign(Lambda) = sign(Lambda_STO) = -sign(n_theta S_np) (where that is not 0); per label
prefix before ``_seed`` (the Ku) the mean and std over its records (the training seeds) and
the subsets of each size ranked by that mean.

Usage:  python signal_search.py OUT.json LABEL=RUN_DIR_OR_NPZ [LABEL=...]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from swimrl.analysis.signal_relevance import subset_search
from swimrl.evaluation.trajectories import load_trajectories

SIZES = (1, 2, 3, 4)
BINS = 10


def analyse(path: Path) -> dict:
    """R^2 of every subset of SIZES signals from one trajectories.npz."""
    z = load_trajectories(path)
    names = z["signal_names"]
    sig = np.asarray(z["signals"][:, 0], dtype=np.float64)  # (F, n, N, d): strategy block 0
    lam = np.asarray(z["Lambda"][:, 0], dtype=np.float64)  # (F, n, N)
    n_flows = sig.shape[0]
    if n_flows < 2:
        raise SystemExit(f"{path}: the flow groups need at least 2 flows, found {n_flows}")
    fold = np.broadcast_to((np.arange(n_flows) < n_flows // 2)[:, None, None], lam.shape)
    r2 = subset_search(lam.ravel(), sig.reshape(-1, sig.shape[-1]), names, fold.ravel(),
                       sizes=SIZES, bins=BINS)
    # STO's sign (eq:sto): sign(Lambda_STO) = -sign(n_theta S_np), where that is not 0
    sto = -np.sign(sig[..., names.index("n_theta")] * sig[..., names.index("S_np")])
    has = sto != 0
    agree = float((np.sign(lam[has]) == sto[has]).mean())
    return {"R2": r2, "n_decisions": int(lam.size), "n_flows": int(n_flows),
            "swimmers_per_flow": int(lam.shape[1]), "var_Lambda": float(lam.var()),
            "sign_agreement_STO": agree}


def of_size(keys: list[str], size: int) -> list[str]:
    """The subsets (``"a,b,c"``) of ``size`` signals among ``keys``."""
    return [k for k in keys if k.count(",") == size - 1]


def summarise(records: dict[str, dict]) -> dict:
    """Per Ku (the label before ``_seed``): mean and std of R^2 over seeds, ranked."""
    groups: dict[str, list[dict]] = {}
    for label, rec in records.items():
        groups.setdefault(label.split("_seed")[0], []).append(rec)
    out = {}
    for ku, recs in groups.items():
        keys = list(recs[0]["R2"])
        vals = {k: np.array([r["R2"][k] for r in recs]) for k in keys}
        mean = {k: float(v.mean()) for k, v in vals.items()}
        std = {k: float(v.std(ddof=1)) if v.size > 1 else 0.0 for k, v in vals.items()}
        ranked = {str(size): sorted(of_size(keys, size), key=lambda k: -mean[k])
                  for size in SIZES}
        agree = np.array([r["sign_agreement_STO"] for r in recs])
        out[ku] = {"n_seeds": len(recs), "R2_mean": mean, "R2_std": std, "ranked": ranked,
                   "sign_agreement_STO_mean": float(agree.mean()),
                   "sign_agreement_STO_std": float(agree.std(ddof=1)) if agree.size > 1 else 0.0,
                   "best_per_seed": {str(size): [max(of_size(keys, size),
                                                     key=lambda k, r=r: r["R2"][k])
                                                 for r in recs] for size in SIZES}}
    return out


def main(argv: list[str]) -> None:
    if len(argv) < 2:
        raise SystemExit(__doc__.strip().splitlines()[-1])
    out = Path(argv[0])
    records = {}
    for arg in argv[1:]:
        label, _, where = arg.partition("=")
        path = Path(where)
        if path.is_dir():
            path = path / "trajectories.npz"
        records[label] = {"source": where, **analyse(path)}
    result = {"measure": "cross-fitted R^2 of Lambda by its mean in cells of the subset "
                         f"({BINS} quantile intervals per signal; folds: first / second half "
                         "of the flows); swimrl.analysis.signal_relevance",
              "records": records, "by_ku": summarise(records)}
    out.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
