"""The 3D stochastic flow (random Fourier modes) and the analytic flows against their
formulas: covariances by Monte Carlo over realisations, incompressibility, gradients by
finite differences, OU statistics, u_rms and tau_K; ABC, linear and Taylor-Green flows."""

from __future__ import annotations

import math

import pytest
import torch
from omegaconf import OmegaConf

from swimrl.errors import ConfigError
from swimrl.flows.analytic import ABCFlow, LinearFlow, TaylorGreenFlow, check_gradient
from swimrl.flows.base import gradient_norm2
from swimrl.flows.pointwise import vorticity
from swimrl.flows.stochastic3d import (
    TAU_K,
    StochasticFlow3D,
    compiled_mode_sum,
    gradient_covariance,
    mode_sum,
    velocity_covariance,
)
from swimrl.physics.body2d import channels_2d

F64 = torch.float64


def fd_gradient(fn, pos: torch.Tensor, h: float) -> torch.Tensor:
    """``d_j u_i`` by central differences of ``fn`` (``(F, S, d) -> (F, S, d)``):
    ``(F, S, d, d)``, error ``h^2 |d^3 u| / 6``."""
    cols = []
    for j in range(pos.shape[-1]):
        e = torch.zeros_like(pos)
        e[..., j] = h
        cols.append((fn(pos + e) - fn(pos - e)) / (2 * h))
    return torch.stack(cols, -1)


def fd_curl(fn, pos: torch.Tensor, h: float) -> torch.Tensor:
    """``curl fn`` by central differences (3D)."""
    return vorticity(fd_gradient(fn, pos, h))


def trace(grad: torch.Tensor) -> torch.Tensor:
    return grad.diagonal(dim1=-2, dim2=-1).sum(-1)


# -- the 3D stochastic flow: analytic moments -------------------------------------------------
def test_analytic_moments_are_derivatives_of_the_covariance():
    """R(0) = I/3 (<u.u> = 1); longitudinal correlation exp(-r^2/2); <A_ij A_kl> equals
    -d_j d_l R_ik(0) (autograd of the formula), is traceless in (i, j) and gives
    <A_ij A_ij> = 5 = tau_K^-2, <A_ij A_ji> = 0."""
    zero = torch.zeros(3, dtype=F64)
    assert torch.allclose(velocity_covariance(zero), torch.eye(3, dtype=F64) / 3, atol=1e-15)
    for r in (0.3, 1.0, 2.5):
        e = torch.tensor([0.6, -0.8, 0.0], dtype=F64)
        r_ll = e @ velocity_covariance(r * e) @ e
        assert float(r_ll) == pytest.approx(math.exp(-r * r / 2) / 3, rel=1e-12)

    def dR(r):
        return torch.autograd.functional.jacobian(velocity_covariance, r, create_graph=True)

    hess = torch.autograd.functional.jacobian(dR, zero)                # [i, k, l, j]
    expected = -torch.einsum("iklj->ijkl", hess)
    g = gradient_covariance()
    assert torch.allclose(g, expected, atol=1e-14)
    assert torch.allclose(torch.einsum("iikl->kl", g), torch.zeros(3, 3, dtype=F64))
    assert float(torch.einsum("ijij->", g)) == pytest.approx(5.0, rel=1e-14)
    assert float(torch.einsum("ijji->", g)) == pytest.approx(0.0, abs=1e-14)
    assert float(torch.einsum("ijij->", g)) ** -0.5 == pytest.approx(TAU_K, rel=1e-14)
    assert math.isclose(TAU_K, 1 / math.sqrt(5), rel_tol=1e-15)


