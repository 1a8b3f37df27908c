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
    """Mean of the flows' ``measured_stats()`` (``u_rms``, ``tau_K``) over environments; a
    scale the flow does not have (None: a linear flow has no ``u_rms``) is recorded as null,
    with the reason under ``undefined``."""
    out: dict = {}
    undefined = []
    for key in ("u_rms", "tau_K"):
        values = [s[key] for s in stats]
        if any(v is None for v in values):
            out[key] = None
            undefined.append(key)
        else:
            out[key] = float(np.mean(values))
    out["note"] = f"grid averages at the end of each episode, {how}"
    if undefined:
        out["undefined"] = (f"{', '.join(undefined)}: the flow defines no such scale "
                            "(a linear flow has no velocity scale)")
    return out


def chunk_outcomes(outcomes: dict, block: slice, update_interval: float) -> dict:
    """One flow chunk's per-flow outcomes of the swimmers ``block`` (a strategy's block of
    the environment) from :meth:`~swimrl.env.SwimmerEnv.outcomes`: the per-flow means of
    ``energy``, ``shape_change``, ``swimming`` (``task=displacement``), for ``task=target`` of
    ``arrived`` and ``final_distance``, for ``task=vertical`` of ``trapped``; every arrived
    swimmer's arrival decision (``arrival_steps``, one list per flow: the pooled median is
    exact) and the swimmers per flow of the block (``swimmers_per_flow``, the denominator of
    the arrival-time distribution,
    :func:`outcome_statistics`)."""
    out = {}
    for key in ("energy", "shape_change", "swimming", "arrived", "final_distance", "trapped"):
        if key in outcomes:
            out[key] = outcomes[key][:, block].double().mean(dim=1).cpu().tolist()
    if "arrival_time" in outcomes:
        times = outcomes["arrival_time"][:, block].double().cpu().numpy()
        out["arrival_steps"] = [sorted(int(round(t / update_interval)) for t in row
                                       if np.isfinite(t)) for row in times]
        out["swimmers_per_flow"] = int(times.shape[1])
    return out


#: Points of the arrival-time CDF grid per episode (about; every ``N // 200`` decisions).
CDF_POINTS = 200


def outcome_statistics(chunks: Sequence[dict], update_interval: float,
                       n_decisions: int | None = None) -> dict:
    r"""A strategy's outcomes over all flows from its :func:`chunk_outcomes` of every chunk.

    ``energy_mean/std/sem`` (``E_hat``), ``shape_change_mean/std/sem`` (``C_hat``, where the
    chunks have it: records written before it do not), ``swimming_mean/std/sem`` (``S_hat``,
    ``task=displacement``, likewise), and for ``task=target``
    ``arrival_mean/std/sem`` (the arrival probability within ``T``) and
    ``final_distance_mean/std/sem`` (units ``ell_f``), for ``task=vertical``
    ``trapped_mean/std/sem`` (the trapped fraction), each with its ``*_per_flow`` values
    (mean, std, SEM over flows), and:

    * ``arrival_time_mean``, ``arrival_time_median``, ``n_arrived``: the mean and median
      arrival time of the arrived swimmers only (units ``tau_K``, pooled over all flows;
      None if none arrived). Conditional on arrival within ``T``: a strategy that brings
      few swimmers, the fastest, has a short median; kept for older records.

    Every swimmer is followed until its arrival or ``T = n_decisions x update_interval``:
    the arrival time is censored at ``T`` only (administratively, the same for all), so the
    empirical distribution ``F(t)`` = (swimmers arrived by ``t``) / (all swimmers) is the
    Kaplan-Meier estimate ``1 - S(t)`` of the arrival-time distribution. With
    ``n_decisions`` given and every chunk's ``swimmers_per_flow`` recorded (absent from the
    partial records written before it; then these keys are left out):

    * ``arrival_cdf_t``: the times of the grid (units ``tau_K``), every
      ``max(1, n_decisions // 200)`` decisions from that one to ``T`` (always included);
    * ``arrival_cdf_mean``, ``arrival_cdf_sem``: ``F(t)`` on that grid, the mean and SEM
      over flows of each flow's fraction arrived by ``t`` (every flow has the same swimmers:
      the mean is the pooled fraction; ``arrival_cdf_mean[-1] = arrival_mean``);
    * ``arrival_time_rmst_mean``, ``arrival_time_rmst_sem``: the restricted mean time to
      arrival ``E[min(t_arrival, T)]`` (units ``tau_K``; the not arrived count ``T``), per
      flow (exact from the arrival decisions), then mean and SEM over flows;
    * ``arrival_time_half``, ``arrival_time_quartile``: the censoring-aware median and first
      quartile, the earliest arrival time at which the pooled ``F`` reaches 0.5 (0.25),
      exact from the arrival decisions (not rounded to the grid); None if it does not
      within ``T``.

    Empty if a chunk has no outcomes (a partial record written before they existed).
    """
    if not chunks or any(not c for c in chunks):
        return {}
    out: dict = {}
    for key, name in (("energy", "energy"), ("shape_change", "shape_change"),
                      ("swimming", "swimming"), ("arrived", "arrival"),
                      ("final_distance", "final_distance"), ("trapped", "trapped")):
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
        if n_decisions is not None and all("swimmers_per_flow" in c for c in chunks):
            out.update(arrival_distribution(chunks, update_interval, int(n_decisions)))
    return out


def arrival_distribution(chunks: Sequence[dict], update_interval: float,
                         n_decisions: int) -> dict:
    """The arrival-time keys of :func:`outcome_statistics` (``arrival_cdf_*``,
    ``arrival_time_rmst_*``, ``arrival_time_half``, ``arrival_time_quartile``) from chunks
    with ``arrival_steps`` and ``swimmers_per_flow``."""
    every = max(1, n_decisions // CDF_POINTS)
    grid = np.arange(every, n_decisions + 1, every)
    if grid[-1] != n_decisions:
        grid = np.append(grid, n_decisions)
    flows = [(np.asarray(row, float), int(c["swimmers_per_flow"]))
             for c in chunks for row in c["arrival_steps"]]
    fractions = np.stack([np.searchsorted(np.sort(s), grid, side="right") / n
                          for s, n in flows])
    cdf = [mean_std_sem(fractions[:, i]) for i in range(grid.size)]
    rmst = [(s.sum() + (n - s.size) * n_decisions) * update_interval / n for s, n in flows]
    rmst_mean, _, rmst_sem = mean_std_sem(rmst)
    pooled = np.sort(np.concatenate([s for s, _ in flows]))
    total = sum(n for _, n in flows)

    def reached(q: float) -> float | None:
        """The earliest arrival time by which a fraction ``q`` of all swimmers arrived."""
        k = math.ceil(q * total)  # F(t) >= q once k swimmers arrived
        return float(pooled[k - 1] * update_interval) if 0 < k <= pooled.size else None

    return {"arrival_cdf_t": [float(g * update_interval) for g in grid],
            "arrival_cdf_mean": [m for m, _, _ in cdf],
            "arrival_cdf_sem": [e for _, _, e in cdf],
            "arrival_time_rmst_mean": rmst_mean, "arrival_time_rmst_sem": rmst_sem,
            "arrival_time_half": reached(0.5), "arrival_time_quartile": reached(0.25)}


def paired_difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """``<a - b>`` over paired flows and its SEM ``std(a - b) / sqrt(n)``."""
    d = np.asarray(a, float) - np.asarray(b, float)
    return float(d.mean()), (float(d.std(ddof=1) / math.sqrt(d.size)) if d.size > 1 else 0.0)
