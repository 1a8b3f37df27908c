"""Spectral grid of the DNS: the 2/3 de-aliasing mask and Parseval sums."""

from __future__ import annotations

import itertools

import pytest
import torch

from swimrl.flows.dns.grid import SpectralGrid, dealias_cutoff

torch.set_num_threads(1)


@pytest.mark.parametrize("n", [8, 32, 48, 64, 512])
def test_mask_keeps_exactly_modes_with_3m_less_than_n(n):
    """Retained set == {(m_x, m_y): 3|m_x| < N and 3|m_y| < N} (square truncation)."""
    g = SpectralGrid(n, dtype=torch.float64)
    K = dealias_cutoff(n)
    assert max(m for m in range(n) if 3 * m < n) == K
    my = torch.fft.fftfreq(n, d=1.0 / n).long()
    mx = torch.fft.rfftfreq(n, d=1.0 / n).long()
    kept = {(int(my[i]), int(mx[j])) for i, j in zip(*torch.nonzero(g.mask, as_tuple=True),
                                                      strict=True)}
    expected = {(a, b) for a in range(-K, K + 1) for b in range(0, K + 1)}
    assert kept == expected
    assert int(g.mask.sum()) == (2 * K + 1) * (K + 1)
    # Nyquist row/column are never kept; K is the largest alias-free cutoff: N - 2K > K
    assert n - 2 * K > K and n - 2 * (K + 1) <= K + 1


def test_cutoff_values():
    assert dealias_cutoff(512) == 170
    assert dealias_cutoff(64) == 21
    assert dealias_cutoff(48) == 15


def _random_truncated(g: SpectralGrid, seed: int) -> torch.Tensor:
    gen = torch.Generator().manual_seed(seed)
    f = torch.randn(g.n, g.n, generator=gen, dtype=torch.float64)
    return g.truncate(g.to_spectral(f))


def test_truncated_product_is_alias_free():
    """P_K[a b] on N nodes equals the exact product (on 2N nodes, no aliasing) truncated to K."""
    n = 24
    g = SpectralGrid(n, dtype=torch.float64)
    a_hat, b_hat = _random_truncated(g, 0), _random_truncated(g, 1)
    prod = g.truncate(g.to_spectral(g.to_physical(a_hat) * g.to_physical(b_hat)))
    # exact: zero-pad to 2N (>= 2K+1 + K modes needed), multiply, bring back
    big = SpectralGrid(2 * n, dtype=torch.float64)
    K = g.cutoff

    def pad(f_hat):
        out = torch.zeros(big.spectral_shape, dtype=f_hat.dtype)
        for my, mx in itertools.product(range(-K, K + 1), range(K + 1)):
            out[my % (2 * n), mx] = f_hat[my % n, mx]
        return out * 4  # unnormalised DFT: coefficients scale with N^2

    exact_big = big.to_spectral(big.to_physical(pad(a_hat)) * big.to_physical(pad(b_hat)))
    exact = torch.zeros_like(prod)
    for my, mx in itertools.product(range(-K, K + 1), range(K + 1)):
        exact[my % n, mx] = exact_big[my % (2 * n), mx] / 4
    assert torch.allclose(prod, exact, rtol=0, atol=1e-10 * exact.abs().max())


def test_mean_product_is_parseval():
    """<a b> from the half-plane spectral sum equals the node average."""
    g = SpectralGrid(16, dtype=torch.float64)
    gen = torch.Generator().manual_seed(3)
    a, b = torch.randn(2, 16, 16, generator=gen, dtype=torch.float64)
    val = g.mean_product(g.to_spectral(a), g.to_spectral(b))
    assert torch.allclose(val, (a * b).mean(), rtol=1e-13, atol=0)


def test_wavenumbers_follow_fft_order_and_box_length():
    g = SpectralGrid(8, length=4.0, dtype=torch.float64)
    assert g.ky[:, 0].tolist() == pytest.approx([m * 2 * torch.pi / 4 for m in
                                                 (0, 1, 2, 3, -4, -3, -2, -1)])
    assert g.kx[0].tolist() == pytest.approx([m * 2 * torch.pi / 4 for m in range(5)])
    assert g.spacing == 0.5
    assert g.k_max == pytest.approx(2 * torch.pi / 4 * 2)
