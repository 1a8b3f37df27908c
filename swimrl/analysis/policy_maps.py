r"""What a policy does, from its recorded decisions: binned policy maps and the S_nn statistic.

* :func:`binned_mean`: ``<Lambda | s_1, s_2>`` (or ``<Lambda | s_1>``), the mean action in bins
  of one or two signals, with the counts per bin (NaN where a bin is empty or has fewer than
  ``min_count`` samples): the paper's Figs. "kuInf" and "ku_pattern".
* :func:`lambda_maps`: ``<Lambda | S_np, n_theta>`` and ``<Lambda | S_np, omega>``, the maps of
  Figs. "ku_pattern" and "dnsFlow" (d), (e).
* :func:`snn_extremes`: among the fraction ``q`` most negative values of ``S_nn``, the
  probability of ``Lambda > 0``; among the fraction ``q`` most positive, of ``Lambda < 0``
  (paper Sec. IV: 82 % for ``q = 1 %`` at Ku = 10^7).

Recorded signals are arrays ``(..., 5)`` in the order of
:data:`~swimrl.physics.body2d.SIGNAL_NAMES` (:data:`SIGNAL`: a name's position).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from swimrl.physics.body2d import SIGNAL_NAMES

#: Position of each signal in the last axis of a recorded ``signals`` array.
SIGNAL = {name: i for i, name in enumerate(SIGNAL_NAMES)}


def binned_mean(
    values: np.ndarray,
    coords: Sequence[np.ndarray],
    bins: int | Sequence[int] = 40,
    ranges: Sequence[tuple[float, float]] | None = None,
    min_count: int = 1,
) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """Mean of ``values`` in bins of one or two ``coords`` (same length as ``values``).

    Returns ``(mean, edges, counts)``: ``mean`` and ``counts`` have one axis per coordinate
    (``mean[i, j]`` is the bin ``edges[0][i:i+2] x edges[1][j:j+2]``); samples outside
    ``ranges`` (default: the data's range) are dropped.
    """
    values = np.asarray(values, dtype=np.float64).ravel()
    coords = [np.asarray(c, dtype=np.float64).ravel() for c in coords]
    if not 1 <= len(coords) <= 2:
        raise ValueError(f"binned_mean takes one or two coordinates, not {len(coords)}")
    if ranges is None:
        ranges = [(float(c.min()), float(c.max())) for c in coords]
    nbins = [bins] * len(coords) if np.isscalar(bins) else list(bins)
    sums, edges = np.histogramdd(np.stack(coords, -1), bins=nbins, range=ranges,
                                 weights=values)
    counts, _ = np.histogramdd(np.stack(coords, -1), bins=nbins, range=ranges)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts
    mean[counts < max(1, min_count)] = np.nan
    return mean, list(edges), counts


def symmetric_range(x: np.ndarray, q: float = 0.995) -> tuple[float, float]:
    """Symmetric range covering the central ``q`` of ``|x|``."""
    m = float(np.quantile(np.abs(x), q)) or 1.0
    return (-m, m)


def lambda_maps(signals: np.ndarray, lam: np.ndarray,
                bins: int = 30) -> dict[str, tuple[np.ndarray, list[np.ndarray]]]:
    """``<Lambda | S_np, n_theta>`` and ``<Lambda | S_np, omega>`` of the decisions ``lam``
    taken at ``signals`` ``(..., 5)``: S_np and omega over their symmetric 99.5 % range
    (:func:`symmetric_range`), n_theta over ``[-1, 1]``, at least 5 samples per bin;
    ``{"n_theta": (mean, edges), "omega": (mean, edges)}`` as :func:`binned_mean` returns
    them (``mean`` ``(bins, bins)``, S_np along its first axis)."""
    s = signals.reshape(-1, 5)
    s_np = s[:, SIGNAL["S_np"]]
    out = {}
    omega = symmetric_range(s[:, SIGNAL["omega"]])
    for other, rng in (("n_theta", (-1.0, 1.0)), ("omega", omega)):
        mean, edges, _ = binned_mean(lam, [s_np, s[:, SIGNAL[other]]], bins=bins,
                                     ranges=[symmetric_range(s_np), rng], min_count=5)
        out[other] = (mean, edges)
    return out


def snn_extremes(snn: np.ndarray, lam: np.ndarray, q: float = 0.01) -> dict[str, float]:
    """``P(Lambda > 0 | S_nn in its lowest q)`` and ``P(Lambda < 0 | S_nn in its highest q)``,
    with the quantile thresholds and the sample counts."""
    snn, lam = np.asarray(snn).ravel(), np.asarray(lam).ravel()
    lo, hi = np.quantile(snn, [q, 1 - q])
    low, high = snn <= lo, snn >= hi
    return {"q": q, "S_nn_low": float(lo), "S_nn_high": float(hi),
            "p_pos_given_low": float(np.mean(lam[low] > 0)),
            "p_neg_given_high": float(np.mean(lam[high] < 0)),
            "n_low": int(low.sum()), "n_high": int(high.sum()), "n": int(snn.size)}
