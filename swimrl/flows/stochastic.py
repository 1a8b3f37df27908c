r"""The 2D stochastic flow of the paper (Sec. II B, App. A), batched over realisations.

Units: $\ell_f = u_\mathrm{rms} = 1$. The stream function is

$$
\psi(\boldsymbol x, t) = \sum_{i=1}^{M} c_i(t)\,\psi_i(\boldsymbol x),\qquad
\boldsymbol u = (\partial_y\psi, -\partial_x\psi),
$$

with independent Gaussian components of covariance
$\langle\psi_i(\boldsymbol x)\,\psi_j(\boldsymbol x')\rangle
= \delta_{ij}\,A\exp(-|\boldsymbol x - \boldsymbol x'|^2/2)$,
$A = u_\mathrm{rms}^2\ell_f^2/2$, and Ornstein-Uhlenbeck coefficients
$\langle c_i(t)\,c_j(t')\rangle = \frac{\delta_{ij}}{M}\exp(-|t - t'|/\tau_f)$,
$\tau_f = \mathrm{Ku}\,\ell_f/u_\mathrm{rms}$.

Kolmogorov time of this model (derivation; $C(r) = A\exp(-r^2/2\ell^2)$). Moments of
derivatives of a stationary Gaussian field follow from derivatives of $C$ at $r = 0$:
$\langle\psi_x^2\rangle = -C_{xx}(0) = A/\ell^2$,
$\langle\psi_{xx}^2\rangle = C_{xxxx}(0) = 3A/\ell^4$,
$\langle\psi_{xy}^2\rangle = \langle\psi_{xx}\psi_{yy}\rangle = C_{xxyy}(0) = A/\ell^4$.
Hence, summing $\langle c_i^2\rangle = 1/M$ over the $M$ components,

* $\langle\boldsymbol u\cdot\boldsymbol u\rangle = \langle\psi_x^2\rangle + \langle\psi_y^2\rangle
  = 2A/\ell^2 = u_\mathrm{rms}^2$ (consistent normalisation);
* $\langle A_{ij}A_{ij}\rangle = \langle\psi_{xx}^2\rangle + \langle\psi_{yy}^2\rangle +
  2\langle\psi_{xy}^2\rangle = 8A/\ell^4 = 4u_\mathrm{rms}^2/\ell^2$;

so $\tau_K = \langle A_{ij}A_{ij}\rangle^{-1/2} = \ell_f/(2u_\mathrm{rms}) = 0.5$.
Component-wise, $\langle S_{xx}^2\rangle = \langle S_{xy}^2\rangle = u_\mathrm{rms}^2/(2\ell^2)$
and $\langle\omega^2\rangle = 4u_\mathrm{rms}^2/\ell^2$.

Generation (exact discrete covariance): with $P_k$ the discrete spectrum of the
periodically summed covariance (:func:`gaussian_spectrum`), a white field $w$ gives
$\psi = \mathrm{IFFT}(\sqrt P\,\mathrm{FFT}(w))$, whose covariance on the grid is the circular
autocorrelation
$\mathrm{IFFT}(P) = \sum_{\boldsymbol n} C(\boldsymbol x - \boldsymbol x' + \boldsymbol nL)$;
for $L = 10\,\ell_f$ the periodic images change $C$ by less than $2e^{-12.5}A$ anywhere.
Derivatives are spectral: $\psi_x = \mathrm{IFFT}(ik_x\hat\psi)$.

Band limit (speed, same draws): $\sqrt{P_k}$ falls as $\exp(-k^2\ell^2/4)$, so only the
modes $|m_x|, |m_y| \le K$ carry the fields (:func:`band_limit`: every dropped mode has
$\sqrt{P_k}\,\max(1, k^2\ell^2) \le 10^{-13}$ of the peak; $K = 18$ of 200 at the default
$L = 10$, $n = 400$). :class:`BandLimitedSynthesis` evaluates the same
$\mathrm{IFFT}(m_k\sqrt P\,\mathrm{FFT}(w))$ as direct sums over those modes (dense float64
products, the last one in the flow's dtype, instead of full FFTs): the same white field $w$,
hence the same realisation, to round-off (float64 plus the dropped $10^{-13}$; a few float32
ulps for float32 flows); several times faster at the default grid.

OU update (exact for any step):

$$
c(t + \delta t) = c(t)\,e^{-\delta t/\tau_f}
+ \sqrt{\frac{1 - e^{-2\delta t/\tau_f}}{M}}\;\xi,\qquad \xi\sim\mathcal N(0, 1);
$$

$c(0)$ is drawn from the stationary law $\mathcal N(0, 1/M)$.

Readings of the specification (options; the defaults are the paper's text as written,
issue 11 item 6 evaluates the others at Ku = 1e7, ``docs/results.md``):

* ``basis``: ``"redrawn"`` (default) draws new components $\psi_i$ with every realisation
  (every flow of an evaluation, every episode of training); ``"fixed"`` draws one set of
  $M$ components from its own generator seeded with ``basis_seed`` and gives it to every
  realisation, which then differ only by $c_i$ (the paper's "at the start of each
  episode, the flow coefficients $c_i$ [...] are randomly sampled"). The ensemble is then
  conditional on one draw of the $\psi_i$: $\langle\boldsymbol u\cdot\boldsymbol u\rangle$ and
  $\tau_K$ hold on average over ``basis_seed``, not for each.
* ``amplitudes``: ``"stationary"`` (default) $c(0)\sim\mathcal N(0, 1/M)$; ``"normalised"``
  $c(0) = \xi/|\xi|$ with the same $\xi\sim\mathcal N(0, 1)$ (uniform on the unit sphere), so
  $\sum_i c_i(0)^2 = 1$ in every realisation while $\langle c_i^2\rangle = 1/M$ still holds:
  the ensemble $u_\mathrm{rms}$ and $\tau_K$ are unchanged, only the realisation-to-realisation
  spread of the flow's energy is removed. The OU steps that follow are unchanged (at
  Ku = 1e7 each $c_i$ diffuses by $(2T/(\tau_f M))^{1/2} \sim 2\times10^{-3}$ over an
  episode).
* ``velocity_scale``: ``"total"`` (default)
  $u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$; ``"component"``: the
  velocity $v_s$ and the Kubo number are measured against the one-component rms
  $\langle u_x^2\rangle^{1/2} = u_\mathrm{rms}/\sqrt2$. The fields are the same; :attr:`u_rms`
  (the reference velocity the environment scales $v_s$ by) becomes $1/\sqrt2$ and
  $\tau_f = \mathrm{Ku}\,\ell_f/(u_\mathrm{rms}/\sqrt2)$. So $v_s = 0.707$ reads
  $0.5\,\langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$ and Ku reads $\mathrm{Ku}\sqrt2$ in
  the default's units; $\tau_K = 0.5$ is unchanged.
* The box $L$ = ``n_grid * spacing`` (10 $\ell_f$ by default) is set by ``n_grid``.

``flow=stochastic``: :class:`StochasticSpec` (the ``flow.*`` keys), its builder and
:data:`STOCHASTIC_ENTRY`, the registry's entry (:mod:`swimrl.flows.registry`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from swimrl.conf_values import yaml_value
from swimrl.errors import as_float, as_int, keep_number_types, one_of, require
from swimrl.flows.base import GriddedFlow
from swimrl.flows.entry import FlowEntry
from swimrl.flows.grid import PeriodicGrid

#: Kolmogorov time of the model in units ell_f / u_rms (see module docstring).
TAU_K = 0.5

#: Options of :class:`StochasticFlow` (readings of the paper's text; first = default).
BASIS_MODES = ("redrawn", "fixed")
AMPLITUDE_MODES = ("stationary", "normalised")
VELOCITY_SCALES = ("total", "component")


def gaussian_spectrum(grid: PeriodicGrid, amplitude: float, ell: float, device) -> torch.Tensor:
    r"""Discrete power spectrum $P_k = (2\pi\ell^2/h^2)\,A\exp(-k^2\ell^2/2)$, $A$ = ``amplitude``.

    This is the FFT (unnormalised, node spacing $h$) of the periodic sum of
    $C(r) = A\exp(-r^2/2\ell^2)$, up to aliasing of modes beyond the Nyquist
    wavenumber (relative size $\exp(-(\pi\ell/h)^2/2)$, i.e. nil for $h \ll \ell$).
    The analytic form avoids the round-off floor of a numerically transformed covariance,
    which the $k^4$ of second derivatives would amplify.
    """
    kx, ky = grid.wavenumbers(device=device, dtype=torch.float64)
    k2 = kx**2 + ky**2
    return (2 * math.pi * ell**2 / grid.spacing**2) * amplitude * torch.exp(-0.5 * k2 * ell**2)


def stream_function_channels(psi_hat: torch.Tensor, grid: PeriodicGrid) -> torch.Tensor:
    r"""Channels $(u_x, u_y, S_{xx}, S_{xy}, \omega)$ of stream functions given by their FFT.

    $u_x = \psi_y$, $u_y = -\psi_x$, $S_{xx} = \psi_{xy}$, $S_{xy} = (\psi_{yy} - \psi_{xx})/2$,
    $\omega = -(\psi_{xx} + \psi_{yy})$. Input ``(..., n, n)`` complex; output
    ``(..., n, n, 5)``.
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
    r"""Smallest $K$ such that every mode with $\max(|m_x|, |m_y|) > K$ has
    $\exp(-k^2\ell^2/4)\max(1, k^2\ell^2) \le \mathrm{tol}\cdot\max_k(\dots)$ ($k = 2\pi m/L$);
    ``None`` when no $K < n/2 - 1$ does (coarse grids: use the full FFT)."""
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
    r"""The $M$ Ornstein-Uhlenbeck coefficients $c_i(t)$ of a flow, ``(n_flows, M)`` in
    ``self.coeffs``, correlation time ``self.tau_f``, stationary variance $1/M$: the time
    dependence shared by the 2D (:class:`StochasticFlow`) and 3D
    (:class:`~swimrl.flows.stochastic3d.StochasticFlow3D`) stochastic flows."""

    def ou_factors(self, dt: float) -> tuple[float, float]:
        r"""$\big(e^{-\delta t/\tau_f}, \sqrt{(1 - e^{-2\delta t/\tau_f})/M}\big)$ computed in
        double precision."""
        decay = math.exp(-dt / self.tau_f)
        return decay, math.sqrt(-math.expm1(-2 * dt / self.tau_f) / self.n_basis)

    def advance(self, dt: float) -> None:
        r"""Exact OU step of all coefficients:
        $c \leftarrow c\,e^{-\delta t/\tau_f} + \sigma_{\delta t}\,\xi$."""
        decay, sigma = self.ou_factors(dt)
        noise = self._randn(self.n_flows, self.n_basis)
        self.coeffs.mul_(decay).add_(noise, alpha=sigma)
        self.time += dt


