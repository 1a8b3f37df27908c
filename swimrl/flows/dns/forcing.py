r"""Forcing: Gaussian, white in time, isotropic, peaked at $|\boldsymbol k| = k_f$ (and a
steady one).

Stochastic forcing. In continuous time
$\hat f(\boldsymbol k, t)\,\mathrm dt = \sigma_k\,\mathrm dW_{\boldsymbol k}(t)$ with independent
complex Wiener processes (Hermitian,
$\mathrm dW_{-\boldsymbol k} = \overline{\mathrm dW_{\boldsymbol k}}$,
$E|\mathrm dW_{\boldsymbol k}|^2 = \mathrm dt$) and

$$
\sigma_k^2 = \frac{2\epsilon N^4 F(k)}{S},\qquad
F(k) = \exp\!\Big(-\frac{(|\boldsymbol k| - k_f)^2}{2\delta_f^2}\Big),\qquad
S = \sum_{\boldsymbol k} \frac{F(k)}{k^2}
$$

(full $\boldsymbol k$ plane, retained modes, $\boldsymbol k \ne 0$).

Because the noise is additive ($\sigma$ does not depend on $\omega$) Itô and Stratonovich
readings of the SDE coincide, and the energy $E = \sum|\hat\omega|^2/(2k^2N^4)$ obeys (Itô)

$$
\mathrm dE = [\dots]\,\mathrm dt + \sum \mathrm{Re}(\hat\psi^*\sigma\,\mathrm dW)/N^4
+ \tfrac12\sum \sigma_k^2/(k^2N^4)\,\mathrm dt.
$$

The martingale term has zero mean whatever the state, so the mean injection rate is

$$
\langle P\rangle = \sum_{\boldsymbol k}\frac{\sigma_k^2}{2k^2N^4} = \epsilon
$$

exactly, independent of the flow; likewise the enstrophy injection rate is
$\sum_{\boldsymbol k}\sigma_k^2/(2N^4) = \epsilon\,\langle k^2\rangle_F$.
Discretisation: one draw $\xi_k$ (standard complex Gaussian, $E|\xi|^2 = 1$) per time step,
$\hat f = \sigma_k\xi_k/\sqrt{\delta t}$ held constant over all stages of the step, so the step
adds $\sigma_k\xi_k\sqrt{\delta t}$ (Wiener increment) to $\hat\omega$.

Random numbers: each realisation has its own ``torch.Generator`` (CPU, seeded by its seed); the
draws are made in float64 on the CPU and then moved/cast, so a seed gives the same forcing
history for any batch composition, dtype and device.
"""

from __future__ import annotations

import math

import torch

from swimrl.flows.dns.grid import SpectralGrid
from swimrl.flows.dns.params import DNSParams


def forcing_shape(grid: SpectralGrid, k_f: float, width: float) -> torch.Tensor:
    r"""$F(k) = \exp(-(|\boldsymbol k| - k_f)^2/(2w^2))$, $w$ = ``width``, on retained
    $\boldsymbol k \ne 0$ modes, 0 elsewhere.

    Values below $10^{-12}$ are set to 0 (they define the forced-mode support). float64, CPU.
    """
    k2 = grid.k2.double().cpu()
    f = torch.exp(-((k2.sqrt() - k_f) ** 2) / (2 * width**2))
    f = torch.where((k2 > 0) & grid.mask.cpu() & (f >= 1e-12), f, 0.0)
    return f


