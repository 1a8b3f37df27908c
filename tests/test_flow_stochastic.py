"""Statistics of the stochastic flow against the analytic model (paper Sec. II B)."""

from __future__ import annotations

import math

import pytest
import torch

from swimrl.flows.base import gradient_norm2
from swimrl.flows.grid import PeriodicGrid
from swimrl.flows.stochastic import (
    TAU_K,
    StochasticFlow,
    band_limit,
    gaussian_spectrum,
    stream_function_channels,
)


def test_discrete_spectrum_has_the_analytic_moments():
    """E[<u.u>] = 1, E[<S_xx^2>] = E[<S_xy^2>] = 1/2, E[<omega^2>] = 4 exactly (no sampling)."""
    flow = StochasticFlow(1, 10.0, n_grid=128, spacing=0.1, dtype=torch.float64)
    p = gaussian_spectrum(flow.grid, 0.5, 1.0, "cpu")
    kx, ky = flow.grid.wavenumbers()
    n4 = flow.grid.n**4  # E|FFT(psi)|^2 = N^2 P; grid mean of f^2 = sum |f_hat|^2 / N^4

    def moment(w):
        return float((w * p).sum() * flow.grid.n**2 / n4)

    assert moment(kx**2 + ky**2) == pytest.approx(1.0, rel=1e-9)  # <u.u>
    assert moment((kx * ky) ** 2) == pytest.approx(0.5, rel=1e-9)  # <S_xx^2> = <psi_xy^2>
    assert moment(0.25 * (ky**2 - kx**2) ** 2) == pytest.approx(0.5, rel=1e-9)
    assert moment((kx**2 + ky**2) ** 2) == pytest.approx(4.0, rel=1e-9)  # <omega^2>
    tau_k = moment(2 * (kx * ky) ** 2 + 0.5 * (ky**2 - kx**2) ** 2 + 0.5 * (kx**2 + ky**2) ** 2)
    assert tau_k**-0.5 == pytest.approx(TAU_K, rel=1e-9)


def test_sampled_fields_match_the_model_moments():
    """Monte Carlo over 16 flows x 5 components: u_rms = 1, tau_K = 1/2 within 3 sigma."""
    gen = torch.Generator().manual_seed(1)
    flow = StochasticFlow(16, 10.0, n_grid=128, spacing=0.1, dtype=torch.float64, generator=gen)
    b = flow.basis  # (F, n, n, M, 5): each component has <c^2> = 1 weight here
    u2 = (b[..., 0] ** 2 + b[..., 1] ** 2).mean().item()
    a2 = gradient_norm2(b).mean().item()
    # ~ L^2 / (2 pi ell^2) = 26 independent areas per field, 80 fields -> ~4% on a variance
    assert u2 == pytest.approx(1.0, rel=0.12)
    assert a2**-0.5 == pytest.approx(TAU_K, rel=0.06)
    stats = flow.measured_stats()  # with the random c_i(0): noisier, but same scale
    assert 0.5 < stats["u_rms"] < 1.5 and 0.3 < stats["tau_K"] < 0.8


def test_velocity_correlation_is_the_gaussian_model():
    """<u_x(x) u_x(x + r e_x)> = e^{-r^2/2}/2, <u_x(x) u_x(x + r e_y)> = (1 - r^2) e^{-r^2/2}/2."""
    gen = torch.Generator().manual_seed(2)
    flow = StochasticFlow(8, 10.0, n_grid=128, spacing=0.1, dtype=torch.float64, generator=gen)
    ux = flow.basis[..., 0].permute(0, 3, 1, 2).reshape(-1, 128, 128)  # (F M, ny, nx)
    spec = torch.fft.fft2(ux).abs() ** 2
    corr = torch.fft.ifft2(spec).real.mean(0) / 128**2  # circular autocorrelation, [dy, dx]
    r = torch.arange(0, 25, dtype=torch.float64) * 0.1
    along_x = corr[0, :25]
    along_y = corr[:25, 0]
    assert torch.allclose(along_x, 0.5 * torch.exp(-(r**2) / 2), atol=0.05)
    assert torch.allclose(along_y, 0.5 * (1 - r**2) * torch.exp(-(r**2) / 2), atol=0.05)


