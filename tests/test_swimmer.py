"""Swimmer dynamics and interpolation against analytic results."""

from __future__ import annotations

import math

import pytest
import torch

from swimrl.flows.interpolation import bilinear_periodic
from swimrl.physics.body2d import compute_signals
from swimrl.physics.swimmer import heun_step, swimmer_rhs
from swimrl.policies.baselines import ShortTimeOptimal


@pytest.fixture(autouse=True)
def _float64():
    """Analytic comparisons in double precision; restore the default afterwards."""
    old = torch.get_default_dtype()
    torch.set_default_dtype(torch.float64)
    yield
    torch.set_default_dtype(old)


def shear_sampler(gamma: float):
    """Simple shear u = (gamma y, 0): S_xx = 0, S_xy = gamma/2, omega = -gamma."""

    def sample(pos):
        q = torch.zeros(pos.shape[0], 5)
        q[:, 0] = gamma * pos[:, 1]
        q[:, 3] = gamma / 2
        q[:, 4] = -gamma
        return q

    return sample


def jeffery_angle(t, theta0, lam_aspect, gamma):
    """Exact 2D Jeffery orbit: tan(theta) = tan(phi0 - gamma lam t / (lam^2 + 1)) / lam."""
    phi0 = math.atan(lam_aspect * math.tan(theta0))
    phi = phi0 - gamma * lam_aspect * t / (lam_aspect**2 + 1)
    # unwrap: theta follows phi branch by branch (both decrease monotonically)
    k = math.floor((phi + math.pi / 2) / math.pi)
    return math.atan(math.tan(phi) / lam_aspect) + k * math.pi


def integrate_theta(shape_factor, gamma, t_end, dt, theta0=0.0):
    """Heun-integrate theta in simple shear for a batch of shape factors; t_end/dt steps."""
    n_steps = round(t_end / dt)
    assert abs(n_steps * dt - t_end) < 1e-9
    lam = torch.as_tensor(shape_factor, dtype=torch.float64).reshape(-1)
    theta = torch.full_like(lam, theta0)
    pos = torch.zeros(lam.shape[0], 2)
    sample = shear_sampler(gamma)
    for _ in range(n_steps):
        pos, theta = heun_step(sample, lambda: None, pos, theta, lam, 0.0, dt)
    return theta


def test_jeffery_orbit_in_simple_shear():
    """theta(t) follows the exact Jeffery orbit; period 2 pi (lambda + 1/lambda) / gamma."""
    gamma, dt = 2.0, 2e-3
    aspects = [0.2, 1.0, 3.0]
    shapes = [(a**2 - 1) / (a**2 + 1) for a in aspects]
    t_end = 6.0
    theta = integrate_theta(shapes, gamma, t_end, dt)
    for a, th in zip(aspects, theta.tolist(), strict=True):
        assert th == pytest.approx(jeffery_angle(t_end, 0.0, a, gamma), abs=1e-5)
    for a, lam in zip(aspects, shapes, strict=True):
        period = 2 * math.pi * (a + 1 / a) / gamma
        n = round(period / dt)
        th = integrate_theta([lam], gamma, n * dt, dt)[0].item()
        # after one full period the orientation has turned by -2 pi (Heun global error
        # ~ dt^2 * period * max|d^3 theta/dt^3| ~ 4e-6 * 16 for the stiffest orbit)
        assert th == pytest.approx(jeffery_angle(n * dt, 0.0, a, gamma), abs=1e-4)
        assert th == pytest.approx(-2 * math.pi, abs=2 * dt * gamma)


def test_heun_is_second_order():
    gamma, aspect = 1.0, 4.0
    shape = (aspect**2 - 1) / (aspect**2 + 1)
    exact = jeffery_angle(3.0, 0.3, aspect, gamma)
    errs = [
        abs(integrate_theta([shape], gamma, 3.0, dt, 0.3).item() - exact)
        for dt in (0.04, 0.02, 0.01)
    ]
    orders = [math.log2(errs[i] / errs[i + 1]) for i in range(2)]
    assert all(1.8 < o < 2.2 for o in orders), orders


