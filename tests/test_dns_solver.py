"""DNS equation and stepper: exact linear decay, manufactured steady state, advection term,
conservation, batching, precision, CFL and parameter errors."""

from __future__ import annotations

import math

import pytest
import torch

from swimrl.errors import ConfigError
from swimrl.flows.dns import DNS, CFLError, DNSParams, SpectralGrid, random_state
from swimrl.flows.dns.equation import Advection, linear_operator
from swimrl.flows.dns.forcing import SteadyForcing
from swimrl.flows.dns.state import flow_channels, state_from_vorticity
from swimrl.flows.dns.stepper import etdrk4_coefficients

torch.set_num_threads(1)


def _nodes(n: int):
    x = torch.arange(n, dtype=torch.float64) * (2 * math.pi / n)
    Y, X = torch.meshgrid(x, x, indexing="ij")
    return X, Y  # X[iy, ix] = x_ix, Y[iy, ix] = y_iy


def _params(**kw) -> DNSParams:
    base = dict(n=32, nu=1e-2, alpha=0.2, hypo_power=1.0, epsilon=0.0, dt=0.01, dtype="float64")
    return DNSParams(**{**base, **kw})


@pytest.mark.parametrize("h", [0.0, 1.0, 2.0])
@pytest.mark.parametrize("mode", [(1, 0), (2, 3)])
def test_single_mode_decays_at_exact_rate(h, mode):
    """omega = cos(m_x x + m_y y) decays as exp(-(nu k^2 + alpha k^{-2h}) t) to round-off.

    A single Fourier mode (and its Taylor-Green combination below) has u || level sets of
    omega, so J(psi, omega) = 0 and the solution is purely linear.
    """
    p = _params(hypo_power=h)
    X, Y = _nodes(p.n)
    mx, my = mode
    w0 = torch.cos(mx * X + my * Y)
    dns = DNS(p, state=state_from_vorticity(SpectralGrid(p.n, dtype=torch.float64), w0))
    dns.step(150)
    k2 = mx**2 + my**2
    rate = p.nu * k2 + p.alpha * k2 ** (-h)
    w = flow_channels(dns.state, dns.grid)[0, ..., 4]
    assert torch.allclose(w, w0 * math.exp(-rate * dns.state.t), rtol=0, atol=1e-13)


def test_taylor_green_vortex_decays_exactly_and_has_correct_velocity():
    """Taylor-Green psi = cos x cos y, omega = 2 cos x cos y: exact decay and all 5 channels."""
    p = _params(nu=0.05, alpha=0.1, hypo_power=1.0)
    X, Y = _nodes(p.n)
    psi = torch.cos(X) * torch.cos(Y)
    w0 = 2 * psi  # omega = -lap psi
    dns = DNS(p, state=state_from_vorticity(SpectralGrid(p.n, dtype=torch.float64), w0))
    dns.step(200)
    decay = math.exp(-(p.nu * 2 + p.alpha / 2) * dns.state.t)
    q = flow_channels(dns.state, dns.grid)[0]
    # u = (d_y psi, -d_x psi), S_xx = d_x u_x, S_xy = (d_y u_x + d_x u_y)/2
    expect = torch.stack(
        (
            -torch.cos(X) * torch.sin(Y),
            torch.sin(X) * torch.cos(Y),
            torch.sin(X) * torch.sin(Y),
            torch.zeros_like(X),
            2 * torch.cos(X) * torch.cos(Y),
        ),
        dim=-1,
    ) * decay
    assert torch.allclose(q, expect, rtol=0, atol=1e-13)


def test_manufactured_steady_solution_with_steady_forcing():
    """omega* = cos(2x + y) + 0.5 sin(x - 2y) with steady forcing f = -L omega* stays put.

    Both modes lie on the shell |k|^2 = 5, so psi = omega*/5 and J(psi, omega*) = 0; f balances
    viscosity and hypo-friction, and ETDRK4 (exact for constant N) keeps the fixed point.
    """
    p = _params(nu=0.03, alpha=0.4, hypo_power=1.5)
    X, Y = _nodes(p.n)
    w_star = torch.cos(2 * X + Y) + 0.5 * torch.sin(X - 2 * Y)
    g = SpectralGrid(p.n, dtype=torch.float64)
    w_hat = state_from_vorticity(g, w_star).omega_hat
    L = linear_operator(g, p)
    dns = DNS(p, state=state_from_vorticity(g, w_star), forcing=SteadyForcing(-L * w_hat))
    dns.step(300)
    w = flow_channels(dns.state, dns.grid)[0, ..., 4]
    assert torch.allclose(w, w_star, rtol=0, atol=1e-13)
    # and the advection term of this field vanishes
    n_hat, _ = Advection(g)(w_hat)
    assert n_hat.abs().max() < 1e-10 * w_hat.abs().max()


