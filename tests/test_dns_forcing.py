"""Stochastic forcing and the energy/enstrophy budgets of the DNS."""

from __future__ import annotations

import math

import pytest
import torch

from swimrl.flows.dns import DNS, DNSParams, DNSState, SpectralGrid, random_state
from swimrl.flows.dns import diagnostics as dg
from swimrl.flows.dns.forcing import StochasticForcing, forcing_shape

torch.set_num_threads(1)


@pytest.mark.parametrize(("n", "k_f", "width"), [(32, 3.0, 0.5), (64, 4.0, 1.0), (16, 2.0, 0.3)])
def test_injection_rate_formula_is_epsilon(n, k_f, width):
    p = DNSParams(n=n, epsilon=0.37, k_f=k_f, forcing_width=width, dtype="float64")
    f = StochasticForcing(SpectralGrid(n, dtype=torch.float64), p, [0])
    assert f.injection_rate() == pytest.approx(0.37, rel=1e-13)
    # enstrophy injection = epsilon <k^2>, with <.> weighted by F(k)/k^2: close to k_f^2
    assert f.enstrophy_injection_rate() == pytest.approx(0.37 * k_f**2, rel=0.15)


def test_forcing_is_real_isotropic_and_peaked_at_kf():
    n = 32
    p = DNSParams(n=n, epsilon=1.0, k_f=3.0, forcing_width=0.5, dtype="float64", dt=1e-2)
    g = SpectralGrid(n, dtype=torch.float64)
    forcing = StochasticForcing(g, p, [1, 2])
    f_hat = forcing.draw(p.dt)
    # Hermitian on the m_x = 0 column: the real field transforms back to the same f_hat
    back = g.to_spectral(g.to_physical(f_hat))
    assert torch.allclose(back, f_hat, atol=1e-12 * f_hat.abs().max())
    shape = forcing_shape(g, 3.0, 0.5)
    assert (f_hat[:, shape == 0] == 0).all()
    assert (f_hat[..., 0, 0] == 0).all()
    # the forcing amplitude depends on |k| only and peaks on the |k| = 3 shell
    k = g.k_magnitude()
    sig = forcing.sigma_full
    for kk in (math.sqrt(5), 3.0, math.sqrt(10)):
        vals = sig[(k - kk).abs() < 1e-9]
        assert torch.allclose(vals, vals[0].expand_as(vals))
    assert float(sig[(k - 3).abs() < 1e-9][0]) == pytest.approx(float(sig.max()))


def test_forcing_variance_and_whiteness():
    """E|f_hat_k|^2 dt = sigma_k^2 and successive draws are uncorrelated (Monte Carlo)."""
    n, draws = 16, 4000
    p = DNSParams(n=n, epsilon=1.0, k_f=2.0, forcing_width=0.5, dtype="float64", dt=0.01)
    g = SpectralGrid(n, dtype=torch.float64)
    forcing = StochasticForcing(g, p, [5])
    f = torch.stack([forcing.draw(p.dt)[0] for _ in range(draws)])  # (draws, n, n//2+1)
    var = (f.abs() ** 2).mean(0) * p.dt
    s2 = forcing.sigma_full**2
    on = s2 > 1e-6 * s2.max()
    rel = (var[on] / s2[on] - 1).abs()
    assert rel.max() < 5 * math.sqrt(1 / draws) * 3  # chi^2_2 relative std 1/sqrt(draws)
    lag = (f[1:] * f[:-1].conj()).mean(0).abs() * p.dt
    assert (lag[on] / s2[on]).max() < 0.1


def test_rng_state_roundtrip_reproduces_draws():
    p = DNSParams(n=16, epsilon=1.0, k_f=2.0, dtype="float64")
    g = SpectralGrid(16, dtype=torch.float64)
    a = StochasticForcing(g, p, [3, 4])
    a.draw(p.dt)
    state = a.get_rng_state()
    x = a.draw(p.dt)
    b = StochasticForcing(g, p, [0, 0])
    b.set_rng_state(state)
    assert torch.equal(b.draw(p.dt), x)