def test_translation_in_uniform_flow():
    """dx/dt = U + v_s n: straight line at constant orientation without gradients."""

    def sample(pos):
        q = torch.zeros(pos.shape[0], 5)
        q[:, 0], q[:, 1] = 0.3, -0.2
        return q

    pos, theta = torch.zeros(1, 2), torch.tensor([0.7])
    for _ in range(100):
        pos, theta = heun_step(sample, lambda: None, pos, theta, torch.tensor([0.5]), 0.9, 0.01)
    expected = torch.tensor([0.3 + 0.9 * math.cos(0.7), -0.2 + 0.9 * math.sin(0.7)])
    assert torch.allclose(pos[0], expected, atol=1e-12)


def test_rhs_matches_the_tensor_form():
    """dtheta/dt = omega/2 + Lambda p.S.n with S the full 2x2 strain tensor."""
    g = torch.Generator().manual_seed(0)
    q = torch.randn(50, 5, generator=g)
    theta = torch.rand(50, generator=g) * 6.3
    lam = torch.rand(50, generator=g) * 2 - 1
    _, rate = swimmer_rhs(q, theta, lam, 0.0)
    n = torch.stack((theta.cos(), theta.sin()), -1)
    p = torch.stack((-theta.sin(), theta.cos()), -1)
    s = torch.stack((torch.stack((q[:, 2], q[:, 3]), -1), torch.stack((q[:, 3], -q[:, 2]), -1)), -2)
    expected = 0.5 * q[:, 4] + lam * torch.einsum("pi,pij,pj->p", p, s, n)
    assert torch.allclose(rate, expected, atol=1e-12)


def test_lambda_minus_one_turns_as_zermelo_heading():
    """Sec. III A / App. D: with Lambda = -1 Jeffery's rate is Zermelo's minimum-time heading
    equation, dtheta/dt = sin^2(theta) v_x + sin(theta) cos(theta) (u_x - v_y)
    - cos^2(theta) u_y, for any incompressible velocity gradient; with Lambda = +1 it is not."""
    g = torch.Generator().manual_seed(1)
    grad = torch.randn(200, 2, 2, generator=g)                # grad[p, i, j] = d u_i / d x_j
    grad[:, 1, 1] = -grad[:, 0, 0]                            # div u = 0
    ux, uy, vx, vy = grad[:, 0, 0], grad[:, 0, 1], grad[:, 1, 0], grad[:, 1, 1]
    q = torch.stack((torch.zeros_like(ux), torch.zeros_like(ux), ux, (uy + vx) / 2, vx - uy), -1)
    theta = torch.rand(200, generator=g) * 2 * math.pi
    s, c = theta.sin(), theta.cos()
    zermelo = s * s * vx + s * c * (ux - vy) - c * c * uy
    _, rate = swimmer_rhs(q, theta, torch.tensor(-1.0), 0.7)
    assert torch.allclose(rate, zermelo, atol=1e-12)
    _, prolate = swimmer_rhs(q, theta, torch.tensor(1.0), 0.7)
    assert (prolate - zermelo).abs().max() > 0.5


