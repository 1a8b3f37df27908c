r"""The vorticity equation split into its stiff linear part and the advective nonlinearity.

$$
\partial_t\hat\omega = L(k)\,\hat\omega + N(\hat\omega) + \hat f
$$

with

$$
L(k) = -\nu k^2 - \alpha k^{-2h}
$$

(viscosity $\nu\nabla^2$ and hypo-friction $-\alpha(-\nabla^2)^{-h}$; $L(0) = 0$, the $k = 0$
mode being identically zero) and

$$
N(\hat\omega) = -P_K\,\mathrm{FFT}[\boldsymbol u\cdot\nabla\omega]
= -P_K\big(ik_x\,\mathrm{FFT}[u_x\omega] + ik_y\,\mathrm{FFT}[u_y\omega]\big)
$$

(divergence form, $\nabla\cdot\boldsymbol u = 0$; $P_K$ is the 2/3-rule projection of
:mod:`swimrl.flows.dns.grid`). With $\boldsymbol u = (\partial_y\psi, -\partial_x\psi)$ one
has $\boldsymbol u\cdot\nabla\omega = -J(\psi, \omega)$,
$J(a, b) = \partial_x a\,\partial_y b - \partial_y a\,\partial_x b$; with the geophysical
stream function $\psi_g = -\psi$ this is the usual $+J(\psi_g, \omega)$. The truncated
nonlinearity conserves energy $\sum|\hat\omega|^2/k^2$ and enstrophy $\sum|\hat\omega|^2$
exactly (Galerkin truncation), so only $L$ and $f$ change them.
"""

from __future__ import annotations

import torch

from swimrl.flows.dns.grid import SpectralGrid
from swimrl.flows.dns.params import DNSParams


def linear_operator(grid: SpectralGrid, params: DNSParams) -> torch.Tensor:
    r"""$L(k) = -\nu k^2 - \alpha k^{-2h}$ on the spectral grid, $L(0) = 0$; float64, CPU.

    Kept in float64 so that the exponential-integrator coefficients are computed accurately.
    """
    k2 = grid.k2.double().cpu()
    hypo = torch.where(k2 > 0, torch.where(k2 > 0, k2, 1.0) ** (-params.hypo_power), 0.0)
    return -params.nu * k2 - params.alpha * hypo


class Advection:
    r"""The de-aliased nonlinear term
    $N(\hat\omega) = -P_K\,\mathrm{FFT}[\boldsymbol u\cdot\nabla\omega]$.

    Two algebraically identical forms (``form``):

    * ``"basdevant"`` (default, 4 FFTs: 2 inverse, 2 forward; Basdevant 1983). With
      $\nabla\cdot\boldsymbol u = 0$,
      $\boldsymbol u\cdot\nabla\omega = \partial_x\partial_y(v^2 - u^2) +
      (\partial_x^2 - \partial_y^2)(uv)$, so

        $$
        \hat N = P_K\big[k_xk_y\,\mathrm{FFT}(v^2 - u^2)
        + (k_x^2 - k_y^2)\,\mathrm{FFT}(uv)\big];
        $$

    * ``"divergence"`` (5 FFTs: 3 inverse, 2 forward):
      $\hat N = -P_K\big(ik_x\,\mathrm{FFT}[u\omega] + ik_y\,\mathrm{FFT}[v\omega]\big)$.

    Here $(u, v) = (u_x, u_y) = \mathrm{IFFT}(ik_y\hat\psi, -ik_x\hat\psi)$ with
    $\hat\psi = \hat\omega/k^2$. Both products are of fields band-limited to the retained
    modes, so with the 2/3 rule both forms give the same alias-free Galerkin truncation (equal
    to round-off; tested).

    ``__call__(omega_hat, want_speed)`` returns ``(N_hat, speed)`` where
    $\mathrm{speed} = \max_{\boldsymbol x}(|u_x| + |u_y|)$ per realisation (``(B,)``) if
    ``want_speed`` else ``None``; the stepper uses it for the CFL check. The multipliers are
    precomputed as complex tensors with the 2/3 mask folded in (complex-by-complex products
    are the fastest on CPU), and each field is transformed on its own (faster than one stacked
    transform on CPU).
    """

    FORMS = ("basdevant", "divergence")

    def __init__(self, grid: SpectralGrid, form: str = "basdevant"):
        if form not in self.FORMS:
            raise ValueError(f"advection form={form!r} not allowed: choose one of {self.FORMS}")
        self.grid = grid
        self.form = form
        cd = grid.complex_dtype
        self._inv_k2 = grid.inv_k2.to(cd)
        self._iky = (1j * grid.ky).to(cd)  # (N, 1)
        self._mikx = (-1j * grid.kx).to(cd)  # (1, N//2+1)
        mask = grid.mask.to(grid.dtype)
        if form == "divergence":
            self._mikx_mask = (-1j * grid.kx * mask).to(cd)  # (N, N//2+1)
            self._miky_mask = (-1j * grid.ky * mask).to(cd)
        else:
            self._kxky_mask = (grid.kx * grid.ky * mask).to(cd)
            self._kx2_ky2_mask = ((grid.kx**2 - grid.ky**2) * mask).to(cd)

    def __call__(
        self, omega_hat: torch.Tensor, want_speed: bool = False
    ) -> tuple[torch.Tensor, torch.Tensor | None]:
        phys = self.grid.to_physical
        psi = omega_hat * self._inv_k2
        ux = phys(psi * self._iky)
        uy = phys(psi * self._mikx)
        speed = None
        if want_speed:
            speed = (ux.abs() + uy.abs()).amax(dim=(-2, -1))
        spec = self.grid.to_spectral
        if self.form == "divergence":
            w = phys(omega_hat)
            fx = spec(ux.mul_(w))
            fy = spec(uy.mul_(w))
            return fx.mul_(self._mikx_mask).add_(fy.mul_(self._miky_mask)), speed
        uv_hat = spec(ux * uy)
        v2_u2 = (uy + ux).mul_(uy.sub_(ux))  # v^2 - u^2 = (v + u)(v - u)
        return spec(v2_u2).mul_(self._kxky_mask).add_(uv_hat.mul_(self._kx2_ky2_mask)), speed