class BandLimitedSynthesis:
    r"""``stream_function_channels(sqrt(P) FFT2(w))`` of real white fields $w$ by direct
    sums over the retained modes $|m_y| \le K$ (complex) and $0 \le m_x \le K$ (real
    symmetry, weights $a_{m_x} = 1, 2, 2, \dots$):

    $$
    W(\boldsymbol m) = \sum_{\boldsymbol j} w_{\boldsymbol j}\,
    e^{-2\pi i\,\boldsymbol m\cdot\boldsymbol j/n},\qquad
    q_c(\boldsymbol j) = n^{-2}\,\mathrm{Re}\sum_{m_y}\sum_{m_x\ge 0} a_{m_x}\,
    \mathrm{mult}_c(\boldsymbol m)\sqrt{P_{\boldsymbol m}}\,W(\boldsymbol m)\,
    e^{2\pi i\,\boldsymbol m\cdot\boldsymbol j/n},
    $$

    with the channel multipliers
    $\mathrm{mult} = \big(ik_y, -ik_x, -k_xk_y, (k_x^2 - k_y^2)/2, k_x^2 + k_y^2\big)$ of
    :func:`stream_function_channels`. In float64 up to the last sum (in ``dtype``, see
    :meth:`__call__`); fields are indexed ``[y, x]`` as :meth:`PeriodicGrid.wavenumbers`.
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
    r"""``n_flows`` independent realisations of the stochastic flow at Kubo number ``kubo``.

    Each realisation has its own $M$ components $\psi_i$ and coefficients $c_i$;
    :meth:`reset` redraws both for the selected flows (with ``basis="fixed"``: only the
    $c_i$, every realisation sharing one set of $\psi_i$). ``amplitudes`` and
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
        r"""Channels of ``count`` $\times M$ fresh components: ``(count, n, n, M, 5)`` in
        ``self.dtype`` (from ``generator``, default the flow's; written into ``out`` if given)."""
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
        """Redraw components (unless fixed) and coefficients $c_i(0)$ of selected flows."""
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