def test_mean_injection_rate_is_epsilon_independent_of_state():
    """Ito: P = <psi_n f> + (1/2)<(psi_{n+1} - psi_n) f>; the first (martingale) term has zero
    mean whatever the state, the second has mean epsilon. Ensemble of B realisations started
    from the same turbulent-like state; 4 standard errors (SE ~ 0.4% for the second term)."""
    B, n, eps = 4000, 16, 1.0
    p = DNSParams(n=n, nu=1e-2, alpha=0.3, epsilon=eps, k_f=3.0, dt=1e-2, dtype="float64")
    g = SpectralGrid(n, dtype=torch.float64)
    w = random_state(g, [0], 2.0, 3.0).omega_hat.expand(B, -1, -1).clone()
    dns = DNS(p, seeds=list(range(B)), state=DNSState(w))
    w0 = dns.state.omega_hat.clone()
    dns.step()
    w1, f = dns.state.omega_hat, dns.last_forcing
    ito = dg.energy_injection_rate(g, w0, f)
    total = dg.energy_injection_rate(g, 0.5 * (w0 + w1), f)
    corr = total - ito

    def se(x):
        return float(x.std()) / math.sqrt(B)

    assert abs(float(ito.mean())) < 4 * se(ito)
    assert abs(float(corr.mean()) - eps) < 4 * se(corr)
    assert se(corr) < 0.01 * eps
    assert abs(float(total.mean()) - eps) < 4 * se(total)
    # enstrophy: the same with <omega f>, mean eta_in = forcing.enstrophy_injection_rate()
    z_mid = dg.enstrophy_injection_rate(g, 0.5 * (w0 + w1), f)
    z_corr = z_mid - dg.enstrophy_injection_rate(g, w0, f)
    eta = dns.forcing.enstrophy_injection_rate()
    assert abs(float(z_corr.mean()) - eta) < 4 * se(z_corr)


def _budget_residuals(dt: float, steps: int, epsilon: float = 1.0):
    """Max over steps of |dE/dt - (P - D - F)| and the same for Z, with midpoint P and
    trapezoidal D, F."""
    p = DNSParams(n=32, nu=5e-3, alpha=0.3, epsilon=epsilon, dt=dt, dtype="float64")
    g = SpectralGrid(32, dtype=torch.float64)
    dns = DNS(p, seeds=[3, 4], state=random_state(g, [0, 1], 2.0, 3.0))
    gg = dns.grid
    r_e = r_z = 0.0
    for _ in range(steps):
        w0 = dns.state.omega_hat.clone()
        dns.step()
        w1, f = dns.state.omega_hat, dns.last_forcing

        def avg(fn, w0=w0, w1=w1):
            return 0.5 * (fn(gg, p, w0) + fn(gg, p, w1))

        p_e = dg.energy_injection_rate(gg, 0.5 * (w0 + w1), f) if f is not None else 0.0
        p_z = dg.enstrophy_injection_rate(gg, 0.5 * (w0 + w1), f) if f is not None else 0.0
        res_e = (dg.energy(gg, w1) - dg.energy(gg, w0)) / dt - (
            p_e - avg(dg.energy_dissipation_rate) - avg(dg.energy_friction_rate))
        res_z = (dg.enstrophy(gg, w1) - dg.enstrophy(gg, w0)) / dt - (
            p_z - avg(dg.enstrophy_dissipation_rate) - avg(dg.enstrophy_friction_rate))
        r_e = max(r_e, float(res_e.abs().max()))
        r_z = max(r_z, float(res_z.abs().max()))
    return r_e, r_z, dns


def test_budgets_close_step_by_step_under_stochastic_forcing():
    """Residuals are the quadrature error of the midpoint/trapezoid rules within one step.

    The held forcing is O(dt^{-1/2}), so the intra-step curvature of psi(t) makes that error
    O(dt) in the rates (first order): we require |r_E| < epsilon dt, |r_Z| < eta_in dt (the
    observed constants are ~0.15) and that halving dt halves the residuals. The individual
    terms are O(1)-O(dt^{-1/2}) (|P_E| ~ 10 at dt = 2e-3), so the budgets close to ~1e-5.
    """
    r_e1, r_z1, dns = _budget_residuals(2e-3, 40)
    r_e2, r_z2, _ = _budget_residuals(1e-3, 80)
    eta_in = dns.forcing.enstrophy_injection_rate()
    assert r_e1 < 1.0 * 2e-3 and r_z1 < eta_in * 2e-3
    assert r_e2 < 1.0 * 1e-3 and r_z2 < eta_in * 1e-3
    assert 1.4 < r_e1 / r_e2 < 3.0
    assert 1.4 < r_z1 / r_z2 < 3.0


def test_budgets_close_to_second_order_without_forcing():
    """Deterministic decay: only the trapezoid error O(dt^2) remains."""
    r_e1, r_z1, _ = _budget_residuals(4e-3, 20, epsilon=0.0)
    r_e2, r_z2, _ = _budget_residuals(2e-3, 40, epsilon=0.0)
    assert r_e1 < 1e-6 and r_z1 < 1e-4
    assert r_e1 / r_e2 > 3.0 and r_z1 / r_z2 > 3.0