def test_bilinear_interpolation_is_exact_for_bilinear_and_second_order():
    n, length = 32, 2 * math.pi
    h = length / n
    x = torch.arange(n) * h

    def field(xx, yy):
        return torch.sin(xx) * torch.cos(2 * yy)

    table = field(x[None, :], x[:, None]).reshape(-1, 1)  # rows (iy, ix)
    g = torch.Generator().manual_seed(1)
    pts = torch.rand(500, 2, generator=g) * 40 - 20  # far outside the box: periodic extension
    fi = torch.zeros(500, dtype=torch.int64)
    err = (bilinear_periodic(table, n, fi, pts, h)[:, 0] - field(pts[:, 0], pts[:, 1])).abs()
    assert err.max() <= h**2 / 8 * (1 + 4) + 1e-12  # (h^2/8)(max|f_xx| + max|f_yy|)
    x_fine = torch.arange(2 * n) * (h / 2)
    table2 = field(x_fine[None, :], x_fine[:, None]).reshape(-1, 1)
    err2 = bilinear_periodic(table2, 2 * n, fi, pts, h / 2)[:, 0] - field(pts[:, 0], pts[:, 1])
    assert 3.0 < err.max() / err2.abs().max() < 5.0  # second order: error / 4 when h / 2
    # exact at nodes and for a bilinear function within a cell
    nodes = torch.stack((x[[3, 7]], x[[5, 9]]), -1)
    vals = bilinear_periodic(table, n, fi[:2], nodes, h)[:, 0]
    assert torch.allclose(vals, field(nodes[:, 0], nodes[:, 1]), atol=1e-12)
    t1 = torch.tensor([[1.0], [2.0], [3.0], [5.0]])  # 2x2 grid values at (0,0),(1,0),(0,1),(1,1)
    got = bilinear_periodic(
        t1, 2, torch.zeros(1, dtype=torch.int64), torch.tensor([[0.25, 0.5]]), 1.0
    )
    assert got.item() == pytest.approx(
        0.75 * 0.5 * 1 + 0.25 * 0.5 * 2 + 0.75 * 0.5 * 3 + 0.25 * 0.5 * 5
    )


def test_sto_strain_turns_the_swimmer_towards_e_r():
    """With Lambda from eq:sto the strain torque Lambda S_np has the sign of -n_theta, so n_r
    never decreases; in a strain whose axes rotate (no fixed alignment) n -> +e_r."""
    g = torch.Generator().manual_seed(2)
    sto = ShortTimeOptimal(0.98)
    displacement = torch.randn(200, 2, generator=g)
    theta = torch.rand(200, generator=g) * 2 * math.pi
    q = torch.zeros(200, 5)
    n_r_old = compute_signals(q, theta, displacement, 1.0)[:, 0]
    dt = 0.01
    for i in range(3000):  # swimmer held in place: orientation dynamics only
        q[:, 2], q[:, 3] = math.cos(0.5 * i * dt), math.sin(0.5 * i * dt)
        sig = compute_signals(q, theta, displacement, tau_k=1.0)
        lam = sto(sig)[:, 0]
        turn = lam * sig[:, 3]
        assert torch.all(turn * sig[:, 1] <= 0)
        # non-decreasing, up to the Euler chatter of size (dt |S_np|)^2 / 2 once aligned
        assert torch.all(sig[:, 0] >= n_r_old - 1e-4)
        n_r_old = sig[:, 0]
        _, rate = swimmer_rhs(q, theta, lam, 0.0)
        theta = theta + dt * rate
    n_r = compute_signals(q, theta, displacement, 1.0)[:, 0]
    assert n_r.min() > 0.999


def test_signals_definitions():
    theta = torch.tensor([0.0, math.pi / 2, 0.3])
    disp = torch.tensor([[2.0, 0.0], [2.0, 0.0], [0.0, 0.0]])
    q = torch.tensor([[0.0, 0.0, 1.0, 0.0, 2.0]] * 3)
    sig = compute_signals(q, theta, disp, tau_k=0.5)
    assert sig[0, :2].tolist() == pytest.approx([1.0, 0.0])
    assert sig[1, :2].tolist() == pytest.approx([0.0, 1.0], abs=1e-12)  # n = e_theta
    assert sig[2, :2].tolist() == pytest.approx([1.0, 0.0])  # at the start point e_r := n
    # S_nn = S_xx cos 2 theta, S_np = -S_xx sin 2 theta, omega tau_K
    assert sig[1, 2:].tolist() == pytest.approx([-0.5, 0.0, 1.0], abs=1e-12)
