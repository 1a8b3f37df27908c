r"""The 2D stochastic flow of the paper (Sec. II B, App. A), batched over realisations.

Units: ``ell_f = u_rms = 1``. The stream function is

``psi(x, t) = sum_{i=1..M} c_i(t) psi_i(x)``,   ``u = (d_y psi, -d_x psi)``,

with independent Gaussian components of covariance
``<psi_i(x) psi_j(x')> = delta_ij A exp(-|x - x'|^2 / 2)``, ``A = u_rms^2 ell_f^2 / 2``,
and Ornstein-Uhlenbeck coefficients ``<c_i(t) c_j(t')> = delta_ij/M exp(-|t - t'|/tau_f)``,
``tau_f = Ku ell_f / u_rms``.

Kolmogorov time of this model (derivation; ``C(r) = A exp(-r^2/2 ell^2)``). Moments of
derivatives of a stationary Gaussian field follow from derivatives of ``C`` at ``r = 0``:
``<psi_x^2> = -C_xx(0) = A/ell^2``, ``<psi_xx^2> = C_xxxx(0) = 3A/ell^4``,
``<psi_xy^2> = <psi_xx psi_yy> = C_xxyy(0) = A/ell^4``. Hence, summing ``<c_i^2> = 1/M``
over the ``M`` components,

* ``<u.u> = <psi_x^2> + <psi_y^2> = 2A/ell^2 = u_rms^2`` (consistent normalisation);
* ``<A_ij A_ij> = <psi_xx^2> + <psi_yy^2> + 2 <psi_xy^2> = 8A/ell^4 = 4 u_rms^2 / ell^2``;

so ``tau_K = <A_ij A_ij>^{-1/2} = ell_f / (2 u_rms) = 0.5``. Component-wise,
``<S_xx^2> = <S_xy^2> = u_rms^2/(2 ell^2)`` and ``<omega^2> = 4 u_rms^2/ell^2``.

Generation (exact discrete covariance): with ``P_k`` the discrete spectrum of the
periodically summed covariance (:func:`gaussian_spectrum`), a white field ``w`` gives
``psi = IFFT(sqrt(P) FFT(w))``, whose covariance on the grid is the circular
autocorrelation ``IFFT(P) = sum_n C(x - x' + n L)``; for ``L = 10 ell_f`` the periodic
images change ``C`` by less than ``2 e^{-12.5} A`` anywhere.
Derivatives are spectral: ``psi_x = IFFT(i k_x psi_hat)``.

OU update (exact for any step): ``c(t+dt) = c(t) e^{-dt/tau_f} + sqrt((1 - e^{-2 dt/tau_f})/M) xi``,
``xi ~ N(0, 1)``; ``c(0)`` is drawn from the stationary law ``N(0, 1/M)``.

Readings of the specification (options; the defaults are the paper's text as written,
issue 11 item 6 evaluates the others at Ku = 1e7, ``docs/results.md``):

* ``basis``: ``"redrawn"`` (default) draws new components ``psi_i`` with every realisation
  (every flow of an evaluation, every episode of training); ``"fixed"`` draws one set of
  ``M`` components from its own generator seeded with ``basis_seed`` and gives it to every
  realisation, which then differ only by ``c_i`` (the paper's "at the start of each
  episode, the flow coefficients ``c_i`` [...] are randomly sampled"). The ensemble is then
  conditional on one draw of the ``psi_i``: ``<u.u>`` and ``tau_K`` hold on average over
  ``basis_seed``, not for each.
* ``amplitudes``: ``"stationary"`` (default) ``c(0) ~ N(0, 1/M)``; ``"normalised"``
  ``c(0) = xi / |xi|`` with the same ``xi ~ N(0, 1)`` (uniform on the unit sphere), so
  ``sum_i c_i(0)^2 = 1`` in every realisation while ``<c_i^2> = 1/M`` still holds: the
  ensemble ``u_rms`` and ``tau_K`` are unchanged, only the realisation-to-realisation
  spread of the flow's energy is removed. The OU steps that follow are unchanged (at
  Ku = 1e7 each ``c_i`` diffuses by ``(2 T / (tau_f M))^{1/2} ~ 2e-3`` over an episode).
* ``velocity_scale``: ``"total"`` (default) ``u_rms = <u.u>^{1/2}``; ``"component"``: the
  velocity ``v_s`` and the Kubo number are measured against the one-component rms
  ``<u_x^2>^{1/2} = u_rms / sqrt(2)``. The fields are the same; :attr:`u_rms` (the
  reference velocity the environment scales ``v_s`` by) becomes ``1/sqrt(2)`` and
  ``tau_f = Ku ell_f / (u_rms / sqrt(2))``. So ``v_s = 0.707`` reads ``0.5 <u.u>^{1/2}`` and
  Ku reads ``Ku sqrt(2)`` in the default's units; ``tau_K = 0.5`` is unchanged.
* The box ``L = n_grid * spacing`` (10 ``ell_f`` by default) is set by ``n_grid``.
"""

