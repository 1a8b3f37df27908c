r"""Energy cost of shape: the viscous drag of a fixed-volume spheroid swimming along its axis.

A spheroid of fixed volume (equal-volume sphere radius $a$), aspect ratio $\lambda$
(symmetry semi-axis over equatorial semi-axis, :func:`aspect_ratio`) swims at speed $v_s$
along its symmetry axis $\boldsymbol n$. The power it spends against viscous drag is

$$
P = F v_s = 6\pi\mu a\,v_s^2\,K(\Lambda),
$$

$K(\Lambda)$ (:func:`drag_factor`) the axial translational resistance of the no-slip spheroid
divided by the Stokes drag $6\pi\mu a$ of the equal-volume sphere ($K(0) = 1$; minimal,
$K = 0.9555$, for the prolate spheroid of $\lambda \approx 1.95$). swimrl reports the energy per
swimmer as

$$
\hat E = \frac1T\int_0^T K(\Lambda(t))\,\mathrm dt,
$$

the work against drag in units of $6\pi\mu a\,v_s^2 T$ (the equal-volume sphere swimming all
of $T$ has $\hat E = 1$). With weight $w$ the reward of decision $i$ loses
$w\,K(\Lambda_i)\,v_s T_u$, so the return in units of $v_s T$ is $\hat R - w\hat E$ (the
environment accumulates it; this module supplies $K$).

Left out: the dissipation of the swimmer rotating relative to the flow and of its
disturbance of the local strain (both depend on $\Lambda$ and on $\mathbb S$; only the translation
at $v_s$ relative to the fluid is counted), and the thrust-generation mechanism: the swimmer
is treated as towed at $v_s$, so $P$ is a lower bound on the power of a self-propelled
swimmer, in the spirit of Piro,
Vilfan, Golestanian & Mahault (2024), arXiv:2307.07301, who find a trade-off between
time-optimal paths and dissipation with the aspect ratio.
"""

from __future__ import annotations

import math

import torch

#: Below this ``|Lambda|`` (``e^2 < 0.02``) ``K`` is evaluated from its series in ``e^2``,
#: above it from the closed forms (whose cancellation costs ``~eps/e^2`` there, < 1e-14).
SERIES_BELOW = 0.01
_N_TERMS = 10  # (e^2)^10 < 1e-17 for |Lambda| < SERIES_BELOW

#: Prolate: ``S_p(x) = sum_{j>=0} 3(j+1)/((2j+1)(2j+3)) x^j``.
_PROLATE = tuple(3 * (j + 1) / ((2 * j + 1) * (2 * j + 3)) for j in range(_N_TERMS))
#: Oblate: ``S_o(x) = sum_{j>=0} 3 c_j/(2j+3) x^j``, ``c_j = binom(2j, j)/(4^j (2j+1))`` the
#: coefficients of ``arcsin e = sum_j c_j e^{2j+1}``.
_OBLATE = tuple(
    3 * math.comb(2 * j, j) / (4**j * (2 * j + 1) * (2 * j + 3)) for j in range(_N_TERMS)
)


def aspect_ratio(shape_factor: torch.Tensor | float) -> torch.Tensor | float:
    r"""Aspect ratio $\lambda = \sqrt{(1 + \Lambda)/(1 - \Lambda)}$, the inverse of
    $\Lambda = (\lambda^2 - 1)/(\lambda^2 + 1)$; $\Lambda$ in $(-1, 1)$."""
    if isinstance(shape_factor, torch.Tensor):
        return torch.sqrt((1 + shape_factor) / (1 - shape_factor))
    return math.sqrt((1 + shape_factor) / (1 - shape_factor))


def _horner(coeffs: tuple[float, ...], x: torch.Tensor) -> torch.Tensor:
    """``sum_j coeffs[j] x^j``."""
    out = torch.full_like(x, coeffs[-1])
    for c in reversed(coeffs[:-1]):
        out = out * x + c
    return out


