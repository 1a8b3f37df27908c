r"""Which signals a policy's action depends on: the variance of ``Lambda`` explained by subsets
of the signals (the paper's Sec. IV.C search over "all three-signal combinations").

For a subset ``A`` of the signals (e.g. ``(n_r, S_np, omega)``) the explained fraction is

``R^2_A = 1 - E[(Lambda - m_A(s_A))^2] / Var(Lambda)``,

with ``m_A(s_A) = <Lambda | s_A>`` the mean action in cells of ``s_A``: every signal of ``A``
cut at its own quantiles into ``bins`` equally filled intervals (the cells of a subset are the
products of these intervals). ``m_A`` is estimated on one group of flows and ``R^2_A``
measured on the other (two-fold cross-fitting, then the mean of the two folds; a cell empty in
the fitting fold predicts the fitting fold's mean), so that more cells cannot raise ``R^2`` by
fitting noise: ``R^2_A`` can be negative for a subset that carries no information. It is at
most 1 (the action a function of ``s_A`` alone, up to the cells' resolution); two subsets are
compared at the same ``bins``.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations

import numpy as np


def quantile_cells(x: np.ndarray, bins: int) -> np.ndarray:
    """Index in ``0 .. bins-1`` of each value of ``x`` among ``bins`` intervals cut at the
    quantiles ``k / bins`` of ``x`` (ties go to the lower interval)."""
    edges = np.quantile(x, np.arange(1, bins) / bins)
    return np.searchsorted(edges, x, side="left")


def cell_index(signals: np.ndarray, subset: Sequence[int], bins: int,
               columns: Sequence[np.ndarray] | None = None) -> np.ndarray:
    """Flat cell index ``sum_k c_k bins^k`` of each decision in the signals ``subset``
    (columns of ``signals``, ``(n, d)``), ``c_k`` from :func:`quantile_cells` (or taken from
    ``columns``, every column's :func:`quantile_cells` computed once)."""
    idx = np.zeros(len(signals), dtype=np.int64)
    for col in subset:
        c = columns[col] if columns is not None else quantile_cells(signals[:, col], bins)
        idx = idx * bins + c
    return idx


def explained_fraction(lam: np.ndarray, signals: np.ndarray, subset: Sequence[int],
                       fold: np.ndarray, bins: int = 10) -> float:
    """Cross-fitted ``R^2_A`` of ``Lambda`` by ``<Lambda | s_A>`` (the module docstring).

    Parameters
    ----------
    lam, signals
        The decisions: ``(n,)`` actions at ``(n, d)`` signals.
    subset
        Columns of ``signals`` (``A``).
    fold
        ``(n,)`` booleans: the two groups (e.g. by flow, so that correlated decisions of one
        trajectory stay in one group); each must hold decisions.
    bins
        Quantile intervals per signal.
    """
    signals = np.asarray(signals, dtype=np.float64)
    cells = cell_index(signals, subset, bins)
    return _cross_fitted(np.asarray(lam, dtype=np.float64), cells, bins ** len(subset), fold)


def _cross_fitted(lam: np.ndarray, cells: np.ndarray, n_cells: int, fold) -> float:
    """:func:`explained_fraction` from each decision's cell index ``cells``."""
    fold = np.asarray(fold, dtype=bool)
    if fold.all() or not fold.any():
        raise ValueError("explained_fraction needs decisions in both folds")
    scores = []
    for fit in (fold, ~fold):
        test = ~fit
        sums = np.bincount(cells[fit], weights=lam[fit], minlength=n_cells)
        counts = np.bincount(cells[fit], minlength=n_cells)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(counts > 0, sums / counts, lam[fit].mean())
        resid = lam[test] - mean[cells[test]]
        var = np.var(lam[test])
        if var == 0:
            raise ValueError("explained_fraction: Lambda is constant in a fold (no variance "
                             "to explain)")
        scores.append(1.0 - np.mean(resid ** 2) / var)
    return float(np.mean(scores))


def subset_search(lam: np.ndarray, signals: np.ndarray, names: Sequence[str],
                  fold: np.ndarray, sizes: Sequence[int] = (1, 2, 3),
                  bins: int = 10) -> dict[str, float]:
    """:func:`explained_fraction` of every subset of ``sizes`` signals, keyed by the names
    joined with ``,`` (``"n_r,S_np,omega"``), subsets in the order of ``names``."""
    lam = np.asarray(lam, dtype=np.float64)
    signals = np.asarray(signals, dtype=np.float64)
    columns = [quantile_cells(signals[:, j], bins) for j in range(len(names))]  # once each
    out = {}
    for k in sizes:
        for sub in combinations(range(len(names)), k):
            cells = cell_index(signals, sub, bins, columns)
            out[",".join(names[i] for i in sub)] = _cross_fitted(lam, cells, bins ** k, fold)
    return out