@pytest.mark.parametrize("form", Advection.FORMS)
def test_advection_term_matches_analytic_jacobian(form):
    """N = -u . grad omega for psi = sin x + cos 2y + sin(x + y) (cross terms non-zero)."""
    n = 32
    g = SpectralGrid(n, dtype=torch.float64)
    X, Y = _nodes(n)
    psi = torch.sin(X) + torch.cos(2 * Y) + torch.sin(X + Y)
    w = torch.sin(X) + 4 * torch.cos(2 * Y) + 2 * torch.sin(X + Y)  # -lap psi
    ux = -2 * torch.sin(2 * Y) + torch.cos(X + Y)  # d_y psi
    uy = -torch.cos(X) - torch.cos(X + Y)  # -d_x psi
    wx = torch.cos(X) + 2 * torch.cos(X + Y)
    wy = -8 * torch.sin(2 * Y) + 2 * torch.cos(X + Y)
    expected = -(ux * wx + uy * wy)
    n_hat, speed = Advection(g, form)(g.to_spectral(w)[None], want_speed=True)
    assert torch.allclose(g.to_physical(n_hat)[0], expected, rtol=0, atol=1e-12)
    assert speed[0] == pytest.approx(float((ux.abs() + uy.abs()).max()), rel=1e-12)
    assert torch.allclose(g.to_physical(g.to_spectral(psi)), psi)


@pytest.mark.parametrize("form", Advection.FORMS)
def test_truncated_advection_conserves_energy_and_enstrophy(form):
    """sum w Re(conj(psi_hat) N_hat) = sum w Re(conj(omega_hat) N_hat) = 0 (Galerkin)."""
    g = SpectralGrid(32, dtype=torch.float64)
    w_hat = random_state(g, [0, 1], 1.0, 6.0).omega_hat
    n_hat, _ = Advection(g, form)(w_hat)
    scale = (g.mean_product(w_hat, w_hat) * g.mean_product(n_hat, n_hat)).sqrt()
    assert (g.mean_product(w_hat * g.inv_k2, n_hat).abs() < 1e-13 * scale).all()
    assert (g.mean_product(w_hat, n_hat).abs() < 1e-13 * scale).all()


@pytest.mark.parametrize("dtype,tol", [(torch.float64, 1e-12), (torch.float32, 3e-5)])
def test_basdevant_and_divergence_forms_agree(dtype, tol):
    """The 4-FFT Basdevant form equals the 5-FFT divergence form on a broadband random state
    (same Galerkin truncation), to round-off relative to the term's largest mode."""
    g = SpectralGrid(64, dtype=dtype)
    w_hat = random_state(g, [0, 1, 2], 1.0, 12.0).omega_hat.to(g.complex_dtype)
    a, sa = Advection(g, "basdevant")(w_hat, want_speed=True)
    b, sb = Advection(g, "divergence")(w_hat, want_speed=True)
    assert ((a - b).abs().amax() / b.abs().amax()) < tol
    assert torch.equal(sa, sb)
    assert (a[..., ~g.mask] == 0).all()
    with pytest.raises(ValueError, match="form='skew'"):
        Advection(g, "skew")


def test_etdrk4_coefficients_limits():
    """phi-functions: finite at L = 0 (Q = h/2, f1 = f3 = h/6, 2 f2 = h/3) and consistent."""
    h = 0.1
    L = torch.tensor([0.0, -1e-9, -3.0, -400.0], dtype=torch.float64)
    c = etdrk4_coefficients(L, h)
    assert c["Q"][0].item() == pytest.approx(h / 2, rel=1e-13)
    assert c["f1"][0].item() == pytest.approx(h / 6, rel=1e-12)
    assert c["f2"][0].item() == pytest.approx(h / 6, rel=1e-12)
    assert c["f3"][0].item() == pytest.approx(h / 6, rel=1e-12)
    # f1 + 4 f2 + f3 = (e^{hL} - 1)/L (exact for constant N)
    phi = torch.where(L != 0, torch.expm1(h * L) / L, torch.full_like(L, h))
    assert torch.allclose(c["f1"] + 4 * c["f2"] + c["f3"], phi, rtol=1e-12, atol=0)


def test_batched_realisations_equal_unbatched_runs_with_same_seeds():
    p = _params(n=32, nu=5e-3, alpha=0.3, epsilon=1.0, dt=4e-3)
    g = SpectralGrid(p.n, dtype=torch.float64)
    seeds = [11, 12, 13]
    batch = DNS(p, seeds=seeds, state=random_state(g, seeds, 1.0, 3.0))
    batch.step(40)
    for b, s in enumerate(seeds):
        single = DNS(p, seeds=[s], state=random_state(g, [s], 1.0, 3.0))
        single.step(40)
        assert torch.allclose(batch.state.omega_hat[b], single.state.omega_hat[0], rtol=1e-12,
                              atol=1e-12 * single.state.omega_hat.abs().max())
    # realisations are independent: different seeds give different flows
    a, b = batch.state.omega_hat[0], batch.state.omega_hat[1]
    assert (a - b).abs().max() > 0.1 * a.abs().max()