# -- flow=stochastic: the spec, its builder and the registry's entry ----------------------------
@dataclass(frozen=True)
class StochasticSpec:
    r"""``flow=stochastic``: the paper's flow at Kubo number ``kubo`` (Sec. II B).

    ``basis``, ``basis_seed``, ``amplitudes``, ``velocity_scale``: readings of the paper's
    text, defaults as written (module docstring). The defaults (for library calls) are read
    from ``conf/flow/stochastic.yaml`` (:mod:`swimrl.conf_values`).

    Parameters
    ----------
    kubo
        $\mathrm{Ku} = \tau_f u_\mathrm{rms}/\ell_f$ (the paper: 0.1, 1, 10, 1e7).
    n_modes
        $M$, the stream-function components (the paper: 5).
    n_grid
        Grid nodes per side (the paper: 400).
    spacing
        Grid spacing in units of $\ell_f$ (the paper: 0.025; box ``n_grid * spacing``).
    basis
        ``redrawn`` (new components per flow) or ``fixed`` (one set, from ``basis_seed``).
    basis_seed
        The seed of the fixed components.
    amplitudes
        ``stationary`` ($c_i(0)\sim\mathcal N(0, 1/M)$) or ``normalised`` (on the unit sphere).
    velocity_scale
        ``total`` ($v_s$ and Ku against $\langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$) or
        ``component``.
    name
        The config group's name.
    """

    kubo: float
    n_modes: int = yaml_value("flow/stochastic", "n_modes")
    n_grid: int = yaml_value("flow/stochastic", "n_grid")
    spacing: float = yaml_value("flow/stochastic", "spacing")
    basis: str = yaml_value("flow/stochastic", "basis")
    basis_seed: int = yaml_value("flow/stochastic", "basis_seed")
    amplitudes: str = yaml_value("flow/stochastic", "amplitudes")
    velocity_scale: str = yaml_value("flow/stochastic", "velocity_scale")
    name: str = yaml_value("flow/stochastic", "name")

    def __post_init__(self) -> None:
        as_float("flow.kubo", self.kubo, lambda v: v > 0, "> 0 (e.g. 0.1, 1, 10, 1e7)")
        as_int("flow.n_modes", self.n_modes)
        n = self.n_grid
        require(as_int("flow.n_grid", n, low=4) % 2 == 0, "flow.n_grid", n, "an even integer >= 4")
        as_float("flow.spacing", self.spacing, lambda v: v > 0, "> 0 (units ell_f)")
        one_of("flow.basis", self.basis, BASIS_MODES)
        as_int("flow.basis_seed", self.basis_seed, low=0)
        one_of("flow.amplitudes", self.amplitudes, AMPLITUDE_MODES)
        one_of("flow.velocity_scale", self.velocity_scale, VELOCITY_SCALES)
        keep_number_types(self)


def _build(spec: StochasticSpec, n_flows, device, dtype, generator, interval,
           duration) -> GriddedFlow:
    return StochasticFlow(
        n_flows, spec.kubo, spec.n_modes, spec.n_grid, spec.spacing, device=device,
        dtype=dtype, generator=generator, basis=spec.basis, basis_seed=spec.basis_seed,
        amplitudes=spec.amplitudes, velocity_scale=spec.velocity_scale,
    )


def _bytes(spec: StochasticSpec, n_flows: int, dtype: torch.dtype, interval: float) -> int:
    """``F n^2 M 5`` values: the basis of ``n_flows`` realisations."""
    size = torch.empty((), dtype=dtype).element_size()
    return n_flows * spec.n_grid**2 * spec.n_modes * 5 * size


#: ``flow=stochastic`` in the registry (:data:`swimrl.flows.registry.BUILTIN_FLOWS`).
STOCHASTIC_ENTRY = FlowEntry("stochastic", StochasticSpec, _build, 2, table_bytes=_bytes)
