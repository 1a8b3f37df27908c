"""The drag factor K(Lambda) of a fixed-volume spheroid against independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from scipy.integrate import quad

from swimrl.physics.energy import SERIES_BELOW, aspect_ratio, drag_factor


def shape_factor_of(aspect: float) -> float:
    """``Lambda = (lambda^2 - 1)/(lambda^2 + 1)``."""
    return (aspect**2 - 1) / (aspect**2 + 1)


def oberbeck_force(a1: float, a2: float, a3: float) -> float:
    """Stokes drag ``F/(mu v)`` of the ellipsoid with semi-axes ``(a1, a2, a3)`` translating along
    axis 1 (Oberbeck 1876; Lamb, *Hydrodynamics*, sec. 339): ``F = 16 pi mu v/(chi + a1^2 alpha1)``,
    ``chi = int_0^inf ds/Delta``, ``alpha1 = int_0^inf ds/((a1^2 + s) Delta)``,
    ``Delta = sqrt((a1^2 + s)(a2^2 + s)(a3^2 + s))``, by adaptive quadrature."""

    def delta(s: float) -> float:
        return math.sqrt((a1**2 + s) * (a2**2 + s) * (a3**2 + s))

    def integral(f) -> float:
        # s = (t/(1-t))^2 maps [0, 1) onto [0, inf), ds = 2t/(1-t)^3 dt; the integrands stay
        # bounded at t = 1 (1/Delta ~ s^{-3/2})
        def g(t: float) -> float:
            return f((t / (1 - t)) ** 2) * 2 * t / (1 - t) ** 3 if t < 1 else 0.0

        return quad(g, 0, 1, epsabs=0, epsrel=1e-13, limit=400)[0]

    chi = integral(lambda s: 1 / delta(s))
    alpha1 = integral(lambda s: 1 / ((a1**2 + s) * delta(s)))
    return 16 * math.pi / (chi + a1**2 * alpha1)


def test_oberbeck_integrals_give_stokes_drag_of_sphere():
    assert oberbeck_force(1.0, 1.0, 1.0) == pytest.approx(6 * math.pi, rel=1e-12)
    assert oberbeck_force(2.5, 2.5, 2.5) == pytest.approx(6 * math.pi * 2.5, rel=1e-12)


@pytest.mark.parametrize(
    "shape_factor",
    [-0.98, -0.9, -0.7, -0.4, -0.1, -0.02, -1e-3, 1e-3, 0.02, 0.1, 0.4, 0.7, 0.9, 0.98],
)
def test_drag_factor_equals_oberbeck_ellipsoid_at_fixed_volume(shape_factor):
    """``K = F/(6 pi mu a v)`` with ``a_par = lambda^{2/3}``, ``b = lambda^{-1/3}`` (``a = 1``)."""
    aspect = aspect_ratio(shape_factor)
    a_par, b = aspect ** (2 / 3), aspect ** (-1 / 3)
    assert a_par * b * b == pytest.approx(1.0, rel=1e-14)
    expected = oberbeck_force(a_par, b, b) / (6 * math.pi)
    assert drag_factor(shape_factor) == pytest.approx(expected, rel=1e-9)


def test_aspect_ratio_inverts_the_shape_factor():
    for aspect in (1e-3, 0.2, 1.0, 1.95, 10.0, 1e3):
        assert aspect_ratio(shape_factor_of(aspect)) == pytest.approx(aspect, rel=1e-9)
    t = torch.tensor([-0.5, 0.0, 0.5], dtype=torch.float64)
    assert torch.allclose(aspect_ratio(t), torch.tensor([3**-0.5, 1.0, 3**0.5], dtype=t.dtype))


def test_sphere_limit_and_smoothness_through_zero():
    """``K(0) = 1`` exactly (``F = 6 pi mu a v``), and near 0 ``K`` follows its Taylor
    polynomial ``1 - 2 Lambda/15 + c2 Lambda^2`` on both sides (one analytic curve), ``c2`` taken
    from a central second difference at the series/closed-form switch's scale."""
    assert drag_factor(0.0) == 1.0
    assert drag_factor(torch.zeros(3, dtype=torch.float64)).tolist() == [1.0, 1.0, 1.0]
    h = 0.02
    c2 = (drag_factor(h) + drag_factor(-h) - 2.0) / (2 * h * h)
    for lam in (1e-4, -1e-4, 1e-3, -1e-3, 1e-2, -1e-2):
        taylor = 1 - 2 * lam / 15 + c2 * lam**2
        assert drag_factor(lam) == pytest.approx(taylor, abs=abs(lam) ** 3)
        assert abs(drag_factor(lam) - 1) < abs(lam) / 7