class StochasticForcing:
    r"""White-in-time Gaussian forcing injecting energy at the mean rate $\epsilon$.

    ``draw(dt)`` returns $\hat f$ ``(B, N, N//2+1)`` $= \sigma\xi/\sqrt{\delta t}$ for the
    current step, advancing each realisation's generator.
    """

    def __init__(self, grid: SpectralGrid, params: DNSParams, seeds: list[int] | tuple[int, ...]):
        self.grid = grid
        self.epsilon = params.epsilon
        shape = forcing_shape(grid, params.k_f, params.forcing_width)
        w = grid.weight.double().cpu()
        s = float((w * shape * grid.inv_k2.double().cpu()).sum())
        n4 = float(grid.n) ** 4
        sigma2 = 2 * params.epsilon * n4 * shape / s if s > 0 else shape * 0
        self.sigma_full = sigma2.sqrt()  # (N, N//2+1) float64 CPU
        # Independent forced modes: m_x > 0, or m_x = 0 and m_y > 0; mirror m_x = 0, m_y < 0.
        ny = grid.n
        my = torch.fft.fftfreq(ny, d=1.0 / ny)
        support = shape > 0
        indep = support.clone()
        indep[:, 0] &= my > 0
        iy, ix = torch.nonzero(indep, as_tuple=True)
        self._iy, self._ix = iy, ix
        mirror_iy = torch.remainder(-iy, ny)
        self._mirror = ix == 0
        self._mirror_iy = mirror_iy[self._mirror]
        self._sigma = self.sigma_full[iy, ix]  # (M,)
        self.n_modes = int(iy.numel())
        self.generators = [torch.Generator().manual_seed(int(s)) for s in seeds]
        # flat indices into the (N, N//2+1) plane, on device
        nh = grid.n // 2 + 1
        self._flat = (iy * nh + ix).to(grid.device)
        self._flat_mirror = (self._mirror_iy * nh).to(grid.device)

    @property
    def batch(self) -> int:
        """Number of realisations (generators)."""
        return len(self.generators)

    def injection_rate(self) -> float:
        r"""Mean energy injection $\sum_k w_k\sigma_k^2/(2k^2N^4)$ ($= \epsilon$)."""
        g = self.grid
        s2 = self.sigma_full**2 * g.weight.double().cpu() * g.inv_k2.double().cpu()
        return float(s2.sum()) / (2 * float(g.n) ** 4)

    def enstrophy_injection_rate(self) -> float:
        r"""Mean enstrophy injection $\sum_k w_k\sigma_k^2/(2N^4)$ ($\sim\epsilon k_f^2$)."""
        g = self.grid
        s2 = self.sigma_full**2 * g.weight.double().cpu()
        return float(s2.sum()) / (2 * float(g.n) ** 4)

    def draw_xi(self) -> torch.Tensor:
        r"""Standard complex Gaussians $\xi$ ``(B, M)`` (float64 CPU), one row per generator."""
        rows = [torch.randn(2, self.n_modes, generator=g, dtype=torch.float64)
                for g in self.generators]
        z = torch.stack(rows)  # (B, 2, M)
        return torch.complex(z[:, 0], z[:, 1]) / math.sqrt(2.0)

    def draw(self, dt: float) -> torch.Tensor:
        r"""$\hat f = \sigma\xi/\sqrt{\delta t}$ on the spectral grid, Hermitian on $m_x = 0$."""
        g = self.grid
        vals = (self.draw_xi() * self._sigma / math.sqrt(dt)).to(g.device, g.complex_dtype)
        nh = g.n // 2 + 1
        out = torch.zeros(self.batch, g.n * nh, dtype=g.complex_dtype, device=g.device)
        out[:, self._flat] = vals
        if self._flat_mirror.numel():
            out[:, self._flat_mirror] = vals[:, self._mirror.to(g.device)].conj()
        return out.view(self.batch, g.n, nh)

    # -- RNG state (for resumable runs) ---------------------------------------------------
    def get_rng_state(self) -> torch.Tensor:
        """Generator states stacked ``(B, S)`` uint8."""
        return torch.stack([g.get_state() for g in self.generators])

    def set_rng_state(self, states: torch.Tensor) -> None:
        """Restore states from :meth:`get_rng_state`."""
        if states.shape[0] != self.batch:
            raise ValueError(f"rng state batch {states.shape[0]} != forcing batch {self.batch}")
        for g, s in zip(self.generators, states, strict=True):
            g.set_state(s.to(torch.uint8).cpu().clone())


class SteadyForcing:
    r"""Deterministic forcing $\hat f$ (constant in time), e.g. for manufactured solutions."""

    def __init__(self, f_hat: torch.Tensor):
        self.f_hat = f_hat

    def draw(self, dt: float) -> torch.Tensor:
        r"""The fixed $\hat f$ (``dt`` is ignored)."""
        return self.f_hat
