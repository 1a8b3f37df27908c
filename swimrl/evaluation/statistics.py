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


def chunk_outcomes(outcomes: dict, block: slice, update_interval: float) -> dict:
    """One flow chunk's per-flow outcomes of the swimmers ``block`` (a strategy's block of
    the environment) from :meth:`~swimrl.env.SwimmerEnv.outcomes`: the per-flow means of
    ``energy`` and, for ``task=target``, of ``arrived`` and ``final_distance``, and every
    arrived swimmer's arrival decision (``arrival_steps``, one list per flow: the pooled
    median is exact)."""
    out = {}
    for key in ("energy", "arrived", "final_distance"):
        if key in outcomes:
            out[key] = outcomes[key][:, block].double().mean(dim=1).cpu().tolist()
    if "arrival_time" in outcomes:
        times = outcomes["arrival_time"][:, block].double().cpu().numpy()
        out["arrival_steps"] = [sorted(int(round(t / update_interval)) for t in row
                                       if np.isfinite(t)) for row in times]
    return out


def outcome_statistics(chunks: Sequence[dict], update_interval: float) -> dict:
    """A strategy's outcomes over all flows from its :func:`chunk_outcomes` of every chunk:
    ``energy_mean/std/sem`` (``E_hat``), and for ``task=target`` ``arrival_mean/std/sem``
    (the arrival probability within ``T``), ``final_distance_mean/std/sem`` (units
    ``ell_f``), each with its ``*_per_flow`` values, and the mean and median arrival time of
    the arrived (units ``tau_K``, pooled over all flows; None if none arrived). Empty if a
    chunk has no outcomes (a partial record written before they existed)."""
    if not chunks or any(not c for c in chunks):
        return {}
    out: dict = {}
    for key, name in (("energy", "energy"), ("arrived", "arrival"),
                      ("final_distance", "final_distance")):
        if key in chunks[0]:
            per_flow = [x for c in chunks for x in c[key]]
            mean, std, sem = mean_std_sem(per_flow)
            out.update({f"{name}_mean": mean, f"{name}_std": std, f"{name}_sem": sem,
                        f"{name}_per_flow": per_flow})
    if "arrival_steps" in chunks[0]:
        steps = np.asarray([s for c in chunks for row in c["arrival_steps"] for s in row], float)
        out["arrival_time_mean"] = float(steps.mean() * update_interval) if steps.size else None
        out["arrival_time_median"] = (float(np.median(steps) * update_interval)
                                      if steps.size else None)
        out["n_arrived"] = int(steps.size)
    return out


def paired_difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """``<a - b>`` over paired flows and its SEM ``std(a - b) / sqrt(n)``."""
    d = np.asarray(a, float) - np.asarray(b, float)
    return float(d.mean()), (float(d.std(ddof=1) / math.sqrt(d.size)) if d.size > 1 else 0.0)