from __future__ import annotations

import math

import torch

from swimrl.flows.base import GriddedFlow
from swimrl.flows.grid import PeriodicGrid

#: Kolmogorov time of the model in units ell_f / u_rms (see module docstring).
TAU_K = 0.5

#: Options of :class:`StochasticFlow` (readings of the paper's text; first = default).
BASIS_MODES = ("redrawn", "fixed")
AMPLITUDE_MODES = ("stationary", "normalised")
VELOCITY_SCALES = ("total", "component")


def gaussian_spectrum(grid: PeriodicGrid, amplitude: float, ell: float, device) -> torch.Tensor:
    """Discrete power spectrum ``P_k = (2 pi ell^2 / h^2) amplitude exp(-k^2 ell^2 / 2)``.

    This is the FFT (unnormalised, node spacing ``h``) of the periodic sum of
    ``C(r) = amplitude exp(-r^2 / 2 ell^2)``, up to aliasing of modes beyond the Nyquist
    wavenumber (relative size ``exp(-(pi ell / h)^2 / 2)``, i.e. nil for ``h << ell``).
    The analytic form avoids the round-off floor of a numerically transformed covariance,
    which the ``k^4`` of second derivatives would amplify.
    """
    kx, ky = grid.wavenumbers(device=device, dtype=torch.float64)
    k2 = kx**2 + ky**2
    return (2 * math.pi * ell**2 / grid.spacing**2) * amplitude * torch.exp(-0.5 * k2 * ell**2)


def stream_function_channels(psi_hat: torch.Tensor, grid: PeriodicGrid) -> torch.Tensor:
    """Channels ``(u_x, u_y, S_xx, S_xy, omega)`` of stream functions given by their FFT.

    ``u_x = psi_y``, ``u_y = -psi_x``, ``S_xx = psi_xy``, ``S_xy = (psi_yy - psi_xx)/2``,
    ``omega = -(psi_xx + psi_yy)``. Input ``(..., n, n)`` complex; output ``(..., n, n, 5)``.
    """
    kx, ky = grid.wavenumbers(device=psi_hat.device, dtype=torch.float64)

    def ifft(f):
        return torch.fft.ifft2(f).real

    psi_x = ifft(1j * kx * psi_hat)
    psi_y = ifft(1j * ky * psi_hat)
    psi_xx = ifft(-kx * kx * psi_hat)
    psi_yy = ifft(-ky * ky * psi_hat)
    psi_xy = ifft(-kx * ky * psi_hat)
    return torch.stack((psi_y, -psi_x, psi_xy, 0.5 * (psi_yy - psi_xx), -(psi_xx + psi_yy)), -1)


