r"""Statistics of ``R_hat`` over flow realisations (and over runs).

A flow realisation is the independent unit: its ``S`` swimmers share the flow, so the
per-flow mean ``R_f = <R_hat>_swimmers`` is the sample and

``R_hat_mean = <R_f>``,  ``R_hat_std = std(R_f)`` (``ddof = 1``),  ``R_hat_sem = std / sqrt(n)``.

Two strategies evaluated on the same flows (common random numbers) are compared by the
paired ratio ``r = <a> / <b>`` with the delta-method standard error
``SEM(r) = std(a - r b) / (sqrt(n) <b>)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def mean_std_sem(values: Sequence[float]) -> tuple[float, float, float]:
    """``(mean, std (ddof = 1; 0 for one value), std / sqrt(n))``."""
    arr = np.asarray(values, dtype=float)
    std = float(arr.std(ddof=1)) if arr.size > 1 else 0.0
    return float(arr.mean()), std, std / math.sqrt(arr.size)


def flow_statistics(per_flow: list[float]) -> dict:
    """``R_hat_mean``, ``R_hat_std``, ``R_hat_sem`` and ``per_flow`` from the per-flow means."""
    mean, std, sem = mean_std_sem(per_flow)
    return {"R_hat_mean": mean, "R_hat_std": std, "R_hat_sem": sem, "per_flow": list(per_flow)}


def paired_ratio(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """``<a>/<b>`` over paired flows and its delta-method SEM ``std(a - r b) / (sqrt(n) <b>)``."""
    r = float(a.mean() / b.mean())
    sem = float((a - r * b).std(ddof=1) / math.sqrt(a.size) / b.mean()) if a.size > 1 else 0.0
    return r, sem


def mean_flow_stats(stats: list[dict], how: str) -> dict:
    """Mean of the flows' ``measured_stats()`` (``u_rms``, ``tau_K``) over environments."""
    return {
        "u_rms": float(np.mean([s["u_rms"] for s in stats])),
        "tau_K": float(np.mean([s["tau_K"] for s in stats])),
        "note": f"grid averages at the end of each episode, {how}",
    }