def test_smooth_across_the_series_switch():
    """Third differences of ``K`` on a grid straddling ``|Lambda| = SERIES_BELOW``: a jump of
    ``delta`` between the two branches would leave ``~delta`` there; a smooth ``K`` leaves
    ``O(h^3 K''')``."""
    h = 1e-3
    for centre in (SERIES_BELOW, -SERIES_BELOW):
        grid = torch.tensor([centre + (k - 1.5) * h for k in range(4)], dtype=torch.float64)
        k = drag_factor(grid)
        third = (k[3] - 3 * k[2] + 3 * k[1] - k[0]).item()
        assert abs(third) < 1e-8


@pytest.mark.parametrize("aspect", [1e3, 1e4])
def test_slender_prolate_limit(aspect):
    """``F -> 4 pi mu a_par v/(ln(2 a_par/b) - 1/2)``. Expanding the exact form in
    ``1/lambda^2`` (``1 - e ~ 1/(2 lambda^2)``, ``l = ln(2 lambda)``):
    ``F/F_slender - 1 = -(3/2 - l/(2l - 1))/lambda^2 + O(1/(lambda^2 l^2))``, an error that
    shrinks like ``1/lambda^2``."""
    lam = shape_factor_of(aspect)
    aspect = aspect_ratio(lam)  # the lambda the code sees
    a_par, ell = aspect ** (2 / 3), math.log(2 * aspect)
    slender = 4 * math.pi * a_par / (ell - 0.5) / (6 * math.pi)
    correction = -(1.5 - ell / (2 * ell - 1)) / aspect**2
    assert drag_factor(lam) / slender - 1 == pytest.approx(correction, rel=0.02)


@pytest.mark.parametrize("aspect", [1e-3, 1e-4])
def test_thin_oblate_disk_limit(aspect):
    """Broadside disk of radius ``b``: ``F -> 16 mu b v``; expanding the exact form,
    ``F/(16 mu b v) - 1 = lambda^2/2 - (8/(3 pi)) lambda^3 + O(lambda^4)``."""
    lam = shape_factor_of(aspect)
    aspect = aspect_ratio(lam)
    disk = 16 * aspect ** (-1 / 3) / (6 * math.pi)
    correction = aspect**2 / 2 - 8 / (3 * math.pi) * aspect**3
    assert drag_factor(lam) / disk - 1 == pytest.approx(correction, rel=aspect)


def test_least_drag_at_aspect_ratio_near_1_95():
    """For axial translation at fixed volume the prolate spheroid of ``lambda ~ 1.95`` has the
    least drag (``K ~ 0.9555``)."""
    grid = torch.linspace(-0.98, 0.98, 19601, dtype=torch.float64)
    k = drag_factor(grid)
    best = grid[k.argmin()].item()
    assert aspect_ratio(best) == pytest.approx(1.95, abs=0.01)
    assert best == pytest.approx(shape_factor_of(1.95), abs=2e-3)
    assert k.min().item() == pytest.approx(0.95551, abs=2e-5)
    assert (k[grid < -1e-6] > 1).all() and k[grid.abs() < 1e-12].item() == 1.0


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_tensor_dtype_shape_and_values(dtype):
    lam = torch.linspace(-0.98, 0.98, 24, dtype=dtype).reshape(2, 3, 4)
    k = drag_factor(lam)
    assert k.dtype == dtype and k.shape == lam.shape and k.device == lam.device
    ref = np.array([drag_factor(float(v)) for v in lam.flatten().tolist()]).reshape(2, 3, 4)
    tol = 1e-6 if dtype == torch.float32 else 1e-14
    assert np.allclose(k.double().numpy(), ref, rtol=tol, atol=0)
    assert drag_factor(torch.tensor(0.3, dtype=dtype)).shape == ()