class StochasticFlow(GriddedFlow):
    """``n_flows`` independent realisations of the stochastic flow at Kubo number ``kubo``.

    Each realisation has its own ``M`` components ``psi_i`` and coefficients ``c_i``;
    :meth:`reset` redraws both for the selected flows (with ``basis="fixed"``: only the
    ``c_i``, every realisation sharing one set of ``psi_i``). ``amplitudes`` and
    ``velocity_scale``: see the module docstring.
    """

    u_rms = 1.0
    tau_k = TAU_K
    ell_f = 1.0

    def __init__(
        self,
        n_flows: int,
        kubo: float,
        n_modes: int = 5,
        n_grid: int = 400,
        spacing: float = 0.025,
        device: torch.device | str = "cpu",
        dtype: torch.dtype = torch.float32,
        generator: torch.Generator | None = None,
        basis: str = "redrawn",
        basis_seed: int = 0,
        amplitudes: str = "stationary",
        velocity_scale: str = "total",
    ):
        for name, value, allowed in (("basis", basis, BASIS_MODES),
                                     ("amplitudes", amplitudes, AMPLITUDE_MODES),
                                     ("velocity_scale", velocity_scale, VELOCITY_SCALES)):
            if value not in allowed:
                raise ValueError(f"{name}={value!r} must be one of {allowed}")
        grid = PeriodicGrid(n_grid, n_grid * spacing)
        super().__init__(grid, n_flows, n_modes, device, dtype)
        self.kubo = float(kubo)
        self.amplitudes = amplitudes
        self.velocity_scale = velocity_scale
        # the fields always have <u.u>^{1/2} = 1; u_rms is the reference velocity of v_s and Ku
        self.u_rms = 1.0 if velocity_scale == "total" else math.sqrt(0.5)
        self.tau_f = self.kubo * self.ell_f / self.u_rms
        self.generator = generator
        amplitude = 0.5 * self.ell_f**2  # A = u_rms^2 ell_f^2 / 2 with <u.u> = 1
        self._sqrt_spectrum = gaussian_spectrum(grid, amplitude, self.ell_f, self.device).sqrt()
        self.fixed_basis: torch.Tensor | None = None
        if basis == "fixed":
            own = torch.Generator(device=self.device).manual_seed(int(basis_seed))
            self.fixed_basis = self.draw_components(1, own)
        self.reset()

    def _randn(self, *shape: int, dtype=None, generator=None) -> torch.Tensor:
        return torch.randn(*shape, device=self.device, dtype=dtype or self.dtype,
                           generator=generator or self.generator)

    def draw_components(self, count: int, generator: torch.Generator | None = None
                        ) -> torch.Tensor:
        """Channels of ``count * M`` fresh components: ``(count, n, n, M, 5)`` in ``self.dtype``
        (from ``generator``, default the flow's)."""
        n, m = self.grid.n, self.n_basis
        out = torch.empty(count, n, n, m, 5, device=self.device, dtype=self.dtype)
        per = max(1, 2**22 // (m * n * n))  # flows per batch: bounds the float64 work memory
        for f0 in range(0, count, per):
            f1 = min(count, f0 + per)
            w = self._randn(f1 - f0, m, n, n, dtype=torch.float64, generator=generator)
            psi_hat = self._sqrt_spectrum * torch.fft.fft2(w)
            q = stream_function_channels(psi_hat, self.grid).permute(0, 2, 3, 1, 4)
            out[f0:f1] = q.to(self.dtype)
        return out

    def reset(self, flows: torch.Tensor | None = None) -> None:
        """Redraw components (unless fixed) and coefficients ``c_i(0)`` of selected flows."""
        if flows is None:
            idx = torch.arange(self.n_flows, device=self.device)
        else:
            idx = flows.nonzero().flatten()
        if idx.numel() == 0:
            return
        if self.fixed_basis is None:
            self.basis[idx] = self.draw_components(idx.numel())
        else:
            self.basis[idx] = self.fixed_basis
        xi = self._randn(idx.numel(), self.n_basis)
        if self.amplitudes == "stationary":
            self.coeffs[idx] = xi / math.sqrt(self.n_basis)
        else:
            xi = xi.double()
            self.coeffs[idx] = (xi / xi.norm(dim=1, keepdim=True)).to(self.dtype)
        self.time[idx] = 0.0

    def ou_factors(self, dt: float) -> tuple[float, float]:
        """``(e^{-dt/tau_f}, sqrt((1 - e^{-2 dt/tau_f}) / M))`` computed in double precision."""
        decay = math.exp(-dt / self.tau_f)
        return decay, math.sqrt(-math.expm1(-2 * dt / self.tau_f) / self.n_basis)

    def advance(self, dt: float) -> None:
        """Exact OU step of all coefficients: ``c <- c e^{-dt/tau_f} + sigma_dt xi``."""
        decay, sigma = self.ou_factors(dt)
        noise = self._randn(self.n_flows, self.n_basis)
        self.coeffs.mul_(decay).add_(noise, alpha=sigma)
        self.time += dt


def kubo_label(kubo: float) -> str:
    """``0.1``, ``1``, ``10``, ``1e7``: the Kubo number as the shipped policies and records
    name it (``%g`` without the exponent's ``+0``)."""
    return f"{float(kubo):g}".replace("e+0", "e").replace("e+", "e")