def test_covariances_match_monte_carlo_over_realisations():
    """<u_i(x) u_k(x+r)> = R_ik(r), <u_i(x) A_kl(x+r)> = d_l R_ik(r) and
    <A_ij(x) A_kl(x+r)> = -d_j d_l R_ik(r) at four separations (r = 0 included), over
    4000 realisations (modes, amplitudes and c_i drawn anew), within 5 standard errors of
    the per-realisation means. K = 8 modes per component: the ensemble moments are exact
    for any K."""
    gen = torch.Generator().manual_seed(11)
    n_flows, n_points = 4000, 4
    flow = StochasticFlow3D(n_flows, 1.0, n_waves=8, dtype=F64, generator=gen, device="cpu")
    seps = torch.tensor([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.3, -0.7, 0.4], [1.5, 0.5, -1.0]],
                        dtype=F64)
    x0 = 20 * torch.rand(n_flows, n_points, 1, 3, generator=gen, dtype=F64)
    pos = (x0 + seps).reshape(n_flows, -1, 3)                       # (F, S * 4, 3)
    u, a = flow.sample(pos)
    u = u.reshape(n_flows, n_points, len(seps), 3)
    a = a.reshape(n_flows, n_points, len(seps), 3, 3)

    def check(products: torch.Tensor, exact: torch.Tensor, scale: float) -> None:
        """``scale``: the product's size ``(<X^2> <Y^2>)^{1/2}`` (<u_x^2> = 1/3,
        <A_xy^2> = 2/3)."""
        per_flow = products.mean(1)                                    # over the points
        mean, se = per_flow.mean(0), per_flow.std(0) / math.sqrt(n_flows)
        assert (se < 0.03 * scale).all()                               # the test has power
        assert ((mean - exact).abs() <= 5 * se + 1e-12).all(), (mean - exact) / se

    for s, r in enumerate(seps):
        d_r = torch.autograd.functional.jacobian(velocity_covariance, r)      # [i, k, l]

        def dR(q):
            return torch.autograd.functional.jacobian(velocity_covariance, q, create_graph=True)

        d2_r = torch.autograd.functional.jacobian(dR, r)                       # [i, k, l, j]
        u0, ur, a0, ar = u[:, :, 0], u[:, :, s], a[:, :, 0], a[:, :, s]
        check(torch.einsum("fpi,fpk->fpik", u0, ur), velocity_covariance(r), 1 / 3)
        check(torch.einsum("fpi,fpkl->fpikl", u0, ar), d_r, math.sqrt(2) / 3)
        check(torch.einsum("fpij,fpkl->fpijkl", a0, ar), -torch.einsum("iklj->ijkl", d2_r),
              2 / 3)


def test_incompressible_to_round_off_and_gradient_is_the_derivative():
    """tr A = div u to float64 round-off; A against central differences of u (h = 1e-5,
    error ~1e-9); u against the curl of the vector potential; near and far from 0."""
    gen = torch.Generator().manual_seed(3)
    flow = StochasticFlow3D(3, 0.5, dtype=F64, generator=gen, device="cpu")
    pos = torch.randn(3, 20, 3, generator=gen, dtype=F64) * torch.tensor([1.0, 10.0, 50.0],
                                                                       dtype=F64)[:, None, None]
    u, a = flow.sample(pos)
    scale = a.abs().max()
    assert (trace(a).abs() <= 1e-13 * scale).all()
    assert torch.allclose(fd_gradient(flow.velocity, pos, 1e-5), a, atol=1e-7 * scale, rtol=0)
    assert torch.allclose(fd_curl(flow.vector_potential, pos, 1e-5), u,
                          atol=1e-7 * u.abs().max(), rtol=0)
    assert torch.allclose(flow.velocity(pos), u, atol=1e-14 * u.abs().max(), rtol=0)
    sub = torch.tensor([2, 0])
    u_sub, a_sub = flow.sample(pos[sub], flows=sub)
    assert torch.allclose(u_sub, u[sub], atol=1e-14) and torch.allclose(a_sub, a[sub], atol=1e-13)


