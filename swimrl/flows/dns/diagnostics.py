r"""Diagnostics of a DNS state, as plain functions of ``(grid, omega_hat)``.

Space means are evaluated in spectral space with Parseval's identity
$\langle ab\rangle = \sum_k w_k\,\mathrm{Re}(\hat a_k\overline{\hat b_k})/N^4$ (half plane,
weights $w_k$, :meth:`SpectralGrid.mean_product`), in float64. Every function reduces the two
spatial axes and returns one value per realisation (shape ``(B,)``) unless stated otherwise.

Budgets ($L = -\nu k^2 - \alpha k^{-2h}$; the nonlinearity conserves $E$ and $Z$):

$$
\begin{aligned}
\frac{\mathrm dE}{\mathrm dt} &= P_E - D_E - F_E, &
P_E &= \langle\psi f\rangle, &
D_E &= \nu\langle\omega^2\rangle = 2\nu Z,\\
&& F_E &= \alpha\sum w\,k^{-2h}|\hat\omega|^2/(k^2N^4), &&\\
\frac{\mathrm dZ}{\mathrm dt} &= P_Z - D_Z - F_Z, &
P_Z &= \langle\omega f\rangle, &
D_Z &= \nu\langle|\nabla\omega|^2\rangle = 2\nu P,\\
&& F_Z &= \alpha\sum w\,k^{-2h}|\hat\omega|^2/N^4 &&
\end{aligned}
$$

with $E = \langle|\boldsymbol u|^2\rangle/2$, $Z = \langle\omega^2\rangle/2$, palinstrophy
$P = \langle|\nabla\omega|^2\rangle/2$.
"""

from __future__ import annotations

import math

import torch

from swimrl.flows.dns.equation import Advection
from swimrl.flows.dns.grid import SpectralGrid
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.state import velocity_hat


def _sum(grid: SpectralGrid, weight: torch.Tensor | float, omega_hat: torch.Tensor) -> torch.Tensor:
    """``sum_k w_k weight_k |omega_hat_k|^2 / N^4`` in float64."""
    p = omega_hat.to(torch.complex128).abs() ** 2 * grid.weight.double()
    if not isinstance(weight, float):
        weight = weight.double()
    return (p * weight).sum(dim=(-2, -1)) / float(grid.n) ** 4


def _hypo(grid: SpectralGrid, h: float) -> torch.Tensor:
    k2 = grid.k2.double()
    return torch.where(k2 > 0, torch.where(k2 > 0, k2, 1.0) ** (-h), 0.0)


