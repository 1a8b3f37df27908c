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

Band limit (speed, same draws): ``sqrt(P_k)`` falls as ``exp(-k^2 ell^2 / 4)``, so only the
modes ``|m_x|, |m_y| <= K`` carry the fields (:func:`band_limit`: every dropped mode has
``sqrt(P_k) max(1, k^2 ell^2) <= 1e-13`` of the peak; ``K = 18`` of 200 at the default
``L = 10``, ``n = 400``). :class:`BandLimitedSynthesis` evaluates the same
``IFFT(m_k sqrt(P) FFT(w))`` as direct sums over those modes (dense float64 products, the
last one in the flow's dtype, instead of full FFTs): the same white field ``w``, hence the
same realisation, to round-off (float64 plus the dropped ``1e-13``; a few float32 ulps for
float32 flows); several times faster at the default grid.

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

from swimrl.conf_values import yaml_value
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


def band_limit(grid: PeriodicGrid, ell: float, tol: float = 1e-13) -> int | None:
    """Smallest ``K`` such that every mode with ``max(|m_x|, |m_y|) > K`` has
    ``exp(-k^2 ell^2 / 4) max(1, k^2 ell^2) <= tol * max_k(...)`` (``k = 2 pi m / L``);
    ``None`` when no ``K < n/2 - 1`` does (coarse grids: use the full FFT)."""
    def weight(k2: float) -> float:
        return math.exp(-0.25 * k2 * ell**2) * max(1.0, k2 * ell**2)

    peak = weight(4.0 / ell**2)  # max of exp(-x/4) max(1, x) at x = k^2 ell^2 = 4
    dk = 2 * math.pi / grid.length
    for k_keep in range(grid.n // 2 - 1):
        # the dropped modes' smallest |k| is (K + 1) dk; weight decreases beyond k ell = 2
        k_drop = (k_keep + 1) * dk
        if k_drop * ell >= 2 and weight(k_drop**2) <= tol * peak:
            return k_keep
    return None


class OUCoefficients:
    """The ``M`` Ornstein-Uhlenbeck coefficients ``c_i(t)`` of a flow, ``(n_flows, M)`` in
    ``self.coeffs``, correlation time ``self.tau_f``, stationary variance ``1/M``: the time
    dependence shared by the 2D (:class:`StochasticFlow`) and 3D
    (:class:`~swimrl.flows.stochastic3d.StochasticFlow3D`) stochastic flows."""

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


class BandLimitedSynthesis:
    """``stream_function_channels(sqrt(P) FFT2(w))`` of real white fields ``w`` by direct
    sums over the retained modes ``|m_y| <= K`` (complex) and ``0 <= m_x <= K`` (real
    symmetry, weights ``1, 2, 2, ...``):

    ``W(m) = sum_{j} w_j e^{-2 pi i m.j / n}``;
    ``q_c(j) = n^{-2} Re sum_{m_y} sum_{m_x >= 0} a_{m_x} mult_c(m) sqrt(P_m) W(m)
    e^{2 pi i m.j / n}``,

    with the channel multipliers ``mult = (i k_y, -i k_x, -k_x k_y, (k_x^2 - k_y^2)/2,
    k_x^2 + k_y^2)`` of :func:`stream_function_channels`. In float64 up to the last sum (in
    ``dtype``, see :meth:`__call__`); fields are indexed ``[y, x]`` as
    :meth:`PeriodicGrid.wavenumbers`.
    """

    def __init__(self, grid: PeriodicGrid, sqrt_spectrum: torch.Tensor, k_keep: int,
                 dtype: torch.dtype = torch.float32):
        n, dev = grid.n, sqrt_spectrum.device
        f64 = torch.float64
        j = torch.arange(n, device=dev, dtype=torch.int64)
        m_x = torch.arange(k_keep + 1, device=dev, dtype=torch.int64)
        m_y = torch.arange(-k_keep, k_keep + 1, device=dev, dtype=torch.int64) % n

        def angles(m: torch.Tensor) -> torch.Tensor:  # 2 pi (m j mod n) / n, exact reduction
            return (2 * math.pi / n) * ((m[:, None] * j[None, :]) % n).to(f64)

        ax, ay = angles(m_x), angles(m_y)                               # (K+1, n), (2K+1, n)
        # forward along x: w @ [cos, -sin] -> (.., n_y, 2(K+1)), read as complex (.., n_y, K+1)
        self.fwd_x = torch.stack((ax.cos().T, -ax.sin().T), -1).reshape(n, 2 * (k_keep + 1))
        self.fwd_y = torch.polar(torch.ones_like(ay), -ay)              # (2K+1, n)
        self.inv_y = torch.polar(torch.ones_like(ay), ay).T.contiguous()  # (n, 2K+1)
        weights = torch.full((k_keep + 1, 1), 2.0, device=dev, dtype=f64)
        weights[0] = 1.0
        weights = weights / n**2
        # inverse along x, real part: [a cos, -a sin] @ [Re G; Im G], the last sum in dtype
        self.inv_x = torch.cat((weights * ax.cos(), -weights * ax.sin()), 0).T.to(dtype)
        self.dtype = dtype
        kx, ky = grid.wavenumbers(device=dev, dtype=f64)
        kx, ky = kx[m_y][:, m_x], ky[m_y][:, m_x]
        zero = torch.zeros_like(kx)
        mult = torch.stack((torch.complex(zero, ky), torch.complex(zero, -kx),
                            torch.complex(-kx * ky, zero),
                            torch.complex(0.5 * (kx**2 - ky**2), zero),
                            torch.complex(kx**2 + ky**2, zero)))        # (5, 2K+1, K+1)
        self.filter = mult * sqrt_spectrum[m_y][:, m_x]

    def __call__(self, w: torch.Tensor, out: torch.Tensor | None = None) -> torch.Tensor:
        """Channels of the real white fields ``w`` ``(B, M, n, n)`` in the basis layout
        ``(B, n_y, n_x, M, 5)`` (written into ``out`` if given), in ``dtype``: float64 sums
        up to the last one, the sum over ``m_x``, which is in ``dtype`` (float32: a few
        float32 ulps from the float64 result)."""
        z = torch.view_as_complex((w @ self.fwd_x).unflatten(-1, (-1, 2)).contiguous())
        spec = (self.fwd_y @ z).unsqueeze(-3) * self.filter            # (B, M, 5, 2K+1, K+1)
        g = self.inv_y @ spec                                           # (B, M, 5, n_y, K+1)
        g = torch.cat((g.real, g.imag), -1).permute(0, 3, 4, 1, 2)      # (B, n_y, 2K+2, M, 5)
        g = g.reshape(*g.shape[:3], -1).to(self.dtype)
        b, n, m = w.shape[0], w.shape[-1], w.shape[1]
        if out is None:
            out = torch.empty(b, n, n, m, 5, device=w.device, dtype=self.dtype)
        torch.matmul(self.inv_x, g, out=out.view(b, n, n, m * 5))       # (B, n_y, n_x, M*5)
        return out


class StochasticFlow(OUCoefficients, GriddedFlow):
    """``n_flows`` independent realisations of the stochastic flow at Kubo number ``kubo``.

    Each realisation has its own ``M`` components ``psi_i`` and coefficients ``c_i``;
    :meth:`reset` redraws both for the selected flows (with ``basis="fixed"``: only the
    ``c_i``, every realisation sharing one set of ``psi_i``). ``amplitudes`` and
    ``velocity_scale``: see the module docstring. The keyword defaults (for library calls)
    are read from ``conf/flow/stochastic.yaml`` (``device``: ``conf/evaluate.yaml``;
    :mod:`swimrl.conf_values`).
    """

    u_rms = 1.0
    tau_k = TAU_K
    ell_f = 1.0

    def __init__(
        self,
        n_flows: int,
        kubo: float,
        n_modes: int = yaml_value("flow/stochastic", "n_modes"),
        n_grid: int = yaml_value("flow/stochastic", "n_grid"),
        spacing: float = yaml_value("flow/stochastic", "spacing"),
        device: torch.device | str = yaml_value("evaluate", "device"),
        dtype: torch.dtype = torch.float32,
        generator: torch.Generator | None = None,
        basis: str = yaml_value("flow/stochastic", "basis"),
        basis_seed: int = yaml_value("flow/stochastic", "basis_seed"),
        amplitudes: str = yaml_value("flow/stochastic", "amplitudes"),
        velocity_scale: str = yaml_value("flow/stochastic", "velocity_scale"),
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
        k_keep = band_limit(grid, self.ell_f)
        self._synthesis = (None if k_keep is None
                           else BandLimitedSynthesis(grid, self._sqrt_spectrum, k_keep, dtype))
        self.fixed_basis: torch.Tensor | None = None
        if basis == "fixed":
            own = torch.Generator(device=self.device).manual_seed(int(basis_seed))
            self.fixed_basis = self.draw_components(1, own)
        self.reset()

    def _randn(self, *shape: int, dtype=None, generator=None) -> torch.Tensor:
        return torch.randn(*shape, device=self.device, dtype=dtype or self.dtype,
                           generator=generator or self.generator)

    def draw_components(self, count: int, generator: torch.Generator | None = None,
                        out: torch.Tensor | None = None) -> torch.Tensor:
        """Channels of ``count * M`` fresh components: ``(count, n, n, M, 5)`` in ``self.dtype``
        (from ``generator``, default the flow's; written into ``out`` if given)."""
        n, m = self.grid.n, self.n_basis
        if out is None:
            out = torch.empty(count, n, n, m, 5, device=self.device, dtype=self.dtype)
        per = max(1, 2**22 // (m * n * n))  # flows per batch: bounds the float64 work memory
        for f0 in range(0, count, per):
            f1 = min(count, f0 + per)
            w = self._randn(f1 - f0, m, n, n, dtype=torch.float64, generator=generator)
            if self._synthesis is None:
                psi_hat = self._sqrt_spectrum * torch.fft.fft2(w)
                q = stream_function_channels(psi_hat, self.grid).permute(0, 2, 3, 1, 4)
                out[f0:f1] = q.to(self.dtype)
            else:
                self._synthesis(w, out=out[f0:f1])
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
            i0, count = int(idx[0]), idx.numel()
            if int(idx[-1]) - i0 + 1 == count:  # a contiguous range: draw in place
                self.draw_components(count, out=self.basis[i0:i0 + count])
            else:
                self.basis[idx] = self.draw_components(count)
        else:
            self.basis[idx] = self.fixed_basis
        self.refresh_mode_speed(idx)
        xi = self._randn(idx.numel(), self.n_basis)
        if self.amplitudes == "stationary":
            self.coeffs[idx] = xi / math.sqrt(self.n_basis)
        else:
            xi = xi.double()
            self.coeffs[idx] = (xi / xi.norm(dim=1, keepdim=True)).to(self.dtype)
        self.time[idx] = 0.0