def test_velocity_is_divergence_free_and_gradients_are_consistent():
    """d_x u_x + d_y u_y = 0; S and omega match 4th-order finite differences of u to 1e-3."""
    gen = torch.Generator().manual_seed(3)
    flow = StochasticFlow(1, 10.0, n_grid=256, spacing=0.05, dtype=torch.float64, generator=gen)
    q = flow.basis[0, :, :, 0]  # (ny, nx, 5)
    h = flow.grid.spacing

    def d(f, dim):  # fourth-order central difference, error ~ (k h)^4 / 30
        r = torch.roll
        return (8 * (r(f, -1, dim) - r(f, 1, dim)) - (r(f, -2, dim) - r(f, 2, dim))) / (12 * h)

    def ddx(f):
        return d(f, 1)

    def ddy(f):
        return d(f, 0)

    ux, uy = q[..., 0], q[..., 1]
    scale = q[..., 4].abs().max()
    assert (ddx(ux) + ddy(uy)).abs().max() < 1e-3 * scale
    assert torch.allclose(ddx(ux), q[..., 2], atol=1e-3 * scale)
    assert torch.allclose(0.5 * (ddy(ux) + ddx(uy)), q[..., 3], atol=1e-3 * scale)
    assert torch.allclose(ddx(uy) - ddy(ux), q[..., 4], atol=1e-3 * scale)


def test_ou_coefficients_have_exponential_time_correlation():
    """<c_i(t) c_j(t + s)> = delta_ij / M exp(-s / tau_f), stationary variance 1/M."""
    gen = torch.Generator().manual_seed(4)
    kubo, dt = 0.5, 0.05
    flow = StochasticFlow(4000, kubo, n_grid=4, spacing=0.25, dtype=torch.float64, generator=gen)
    c0 = flow.coeffs.clone()
    path = flow.coefficient_path(30, dt)  # (31, F, M)
    m = flow.n_basis
    for lag in (0, 5, 10, 20, 30):
        corr = (c0 * path[lag]).mean().item()
        expected = math.exp(-lag * dt / kubo) / m
        assert corr == pytest.approx(expected, abs=4 * 1.5 / m / math.sqrt(c0.numel()))
    cross = (c0[:, 0] * path[10][:, 1]).mean().item()
    assert abs(cross) < 4 / m / math.sqrt(c0.shape[0])
    assert path[-1].var().item() == pytest.approx(1 / m, rel=0.05)


def test_huge_kubo_is_frozen():
    gen = torch.Generator().manual_seed(5)
    flow = StochasticFlow(2, 1e7, n_grid=16, spacing=0.25, generator=gen)
    c0 = flow.coeffs.clone()
    flow.coefficient_path(20000, 0.005)  # one full episode of T = 200 tau_K
    assert torch.allclose(flow.coeffs, c0, atol=5e-3 * c0.abs().max())


@pytest.mark.parametrize("n_grid, spacing", [(128, 0.1), (400, 0.025)])
def test_band_limited_synthesis_equals_the_full_fft(n_grid, spacing):
    """The direct sums over |m| <= K give IFFT(mult sqrt(P) FFT(w)) of the same white field
    to float64 round-off (the dropped modes weigh <= 1e-13), for every channel."""
    flow = StochasticFlow(1, 10.0, n_grid=n_grid, spacing=spacing, dtype=torch.float64)
    assert flow._synthesis is not None
    w = torch.randn(2, 3, n_grid, n_grid, dtype=torch.float64,
                    generator=torch.Generator().manual_seed(4))
    full = stream_function_channels(flow._sqrt_spectrum * torch.fft.fft2(w), flow.grid)
    full = full.permute(0, 2, 3, 1, 4)  # the basis layout (B, n_y, n_x, M, 5)
    fast = flow._synthesis(w)
    scale = full.abs().amax(dim=(0, 1, 2, 3))
    assert ((fast - full).abs().amax(dim=(0, 1, 2, 3)) / scale).max() < 1e-12


def test_redraw_is_the_same_realisation_as_the_fft_path():
    """Same generator state -> the same float32 fields whichever synthesis draws them."""
    fields = []
    for fast in (True, False):
        gen = torch.Generator().manual_seed(2)
        flow = StochasticFlow(3, 1.0, n_grid=128, spacing=0.1, generator=gen)
        if not fast:
            flow._synthesis = None
        flow.reset()
        fields.append((flow.basis.clone(), flow.coeffs.clone()))
    (b1, c1), (b2, c2) = fields
    assert torch.equal(c1, c2)
    torch.testing.assert_close(b1, b2, rtol=0, atol=2e-6 * float(b2.abs().max()))


def test_band_limit_needs_resolved_modes():
    """K = 18 of 200 at the default L = 10, n = 400; None on a grid that resolves no cut-off."""
    assert band_limit(PeriodicGrid(400, 10.0), 1.0) == 18
    assert band_limit(PeriodicGrid(16, 8.0), 1.0) is None