def energy(grid: SpectralGrid, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""$E = \langle|\boldsymbol u|^2\rangle/2 = \sum w\,|\hat\omega|^2/(2k^2N^4)$."""
    return 0.5 * _sum(grid, grid.inv_k2, omega_hat)


def enstrophy(grid: SpectralGrid, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""$Z = \langle\omega^2\rangle/2 = \sum w\,|\hat\omega|^2/(2N^4)$."""
    return 0.5 * _sum(grid, 1.0, omega_hat)


def palinstrophy(grid: SpectralGrid, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""$P = \langle|\nabla\omega|^2\rangle/2 = \sum w\,k^2|\hat\omega|^2/(2N^4)$."""
    return 0.5 * _sum(grid, grid.k2, omega_hat)


def energy_dissipation_rate(grid, params: DNSParams, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""Viscous $D_E = \nu\langle|\nabla\boldsymbol u|^2\rangle = 2\nu Z$."""
    return 2 * params.nu * enstrophy(grid, omega_hat)


def enstrophy_dissipation_rate(grid, params: DNSParams, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""Viscous $D_Z = \nu\langle|\nabla\omega|^2\rangle = 2\nu P$ (= enstrophy flux $\eta$ when
    steady)."""
    return 2 * params.nu * palinstrophy(grid, omega_hat)


def energy_friction_rate(grid, params: DNSParams, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""Hypo-friction $F_E = \alpha\sum w\,k^{-2h}|\hat\omega|^2/(k^2N^4)$."""
    return params.alpha * _sum(grid, _hypo(grid, params.hypo_power) * grid.inv_k2.double(),
                               omega_hat)


def enstrophy_friction_rate(grid, params: DNSParams, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""Hypo-friction $F_Z = \alpha\sum w\,k^{-2h}|\hat\omega|^2/N^4$."""
    return params.alpha * _sum(grid, _hypo(grid, params.hypo_power), omega_hat)


def scalar_summary(grid: SpectralGrid, params: DNSParams, omega_hat: torch.Tensor) -> dict:
    r"""All scalar diagnostics from one pass over $p_k = w_k|\hat\omega_k|^2/N^4$.

    $E = \sum p/(2k^2)$, $Z = \sum p/2$, $P = \sum k^2p/2$, $D_E = 2\nu Z$,
    $D_Z = 2\nu P$, $F_E = \alpha\sum k^{-2h}p/k^2$, $F_Z = \alpha\sum k^{-2h}p$,
    $u_\mathrm{rms} = (2E)^{1/2}$ and $\tau_K = (2Z)^{-1/2}$ (2D identities, tested against the
    definitions). Values are ``(B,)`` float64 tensors.
    """
    p = omega_hat.to(torch.complex128).abs() ** 2 * (grid.weight.double() / float(grid.n) ** 4)
    inv = grid.inv_k2.double()
    hyp = _hypo(grid, params.hypo_power)
    e = 0.5 * (p * inv).sum(dim=(-2, -1))
    z = 0.5 * p.sum(dim=(-2, -1))
    pal = 0.5 * (p * grid.k2.double()).sum(dim=(-2, -1))
    f_z = params.alpha * (p * hyp).sum(dim=(-2, -1))
    f_e = params.alpha * (p * hyp * inv).sum(dim=(-2, -1))
    return {"energy": e, "enstrophy": z, "palinstrophy": pal,
            "energy_dissipation": 2 * params.nu * z, "energy_friction": f_e,
            "enstrophy_dissipation": 2 * params.nu * pal, "enstrophy_friction": f_z,
            "u_rms": (2 * e).sqrt(), "tau_k": (2 * z).rsqrt()}


def energy_injection_rate(grid, omega_hat: torch.Tensor, f_hat: torch.Tensor) -> torch.Tensor:
    r"""$P_E = \langle\psi f\rangle = \sum w\,\mathrm{Re}(\hat\psi\overline{\hat f})/N^4$ at the
    given ``omega_hat``.

    For a step with forcing held constant, evaluate it at the mid-step vorticity
    $(\omega_n + \omega_{n+1})/2$ (Stratonovich/midpoint), which makes the forcing
    contribution to $E_{n+1} - E_n$ exact; its ensemble mean is $\epsilon$.
    """
    psi = omega_hat.to(torch.complex128) * grid.inv_k2.double()
    prod = (psi * f_hat.to(torch.complex128).conj()).real * grid.weight.double()
    return prod.sum(dim=(-2, -1)) / float(grid.n) ** 4


def enstrophy_injection_rate(grid, omega_hat: torch.Tensor, f_hat: torch.Tensor) -> torch.Tensor:
    r"""$P_Z = \langle\omega f\rangle = \sum w\,\mathrm{Re}(\hat\omega\overline{\hat f})/N^4$
    (midpoint, as above)."""
    w = omega_hat.to(torch.complex128)
    prod = (w * f_hat.to(torch.complex128).conj()).real * grid.weight.double()
    return prod.sum(dim=(-2, -1)) / float(grid.n) ** 4


def u_rms(grid: SpectralGrid, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""$u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}
    = \big(\sum w\,(|\hat u_x|^2 + |\hat u_y|^2)/N^4\big)^{1/2}$ (Sec. II B)."""
    ux, uy = velocity_hat(grid, omega_hat.to(torch.complex128))
    return (_sum(grid, 1.0, ux) + _sum(grid, 1.0, uy)).sqrt()


def tau_k(grid: SpectralGrid, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""Kolmogorov time
    $\tau_K = \langle\partial_i u_j\,\partial_i u_j\rangle^{-1/2} = \langle\omega^2\rangle^{-1/2}
    = (2Z)^{-1/2}$ (paper Sec. II B; the middle equality holds for 2D incompressible flow on a
    periodic box).
    """
    return (2 * enstrophy(grid, omega_hat)) ** -0.5


def _shells(grid: SpectralGrid) -> tuple[torch.Tensor, torch.Tensor, int]:
    dk = 2 * math.pi / grid.length
    idx = torch.round(grid.k2.double().sqrt() / dk).long()
    idx = torch.where(grid.mask, idx, -1)
    nk = int(idx.max()) + 1
    return idx, torch.arange(nk, dtype=torch.float64) * dk, nk


def _shell_sum(grid: SpectralGrid, density: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Sum ``density`` ``(B, N, N//2+1)`` (already Parseval-weighted) over shells ``|k| ~ j dk``."""
    idx, k, nk = _shells(grid)
    flat = density.reshape(density.shape[0], -1)
    sel = idx.reshape(-1) >= 0
    out = torch.zeros(flat.shape[0], nk, dtype=flat.dtype, device=flat.device)
    out.index_add_(1, idx.reshape(-1)[sel].to(flat.device), flat[:, sel])
    return k, out


def energy_spectrum(
    grid: SpectralGrid, omega_hat: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""Isotropic spectrum
    $E(k_j) = \sum_{|\boldsymbol k|\in\text{shell }j} w\,|\hat\omega|^2/(2k^2N^4)/\delta k$.

    Shells $(j - 1/2)\,\delta k \le |\boldsymbol k| < (j + 1/2)\,\delta k$, $\delta k = 2\pi/L$;
    returns $(k_j, E)$ with $E$ ``(B, n_shells)`` and $\sum_j E(k_j)\,\delta k = E$. Shells with
    $j > K$ (the 2/3 cutoff) are only partially populated (corners of the square truncation).
    """
    dk = 2 * math.pi / grid.length
    dens = 0.5 * omega_hat.to(torch.complex128).abs() ** 2 * (grid.weight * grid.inv_k2).double()
    k, e = _shell_sum(grid, dens / float(grid.n) ** 4)
    return k, e / dk


def spectral_fluxes(grid: SpectralGrid, omega_hat: torch.Tensor) -> tuple[torch.Tensor, ...]:
    r"""Nonlinear fluxes through $|\boldsymbol k|$:
    $\Pi_E(k) = -\sum_{|\boldsymbol k'|\le k} T_E$, same for $Z$.

    $T_Z(\boldsymbol k') = w\,\mathrm{Re}(\overline{\hat\omega}\hat N)/N^4$,
    $T_E = T_Z/k'^2$, $N$ the de-aliased advection term. Returns $(k, \Pi_E, \Pi_Z)$;
    $\Pi_Z \sim \eta$ in the direct cascade range.
    """
    n_hat = Advection(grid)(omega_hat)[0].to(torch.complex128)
    w = omega_hat.to(torch.complex128)
    t_z = (w.conj() * n_hat).real * grid.weight.double() / float(grid.n) ** 4
    k, tz = _shell_sum(grid, t_z)
    _, te = _shell_sum(grid, t_z * grid.inv_k2.double())
    return k, -te.cumsum(-1), -tz.cumsum(-1)


def standardized_pdf(
    x: torch.Tensor, bins: int = 81, half_width: float = 8.0
) -> tuple[torch.Tensor, torch.Tensor, float]:
    """Histogram PDF of ``x / std(x)`` (mean removed) on ``[-half_width, half_width]``.

    Returns ``(centres, density, std)``; ``density`` integrates to the fraction inside range.
    """
    x = x.detach().double().reshape(-1).cpu()
    x = x - x.mean()
    std = float(x.std())
    z = x / std
    hist = torch.histc(z, bins=bins, min=-half_width, max=half_width)
    width = 2 * half_width / bins
    centres = -half_width + width * (torch.arange(bins, dtype=torch.float64) + 0.5)
    return centres, hist.double() / (z.numel() * width), std


def gaussian_pdf(z: torch.Tensor) -> torch.Tensor:
    r"""Standard normal density $\exp(-z^2/2)/\sqrt{2\pi}$."""
    return torch.exp(-0.5 * z**2) / math.sqrt(2 * math.pi)


def moments(x: torch.Tensor) -> dict[str, float]:
    r"""Standardised moments: ``std``, skewness $\langle z^3\rangle$, flatness
    $\langle z^4\rangle$ (3 if Gaussian)."""
    x = x.detach().double().reshape(-1)
    z = x - x.mean()
    std = z.pow(2).mean().sqrt()
    z = z / std
    return {"std": float(std), "skewness": float(z.pow(3).mean()),
            "flatness": float(z.pow(4).mean())}
