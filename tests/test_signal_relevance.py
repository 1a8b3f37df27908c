"""The signal-subset search (swimrl.analysis.signal_relevance) on synthetic decisions whose
dependence on the signals is known."""

import numpy as np
import pytest

from swimrl.analysis.signal_relevance import explained_fraction, quantile_cells, subset_search

NAMES = ("a", "b", "c", "d", "e")


def synthetic(n: int = 200_000, seed: int = 0):
    """Five independent signals uniform in [-1, 1]; Lambda = tanh(3 a c) + e / 2 + noise."""
    rng = np.random.default_rng(seed)
    s = rng.uniform(-1, 1, (n, 5))
    lam = np.tanh(3 * s[:, 0] * s[:, 2]) + 0.5 * s[:, 4] + 0.05 * rng.standard_normal(n)
    fold = np.arange(n) < n // 2
    return lam, s, fold


def test_quantile_cells_are_equally_filled():
    x = np.random.default_rng(1).standard_normal(10_000)
    counts = np.bincount(quantile_cells(x, 8), minlength=8)
    assert counts.sum() == 10_000 and counts.min() >= 1240 and counts.max() <= 1260


def test_one_signal_explains_its_share_of_the_variance():
    lam, s, fold = synthetic()
    # e alone: Var(e/2) / Var(Lambda), less the variance of e/2 within a cell (width 0.2)
    total = np.var(lam)
    expected = (0.25 / 3 - 0.25 * 0.2 ** 2 / 12) / total
    assert explained_fraction(lam, s, [4], fold) == pytest.approx(expected, abs=0.01)
    # an unrelated signal explains nothing (cross-fitted: about 0, not the cells' count / n)
    assert abs(explained_fraction(lam, s, [1], fold)) < 0.002
    assert abs(explained_fraction(lam, s, [1, 3], fold)) < 0.003


def test_the_search_ranks_the_true_triple_first():
    lam, s, fold = synthetic()
    r2 = subset_search(lam, s, NAMES, fold, sizes=(3,))
    assert len(r2) == 10
    best = max(r2, key=r2.get)
    assert best == "a,c,e" and r2[best] > 0.9
    # the pair (a, c) holds the product, most of the variance; e adds its share
    pair = subset_search(lam, s, NAMES, fold, sizes=(2,))["a,c"]
    assert 0.5 < pair < r2[best] - 0.1


def test_both_folds_must_hold_decisions():
    lam, s, _ = synthetic(100)
    with pytest.raises(ValueError, match="both folds"):
        explained_fraction(lam, s, [0], np.ones(100, dtype=bool))