def test_ou_coefficients_have_the_stationary_law_and_exponential_correlation():
    """<c_i(t) c_j(t + s)> = delta_ij / M exp(-s / tau_f), tau_f = Ku ell_f / u_rms, variance
    1/M after 30 steps; the update composes exactly (two half steps = one step in law)."""
    gen = torch.Generator().manual_seed(4)
    kubo, dt, n_flows = 0.5, 0.05, 4000
    flow = StochasticFlow3D(n_flows, kubo, n_waves=1, dtype=F64, generator=gen, device="cpu")
    m = flow.n_basis
    assert flow.tau_f == kubo * flow.ell_f / flow.u_rms == kubo
    c0 = flow.coeffs.clone()
    path = [c0]
    for _ in range(30):
        flow.advance(dt)
        path.append(flow.coeffs.clone())
    for lag in (0, 5, 10, 20, 30):
        corr = (c0 * path[lag]).mean().item()
        expected = math.exp(-lag * dt / kubo) / m
        assert corr == pytest.approx(expected, abs=4 * 1.5 / m / math.sqrt(c0.numel()))
    cross = (c0[:, 0] * path[10][:, 1]).mean().item()
    assert abs(cross) < 4 / m / math.sqrt(n_flows)
    assert path[-1].var().item() == pytest.approx(1 / m, rel=0.05)
    assert torch.allclose(flow.time, torch.full_like(flow.time, 30 * dt))
    (d1, s1), (d2, s2) = flow.ou_factors(dt), flow.ou_factors(dt / 2)
    assert d2 * d2 == pytest.approx(d1, rel=1e-14)
    assert s2 * s2 * (1 + d2 * d2) == pytest.approx(s1 * s1, rel=1e-12)


def test_u_rms_and_tau_k_against_their_formulas():
    """Ensemble means of the per-realisation space averages (mode sums) at the default
    K = 64: <u.u> = 1 and <A_ij A_ij> = 5 (tau_K = 1/sqrt 5) within 5 standard errors;
    one realisation's mode sums against its average over 20000 random points (5 %)."""
    gen = torch.Generator().manual_seed(5)
    n_flows = 2000
    flow = StochasticFlow3D(n_flows, 1.0, dtype=F64, generator=gen, device="cpu")
    assert flow.n_waves == 64 and flow.n_basis == 5
    assert flow.u_rms == 1.0 and flow.ell_f == 1.0 and flow.tau_k == TAU_K
    u2, a2 = flow.realisation_moments()
    for values, exact in ((u2, 1.0), (a2, 5.0)):
        assert abs(values.mean().item() - exact) <= 5 * values.std().item() / math.sqrt(n_flows)
    stats = flow.measured_stats()
    assert stats["u_rms"] == pytest.approx(1.0, rel=0.05)
    assert stats["tau_K"] == pytest.approx(TAU_K, rel=0.05)
    pos = 1000 * torch.rand(1, 20000, 3, generator=gen, dtype=F64)
    u, a = flow.sample(pos, flows=torch.tensor([0]))
    assert (u**2).sum(-1).mean().item() == pytest.approx(u2[0].item(), rel=0.05)
    assert (a**2).sum((-1, -2)).mean().item() == pytest.approx(a2[0].item(), rel=0.05)


def test_fixed_and_redrawn_bases_and_partial_reset():
    """fixed: one set of modes from basis_seed alone, shared by every realisation; redrawn:
    new modes per realisation; reset(mask) redraws the selected flows only."""
    make = lambda seed, basis: StochasticFlow3D(  # noqa: E731
        3, 1.0, n_waves=4, dtype=F64, device="cpu", basis=basis, basis_seed=7,
        generator=torch.Generator().manual_seed(seed))
    a, b = make(0, "fixed"), make(1, "fixed")
    assert a.wavevectors.shape[0] == 1 and torch.equal(a.wavevectors, b.wavevectors)
    assert torch.equal(a.amp_cos, b.amp_cos) and not torch.equal(a.coeffs, b.coeffs)
    pos = torch.rand(1, 5, 3, dtype=F64).expand(3, -1, -1).contiguous()
    same, _ = a.sample(pos, coeffs=a.coeffs[:1].expand(3, -1))      # equal c: equal fields
    assert torch.allclose(same, same[:1].expand(3, -1, -1), atol=1e-15)
    own, _ = a.sample(pos)                                           # own c: different
    assert not torch.allclose(own[0], own[1])
    r = make(0, "redrawn")
    assert r.wavevectors.shape[0] == 3 and not torch.equal(r.wavevectors[0], r.wavevectors[1])
    r.advance(0.1)
    before, c_before = r.wavevectors.clone(), r.coeffs.clone()
    r.reset(torch.tensor([False, True, False]))
    assert torch.equal(r.wavevectors[[0, 2]], before[[0, 2]])
    assert torch.equal(r.coeffs[[0, 2]], c_before[[0, 2]])
    assert not torch.equal(r.wavevectors[1], before[1])
    assert r.time.tolist() == pytest.approx([0.1, 0.0, 0.1])


