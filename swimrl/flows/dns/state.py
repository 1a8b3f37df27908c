r"""DNS state (the vorticity ``omega_hat``) and the kinematics derived from it.

Sign convention (the one of the paper's stochastic flow and of :mod:`swimrl.flows.fields`):

$$
\boldsymbol u = (\partial_y\psi, -\partial_x\psi),\qquad
\omega = \partial_x u_y - \partial_y u_x = -\nabla^2\psi
$$

so in Fourier space ($\hat\omega = \mathrm{rfft2}(\omega)$, unnormalised)

$$
\begin{aligned}
&\hat\psi = \hat\omega/k^2,\qquad \hat u_x = ik_y\hat\psi,\qquad \hat u_y = -ik_x\hat\psi,\\
&\hat S_{xx} = ik_x\hat u_x = -k_xk_y\hat\psi,\\
&\hat S_{xy} = (ik_y\hat u_x + ik_x\hat u_y)/2 = (k_x^2 - k_y^2)\,\hat\psi/2
\end{aligned}
$$

($S_{yy} = -S_{xx}$). The $k = 0$ mode of $\omega$ is zero (periodic box), and the mean flow
is zero ($\hat{\boldsymbol u}(0) = 0$).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from swimrl.flows.dns.grid import SpectralGrid


@dataclass
class DNSState:
    """Batched state: ``omega_hat`` ``(B, N, N//2+1)`` complex, time ``t`` and step counter."""

    omega_hat: torch.Tensor
    t: float = 0.0
    step: int = 0

    @property
    def batch(self) -> int:
        """Number of independent realisations ``B``."""
        return self.omega_hat.shape[0]

    def clone(self) -> DNSState:
        """Deep copy."""
        return DNSState(self.omega_hat.clone(), self.t, self.step)


def zero_state(grid: SpectralGrid, batch: int = 1) -> DNSState:
    r"""Fluid at rest: $\hat\omega = 0$ for ``batch`` realisations."""
    shape = (batch, *grid.spectral_shape)
    return DNSState(torch.zeros(shape, dtype=grid.complex_dtype, device=grid.device))


def state_from_vorticity(grid: SpectralGrid, omega: torch.Tensor) -> DNSState:
    r"""State from node values ``omega`` ``(B, N, N)``:
    $\hat\omega = \mathrm{mask}\cdot\mathrm{rfft2}(\omega)$.

    The $k = 0$ mode is removed (zero mean vorticity on a periodic box).
    """
    if omega.dim() == 2:
        omega = omega[None]
    w_hat = grid.truncate(grid.to_spectral(omega.to(grid.device, grid.dtype)))
    w_hat[..., 0, 0] = 0
    return DNSState(w_hat)


def random_state(
    grid: SpectralGrid,
    seeds: list[int] | tuple[int, ...],
    energy: float,
    k_peak: float,
) -> DNSState:
    r"""Random initial condition
    $\hat\omega = \mathrm{mask}\cdot k\exp(-(k/k_\mathrm{peak})^2)
    \cdot\mathrm{rfft2}(\text{white noise})$.

    Its energy spectrum is $E(k) \sim k\exp(-2(k/k_\mathrm{peak})^2)$. One realisation per seed
    (drawn in float64 on the CPU, so the same seed gives the same field for any dtype/device),
    rescaled to the energy $E = \langle|\boldsymbol u|^2\rangle/2$ = ``energy``.
    """
    cpu = SpectralGrid(grid.n, grid.length, "cpu", torch.float64)
    k = cpu.k_magnitude()
    amp = torch.where(k > 0, (k * torch.exp(-((k / k_peak) ** 2))), 0.0)  # |omega_hat| ~ k^{1}
    fields = []
    for seed in seeds:
        g = torch.Generator().manual_seed(int(seed))
        noise = torch.randn((grid.n, grid.n), generator=g, dtype=torch.float64)
        w_hat = cpu.truncate(torch.fft.rfft2(noise)) * amp
        w_hat[0, 0] = 0
        e = 0.5 * cpu.mean_product(w_hat * cpu.inv_k2, w_hat)
        fields.append(w_hat * (energy / e) ** 0.5 if e > 0 else w_hat)
    w = torch.stack(fields).to(grid.device, grid.complex_dtype)
    return DNSState(w)


def streamfunction_hat(grid: SpectralGrid, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""$\hat\psi = \hat\omega/k^2$ ($\omega = -\nabla^2\psi$; 0 at $k = 0$)."""
    return omega_hat * grid.inv_k2


def velocity_hat(grid: SpectralGrid, omega_hat: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    r"""$(\hat u_x, \hat u_y) = (ik_y\hat\psi, -ik_x\hat\psi)$."""
    psi = streamfunction_hat(grid, omega_hat)
    return 1j * grid.ky * psi, -1j * grid.kx * psi


def channels_hat(grid: SpectralGrid, omega_hat: torch.Tensor) -> torch.Tensor:
    r"""Spectral channels ``(B, 5, N, N//2+1)``: $u_x, u_y, S_{xx}, S_{xy}, \omega$ (formulas
    above)."""
    psi = streamfunction_hat(grid, omega_hat)
    kx, ky = grid.kx, grid.ky
    return torch.stack(
        (
            1j * ky * psi,
            -1j * kx * psi,
            -(kx * ky) * psi,
            0.5 * (kx * kx - ky * ky) * psi,
            omega_hat,
        ),
        dim=-3,
    )


def flow_channels(
    state_or_omega_hat: DNSState | torch.Tensor,
    grid: SpectralGrid | None = None,
    cutoff: int | None = None,
) -> torch.Tensor:
    r"""Node values of $(u_x, u_y, S_{xx}, S_{xy}, \omega)$, shape ``(B, N, N, 5)``,
    ``[b, iy, ix, c]``.

    Nodes $x_j = jL/N$ (:data:`swimrl.flows.fields.CHANNELS` order); computed exactly (to
    round-off) by spectral differentiation of the truncated $\hat\omega$. ``grid`` defaults to
    a grid inferred from the shape (box $2\pi$, same device/dtype). ``cutoff``: $\hat\omega$
    is zero for $m_x >$ ``cutoff``, so the inverse transform along $y$ runs on the
    ``cutoff + 1`` columns that hold modes only (a pruned ``irfft2``, the same numbers in
    ~60 % of the time at $512^2$ with the 2/3 rule).
    """
    w_hat = state_or_omega_hat.omega_hat if isinstance(state_or_omega_hat, DNSState) else (
        state_or_omega_hat
    )
    squeeze = w_hat.dim() == 2
    if squeeze:
        w_hat = w_hat[None]
    if grid is None:
        real = torch.float64 if w_hat.dtype == torch.complex128 else torch.float32
        grid = _cached_grid(w_hat.shape[-2], w_hat.device, real)
    if cutoff is None:
        q = grid.to_physical(channels_hat(grid, w_hat))  # (B, 5, N, N)
    else:
        c = cutoff + 1
        sub = SpectralGridColumns(grid, c)
        rows = torch.fft.ifft(channels_hat(sub, w_hat[..., :c]), dim=-2)  # (B, 5, N, c)
        q = torch.fft.irfft(rows, n=grid.n, dim=-1)
    q = q.permute(0, 2, 3, 1).contiguous()
    return q[0] if squeeze else q


class SpectralGridColumns:
    """The wavenumbers of the first ``columns`` ``m_x`` columns of ``grid`` (what
    :func:`channels_hat` needs)."""

    def __init__(self, grid: SpectralGrid, columns: int):
        self.kx, self.ky = grid.kx[:, :columns], grid.ky
        self.inv_k2 = grid.inv_k2[:, :columns]


_GRIDS: dict[tuple, SpectralGrid] = {}


def _cached_grid(n: int, device: torch.device, dtype: torch.dtype) -> SpectralGrid:
    key = (n, str(device), dtype)
    if key not in _GRIDS:
        _GRIDS[key] = SpectralGrid(n, device=device, dtype=dtype)
    return _GRIDS[key]