def drag_factor(shape_factor: torch.Tensor | float) -> torch.Tensor | float:
    r"""Axial drag of the fixed-volume spheroid over that of the equal-volume sphere, $K(\Lambda)$.

    Semi-axes $a_\parallel = a\lambda^{2/3}$ (along $\boldsymbol n$) and $b = a\lambda^{-1/3}$ (so
    $a_\parallel b^2 = a^3$); eccentricity $e$, with $e^2 = 2|\Lambda|/(1 + |\Lambda|)$ on both
    sides. The exact resistances (Happel & Brenner, *Low Reynolds Number Hydrodynamics*,
    Prentice-Hall 1965, ch. 4, axisymmetric flow past prolate and oblate spheroids; Kim &
    Karrila, *Microhydrodynamics*, Butterworth-Heinemann 1991, ch. 3, the spheroid resistance
    function $X^A$, $F = 6\pi\mu a_\mathrm{major} X^A v$; checked against Oberbeck's ellipsoid
    integrals in ``tests/test_energy.py``), with $L = \ln\frac{1+e}{1-e}$:

    * prolate ($\Lambda > 0$, $e = \sqrt{1 - b^2/a_\parallel^2}$):

        $$
        F = \frac{16\pi\mu a_\parallel v\,e^3}{(1 + e^2) L - 2e},
        \quad\text{hence}\quad
        K = \frac{\tfrac83\,\lambda^{2/3} e^3}{(1 + e^2) L - 2e};
        $$

    * oblate ($\Lambda < 0$, $e = \sqrt{1 - a_\parallel^2/b^2}$, broadside):

        $$
        F = \frac{8\pi\mu b v\,e^3}{e\sqrt{1 - e^2} - (1 - 2e^2)\arcsin e},
        \quad\text{hence}\quad
        K = \frac{\tfrac43\,\lambda^{-1/3} e^3}{e\lambda - (1 - 2e^2)\arcsin e}.
        $$

    For $|\Lambda| <$ :data:`SERIES_BELOW` the brackets are summed as series,
    $K = \lambda^{2/3}/S_p(e^2)$ and $K = \lambda^{-1/3}/S_o(e^2)$, with
    $S_p(x) = 1 + 2x/5 + 9x^2/35 + \dots$ (from $L = 2\sum_k e^{2k+1}/(2k+1)$) and
    $S_o(x) = 1 + x/10 + 9x^2/280 + \dots$ (from
    $\frac{\mathrm d}{\mathrm de}\big[e\sqrt{1-e^2} - (1-2e^2)\arcsin e\big] = 4e\arcsin e$),
    so $K(0) = 1$ exactly and $K = 1 - 2\Lambda/15 + O(\Lambda^2)$
    on both sides. $L = 2\operatorname{log1p}(e) + 2\operatorname{atanh}(\Lambda)$
    ($1 - e^2 = \lambda^{-2}$) and $\arcsin e = \operatorname{atan2}(e, \lambda)$ keep the
    slender and disk limits accurate.

    $\Lambda$ in $(-1, 1)$. A tensor is evaluated in float64 on its device and returned in
    its dtype and shape; a float gives a float.

    Parameters
    ----------
    shape_factor
        $\Lambda$ in $(-1, 1)$, a tensor or a float.

    Returns
    -------
    torch.Tensor or float
        $K(\Lambda)$: 1 for the sphere, least (0.9555) at $\Lambda = 0.584$.
    """
    if not isinstance(shape_factor, torch.Tensor):
        return float(drag_factor(torch.tensor(float(shape_factor), dtype=torch.float64)))
    lam = shape_factor.to(torch.float64)
    mag = lam.abs()
    log_aspect = torch.atanh(lam)  # ln(lambda)
    x = 2 * mag / (1 + mag)  # e^2
    # series branch (|Lambda| < SERIES_BELOW)
    series = torch.where(
        lam > 0,
        torch.exp(2 / 3 * log_aspect) / _horner(_PROLATE, x),
        torch.exp(-log_aspect / 3) / _horner(_OBLATE, x),
    )
    # closed forms, evaluated away from e = 0 (the series holds there)
    xc = torch.clamp(x, min=2 * SERIES_BELOW / (1 + SERIES_BELOW))
    e = torch.sqrt(xc)
    log_c = torch.sign(lam) * torch.clamp(log_aspect.abs(), min=math.atanh(SERIES_BELOW))
    ell = 2 * torch.log1p(e) + 2 * log_c
    prolate = (8 / 3) * torch.exp(2 / 3 * log_c) * e**3 / ((1 + xc) * ell - 2 * e)
    aspect = torch.exp(log_c)  # sqrt(1 - e^2) on the oblate side
    # arcsin e = atan2(e, sqrt(1 - e^2)): well conditioned up to the disk (e -> 1)
    bracket = e * aspect - (1 - 2 * xc) * torch.atan2(e, aspect)
    oblate = (4 / 3) * torch.exp(-log_c / 3) * e**3 / bracket
    closed = torch.where(lam > 0, prolate, oblate)
    return torch.where(mag < SERIES_BELOW, series, closed).to(shape_factor.dtype)