@pytest.mark.parametrize("kwargs, key", [
    ({"basis": "bogus"}, "flow.basis='bogus' is invalid: allowed one of ['redrawn', 'fixed']"),
    ({"kubo": 0.0}, "flow.kubo=0.0 is invalid"),
    ({"n_waves": 0}, "flow.n_waves=0 is invalid"),
    ({"n_modes": 2.5}, "flow.n_modes=2.5 is invalid"),
])
def test_stochastic3d_refuses_bad_values(kwargs, key):
    args = {"n_flows": 1, "kubo": 1.0, "device": "cpu", **kwargs}
    with pytest.raises(ConfigError) as err:
        StochasticFlow3D(**args)
    assert str(err.value).startswith(key) and "\n" not in str(err.value)


# -- ABC ------------------------------------------------------------------------------------
def abc_formula(pos, a, b, c, k=1.0, phi=0.0):
    x, y, z = (k * pos + phi).unbind(-1)
    return torch.stack((a * torch.sin(z) + c * torch.cos(y), b * torch.sin(x) + a * torch.cos(z),
                        c * torch.sin(y) + b * torch.cos(x)), -1)


def test_abc_is_incompressible_beltrami_with_the_exact_gradient():
    """The stated form; div u = tr A = 0 exactly; curl u = k u (Beltrami) from A and by
    finite differences; A against finite differences; steady and modulated, k = 1 and 2."""
    gen = torch.Generator().manual_seed(6)
    pos = 10 * torch.rand(2, 30, 3, generator=gen, dtype=F64)
    a, b, c = 1.0, math.sqrt(2 / 3), math.sqrt(1 / 3)
    for k, eps, omega in ((1.0, 0.0, 0.0), (2.0, 0.0, 0.0), (1.0, 0.7, 2.0)):
        flow = ABCFlow(2, terms=[[a, b, c, k]], modulation=eps, frequency=omega, dtype=F64)
        flow.advance(0.3)
        phi = eps * math.sin(omega * 0.3)
        u, grad = flow.sample(pos)
        assert torch.allclose(u, abc_formula(pos, a, b, c, k, phi), atol=1e-15)
        assert torch.equal(trace(grad), torch.zeros_like(trace(grad)))
        assert torch.allclose(vorticity(grad), k * u, atol=1e-14)
        assert torch.allclose(fd_curl(flow.velocity, pos, 1e-5), k * u, atol=1e-8)
        assert torch.allclose(fd_gradient(flow.velocity, pos, 1e-5), grad, atol=1e-8)
    standard = ABCFlow(1, dtype=F64)
    assert torch.allclose(standard.velocity(pos[:1]), abc_formula(pos[:1], 1, 1, 1), atol=1e-15)