def test_float32_agrees_with_float64():
    """Same seeds: relative L2 difference of omega after 100 steps < 1e-4 (float32 eps 1.2e-7
    amplified by ~1e2 steps of chaotic growth, observed ~1e-6)."""
    kw = dict(n=32, nu=5e-3, alpha=0.3, epsilon=1.0, dt=4e-3)
    out = {}
    for dt in ("float32", "float64"):
        p = _params(**kw, dtype=dt)
        g = SpectralGrid(p.n, dtype=p.torch_dtype)
        dns = DNS(p, seeds=[7], state=random_state(g, [7], 1.0, 3.0))
        dns.step(100)
        out[dt] = dns.state.omega_hat.to(torch.complex128)
    rel = (out["float32"] - out["float64"]).norm() / out["float64"].norm()
    assert rel < 1e-4


def test_cfl_violation_raises_before_stepping():
    p = _params(n=32, nu=1e-3, alpha=0.0, epsilon=0.0, dt=0.5)
    g = SpectralGrid(p.n, dtype=torch.float64)
    dns = DNS(p, state=random_state(g, [0], 4.0, 3.0))
    before = dns.state.omega_hat.clone()
    with pytest.raises(CFLError, match=r"CFL number [0-9.]+ exceeds the limit cfl_max=1"):
        dns.step()
    assert torch.equal(dns.state.omega_hat, before)
    assert torch.isfinite(dns.state.omega_hat).all()
    assert dns.state.step == 0


def test_cfl_check_reports_nonfinite_flow():
    p = _params(n=32, epsilon=0.0)
    g = SpectralGrid(p.n, dtype=torch.float64)
    st = random_state(g, [0], 1.0, 3.0)
    st.omega_hat[0, 1, 1] = float("nan")
    with pytest.raises(CFLError, match="non-finite"):
        DNS(p, state=st).step()


@pytest.mark.parametrize(
    ("key", "value", "fragment"),
    [
        ("n", 31, "dns.n=31 is invalid: allowed an even integer >= 8"),
        ("n", 4, "dns.n=4"),
        ("nu", -1.0, "dns.nu=-1.0 is invalid: allowed >= 0"),
        ("alpha", float("nan"), "dns.alpha=nan is invalid: allowed a finite number"),
        ("hypo_power", -1.0, "dns.hypo_power=-1.0 is invalid: allowed in [0, 8]"),
        ("epsilon", -0.1, "dns.epsilon=-0.1 is invalid: allowed >= 0"),
        ("k_f", 0.5, "dns.k_f=0.5 is invalid: allowed in [1, 10]"),
        ("k_f", 100.0, "dns.k_f=100.0 is invalid"),
        ("forcing_width", 0.0, "dns.forcing_width=0.0 is invalid: allowed in (0, k_f=3.0]"),
        ("dt", 0.0, "dns.dt=0.0 is invalid: allowed > 0"),
        ("dtype", "float16", "dns.dtype='float16' is invalid: allowed one of"),
        ("device", "tpu", "dns.device='tpu' is invalid"),
        ("cfl_max", 2.0, "dns.cfl_max=2.0 is invalid: allowed in (0, 1.35]"),
        ("cfl_every", 0, "dns.cfl_every=0 is invalid: allowed an integer >= 1"),
        ("length", -1.0, "dns.length=-1.0 is invalid: allowed > 0"),
    ],
)
def test_bad_parameters_raise_one_line_errors(key, value, fragment):
    with pytest.raises(ConfigError) as err:
        DNSParams(n=32, **{key: value}) if key != "n" else DNSParams(n=value)
    msg = str(err.value)
    assert fragment in msg
    assert "\n" not in msg


def test_unknown_parameter_key_is_rejected():
    with pytest.raises(ConfigError, match="dns.viscosity is not a DNS parameter"):
        DNSParams.from_mapping({"viscosity": 1.0})


@pytest.mark.gpu
@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_cuda_run_matches_cpu_run():
    """Same seeds on CUDA and CPU (noise is drawn on the CPU): same flow to float64 round-off."""
    out = {}
    for dev in ("cpu", "cuda"):
        p = _params(n=32, nu=5e-3, alpha=0.3, epsilon=1.0, dt=4e-3, device=dev)
        g = SpectralGrid(p.n, dtype=torch.float64, device=dev)
        dns = DNS(p, seeds=[1, 2], state=random_state(g, [1, 2], 1.0, 3.0))
        dns.step(20)
        out[dev] = dns.state.omega_hat.cpu()
        assert flow_channels(dns.state, dns.grid).device.type == dev
    assert torch.allclose(out["cuda"], out["cpu"], rtol=0, atol=1e-10 * out["cpu"].abs().max())