def test_abc_superposition_and_its_scales():
    """A superposition is the sum of its terms; u_rms and tau_K are the space averages
    (exact on a 16^3 grid over the common period 2 pi): u_rms = sqrt 3, tau_K = 1/sqrt 3 for
    the standard flow."""
    n = 16
    axis = torch.arange(n, dtype=F64) * (2 * math.pi / n)
    grid = torch.stack(torch.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(1, -1, 3)
    terms = [[1.0, 1.0, 1.0, 1.0], [0.5, -0.3, 0.2, 2.0], [0.1, 0.2, 0.3, 1.0]]
    flow = ABCFlow(1, terms=terms, dtype=F64)
    u, grad = flow.sample(grid)
    parts = [ABCFlow(1, terms=[t], dtype=F64).sample(grid) for t in terms]
    assert torch.allclose(u, sum(p[0] for p in parts), atol=1e-14)
    assert torch.allclose(grad, sum(p[1] for p in parts), atol=1e-14)
    for f in (flow, ABCFlow(1, dtype=F64)):
        u, grad = f.sample(grid)
        assert (u**2).sum(-1).mean().item() ** 0.5 == pytest.approx(f.u_rms, rel=1e-12)
        assert (grad**2).sum((-1, -2)).mean().item() ** -0.5 == pytest.approx(f.tau_k, rel=1e-12)
    standard = ABCFlow(1)
    assert standard.u_rms == pytest.approx(math.sqrt(3)) and standard.tau_k == pytest.approx(
        1 / math.sqrt(3))
    with pytest.raises(ConfigError, match=r"^flow\.terms=.*k > 0"):
        ABCFlow(1, terms=[[1, 1, 1, 0]])


# -- linear ---------------------------------------------------------------------------------
@pytest.mark.parametrize("matrix", [
    [[0.5, 2.0], [-1.25, -0.5]],
    [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
    [[0.25, -1.5, 0.75], [2.0, 0.5, -0.125], [1.0, 3.0, -0.75]],
])
def test_linear_flow_is_u_equals_a_x(matrix):
    """u_i = sum_j A_ij x_j exactly (dyadic values: no rounding), A everywhere, tr A = 0."""
    d = len(matrix)
    flow = LinearFlow(matrix, n_flows=2, dtype=F64)
    pos = torch.randint(-64, 64, (2, 7, d), generator=torch.Generator().manual_seed(1)).to(F64) / 8
    u, grad = flow.sample(pos)
    a = torch.tensor(matrix, dtype=F64)
    exact = torch.stack([sum(a[i, j] * pos[..., j] for j in range(d)) for i in range(d)], -1)
    assert flow.dim == d and torch.equal(u, exact)
    assert torch.equal(grad, a.expand(2, 7, d, d))
    assert flow.u_rms is None and flow.tau_k == pytest.approx(float((a**2).sum()) ** -0.5)


@pytest.mark.parametrize("value", [
    [[1.0, 0.0], [0.0, 1.0]],                              # tr A = 2
    [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.5]],   # tr A = 0.5
    [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0]],                    # 2 x 3
    [[0.0]],                                               # 1 x 1
    [[0.0] * 4] * 4,                                       # 4 x 4
    [[0.0, 1.0], [0.0]],                                   # ragged
    [[0.0, "shear"], [0.0, 0.0]],
    [[math.nan, 0.0], [0.0, 0.0]],
    [[True, 0.0], [0.0, False]],
    "shear",
    None,
])
def test_linear_flow_refuses_a_bad_matrix_in_one_line(value):
    with pytest.raises(ConfigError) as err:
        LinearFlow(value)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith("flow.gradient=")
    assert "is invalid: allowed a 2x2 or 3x3 matrix" in message and "zero trace" in message


def test_linear_flow_accepts_decimal_tensor_and_config_input():
    """0.1 + 0.2 - 0.3 != 0 in floats: accepted (round-off); a tensor and an OmegaConf list
    are read as lists."""
    decimal = [[0.1, 1.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, -0.3]]
    assert check_gradient(decimal)[2][2] == -0.3
    assert LinearFlow(torch.tensor([[0.0, 1.0], [0.0, 0.0]])).dim == 2
    assert LinearFlow(OmegaConf.create({"g": [[0.0, 1.0], [-1.0, 0.0]]}).g).dim == 2


# -- Taylor-Green ---------------------------------------------------------------------------
def test_taylor_green_is_incompressible_with_the_exact_gradient():
    """The stated form; tr A = 0 exactly; A against finite differences; the five 2D
    channels (omega = 2 U k sin kx sin ky; A_ij A_ij by the 2D flows' gradient_norm2);
    u_rms = U/sqrt 2 and tau_K = 1/(U k) against the average over a period grid."""
    amp, k = 1.5, 2.0
    flow = TaylorGreenFlow(2, amplitude=amp, wavenumber=k, dtype=F64)
    pos = 10 * torch.rand(2, 40, 2, generator=torch.Generator().manual_seed(2), dtype=F64)
    u, grad = flow.sample(pos)
    x, y = (k * pos).unbind(-1)
    assert torch.allclose(u, amp * torch.stack((x.sin() * y.cos(), -x.cos() * y.sin()), -1),
                          atol=1e-15)
    assert torch.equal(trace(grad), torch.zeros_like(trace(grad)))
    assert torch.allclose(fd_gradient(flow.velocity, pos, 1e-5), grad, atol=1e-8)
    q = channels_2d(u, grad)
    assert torch.allclose(q[..., 4], 2 * amp * k * x.sin() * y.sin(), atol=1e-14)
    assert torch.allclose(gradient_norm2(q), (grad**2).sum((-1, -2)), atol=1e-13)
    n = 16
    axis = torch.arange(n, dtype=F64) * (2 * math.pi / (k * n))
    grid = torch.stack(torch.meshgrid(axis, axis, indexing="ij"), -1).reshape(1, -1, 2)
    u, grad = TaylorGreenFlow(1, amplitude=amp, wavenumber=k, dtype=F64).sample(grid)
    assert (u**2).sum(-1).mean().item() ** 0.5 == pytest.approx(amp / math.sqrt(2), rel=1e-12)
    assert (grad**2).sum((-1, -2)).mean().item() ** -0.5 == pytest.approx(1 / (amp * k),
                                                                           rel=1e-12)
    assert flow.u_rms == pytest.approx(amp / math.sqrt(2)) and flow.tau_k == pytest.approx(
        1 / (amp * k))


def test_point_flows_check_the_positions_shape():
    with pytest.raises(ValueError, match=r"expected \(1, S, 2\)"):
        TaylorGreenFlow(1).sample(torch.zeros(1, 4, 3))
    with pytest.raises(ValueError, match=r"expected \(2, S, 3\)"):
        ABCFlow(2).sample(torch.zeros(1, 4, 3))


@pytest.mark.parametrize("basis", ["redrawn", "fixed"])
def test_compiled_sampler_agrees_with_the_eager_one(basis):
    """``kernel=compiled``: the compiled mode sum gives the eager (u, A) to float32
    round-off, for all flows and for a subset (``fullgraph=True``: a graph break fails)."""
    gen = torch.Generator().manual_seed(3)
    flow = StochasticFlow3D(3, 10.0, generator=gen, basis=basis)
    pos = 5 * torch.randn(3, 7, 3, generator=gen)
    u0, a0 = flow.sample(pos)
    sub_pos, sub = pos[:2], torch.tensor([2, 0])
    u1, a1 = flow.sample(sub_pos, sub)
    flow.compile_sampler()
    u, a = flow.sample(pos)
    torch.testing.assert_close(u, u0, rtol=1e-5, atol=1e-5)
    torch.testing.assert_close(a, a0, rtol=1e-5, atol=1e-5)
    u, a = flow.sample(sub_pos, sub)
    torch.testing.assert_close(u, u1, rtol=1e-5, atol=1e-5)
    torch.testing.assert_close(a, a1, rtol=1e-5, atol=1e-5)


def test_compiled_kernel_runs_the_3d_env_as_the_eager_one(compose_cfg):
    """A 3D environment with ``kernel=compiled`` follows the eager one's swimmers to float32
    round-off over a decision, and ``kernel`` refuses a kernel the flow lacks in one line."""
    from swimrl.config import env_params
    from swimrl.env import PointSwimmerEnv

    params = env_params(compose_cfg(["flow=stochastic3d", "episode.duration=1.0"]))
    envs = {}
    for kernel in ("eager", "compiled"):
        gen = torch.Generator().manual_seed(5)
        envs[kernel] = PointSwimmerEnv(StochasticFlow3D(2, 10.0, generator=gen), 4, params,
                                       generator=gen, kernel=kernel)
    tds = {k: e.reset() for k, e in envs.items()}
    action = torch.full((2, 4, 1), 0.5)
    for k, e in envs.items():
        tds[k] = e.step(tds[k].set("action", action))["next"]
    torch.testing.assert_close(envs["compiled"].pos, envs["eager"].pos, rtol=1e-4, atol=1e-5)
    torch.testing.assert_close(tds["compiled"]["signals"], tds["eager"]["signals"],
                               rtol=1e-4, atol=1e-4)
    assert envs["compiled"].flow._mode_sum is compiled_mode_sum()
    assert envs["eager"].flow._mode_sum is mode_sum
    auto = PointSwimmerEnv(StochasticFlow3D(1, 10.0), 2, params, kernel="auto")
    assert auto.flow._mode_sum is mode_sum  # auto on the CPU: eager
    with pytest.raises(ConfigError, match="kernel"):  # fused: the 3D stochastic flow only
        PointSwimmerEnv(ABCFlow(1), 2, params, kernel="fused")
