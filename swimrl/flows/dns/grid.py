r"""Spectral grid of the DNS: real-FFT wavenumbers and the 2/3 de-aliasing mask.

Physical grid: $N\times N$ nodes $x_j = jL/N$, $j = 0, \dots, N-1$, arrays indexed
``[..., iy, ix]`` (the node grid :class:`swimrl.flows.grid.PeriodicGrid` shared with every
flow). Spectral grid: ``torch.fft.rfft2`` layout, ``(N, N//2 + 1)`` indexed
``[..., m_y, m_x]`` with $m_y$ in FFT order $0, \dots, N/2-1, -N/2, \dots, -1$ and
$m_x = 0, \dots, N/2$; the wavenumbers are $k = 2\pi m/L$.

De-aliasing (Orszag's 2/3 rule, square truncation): the retained modes are exactly

$$
3|m_x| < N \ \text{ and } \ 3|m_y| < N,\qquad
\text{i.e.}\quad |m_x|, |m_y| \le K = \lfloor (N - 1)/3 \rfloor
$$

($K = 170$ for $N = 512$, $K = 21$ for $N = 64$). The product of two fields band-limited
to $|m| \le K$ has $|m| \le 2K$; its aliases land at $|m| \ge N - 2K > K$, outside the
retained set, so the truncated quadratic term is alias-free (exact Galerkin truncation). The
Nyquist row/column $m = -N/2$ / $m_x = N/2$ is always discarded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import torch

from swimrl.flows.grid import PeriodicGrid


def dealias_cutoff(n: int) -> int:
    r"""Largest retained integer wavenumber $K = \lfloor (N - 1)/3\rfloor$ (modes $3|m| < N$)."""
    return (n - 1) // 3


@dataclass
class SpectralGrid:
    r"""Bi-periodic square box of side ``length`` with $n\times n$ nodes, on ``device``/``dtype``.

    Attributes (all tensors broadcast against ``(..., n, n//2 + 1)`` spectral arrays):
    ``kx`` ``(1, n//2+1)``, ``ky`` ``(n, 1)``, ``k2`` $= k_x^2 + k_y^2$, ``inv_k2`` $= 1/k^2$
    (0 at $k = 0$), ``mask`` (bool, the 2/3 rule above), ``weight`` (1 on the $m_x = 0$ and
    $m_x = N/2$ columns, 2 elsewhere: Parseval weight of the half plane).
    """

    n: int
    length: float = 2 * math.pi
    device: torch.device | str = "cpu"
    dtype: torch.dtype = torch.float32
    kx: torch.Tensor = field(init=False, repr=False)
    ky: torch.Tensor = field(init=False, repr=False)
    k2: torch.Tensor = field(init=False, repr=False)
    inv_k2: torch.Tensor = field(init=False, repr=False)
    mask: torch.Tensor = field(init=False, repr=False)
    weight: torch.Tensor = field(init=False, repr=False)
    nodes: PeriodicGrid = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.n < 8:
            raise ValueError(f"grid n={self.n} out of range: must be an even integer >= 8")
        self.nodes = PeriodicGrid(self.n, self.length)  # checks n even, length > 0
        self.device = torch.device(self.device)
        n, dev, dt = self.n, self.device, self.dtype
        my = torch.fft.fftfreq(n, d=1.0 / n, dtype=torch.float64)  # integers in FFT order
        mx = torch.fft.rfftfreq(n, d=1.0 / n, dtype=torch.float64)
        scale = 2 * math.pi / self.length
        self.kx = (mx * scale).to(dev, dt)[None, :]
        self.ky = (my * scale).to(dev, dt)[:, None]
        k2 = (self.kx.double() ** 2 + self.ky.double() ** 2).cpu()
        inv = torch.where(k2 > 0, 1.0 / torch.where(k2 > 0, k2, 1.0), 0.0)
        self.k2 = k2.to(dev, dt)
        self.inv_k2 = inv.to(dev, dt)
        keep_y = 3 * my.abs() < n
        keep_x = 3 * mx.abs() < n
        self.mask = (keep_y[:, None] & keep_x[None, :]).to(dev)
        w = torch.full((n, n // 2 + 1), 2.0, dtype=torch.float64)
        w[:, 0] = 1.0
        w[:, -1] = 1.0
        self.weight = w.to(dev, dt)

    # -- geometry -------------------------------------------------------------------------
    @property
    def spacing(self) -> float:
        r"""Grid spacing $\delta x = L/N$ (of :attr:`nodes`)."""
        return self.nodes.spacing

    @property
    def cutoff(self) -> int:
        """Largest retained integer wavenumber $K$ (see module docstring)."""
        return dealias_cutoff(self.n)

    @property
    def k_max(self) -> float:
        r"""Largest retained wavenumber component $k_\mathrm{max} = 2\pi K/L$."""
        return 2 * math.pi * self.cutoff / self.length

    @property
    def spectral_shape(self) -> tuple[int, int]:
        """Shape ``(N, N//2 + 1)`` of one rfft2 field."""
        return (self.n, self.n // 2 + 1)

    @property
    def complex_dtype(self) -> torch.dtype:
        """Complex dtype matching :attr:`dtype`."""
        return torch.complex128 if self.dtype == torch.float64 else torch.complex64

    def coords(self) -> torch.Tensor:
        """Node coordinates $x_j = jL/N$ (1D, float64, CPU)."""
        return self.nodes.coords()

    def k_magnitude(self) -> torch.Tensor:
        r"""$|\boldsymbol k| = (k_x^2 + k_y^2)^{1/2}$ on the spectral grid."""
        return self.k2.sqrt()

    # -- transforms -----------------------------------------------------------------------
    def to_spectral(self, f: torch.Tensor) -> torch.Tensor:
        """``f_hat = rfft2(f)`` (unnormalised forward DFT over the last two axes)."""
        return torch.fft.rfft2(f)

    def to_physical(self, f_hat: torch.Tensor) -> torch.Tensor:
        """``f = irfft2(f_hat)`` on the ``N x N`` nodes (inverse of :meth:`to_spectral`)."""
        return torch.fft.irfft2(f_hat, s=(self.n, self.n))

    def truncate(self, f_hat: torch.Tensor) -> torch.Tensor:
        """Project onto the retained modes: ``f_hat * mask`` (2/3 rule)."""
        return f_hat * self.mask

    def mean_product(self, a_hat: torch.Tensor, b_hat: torch.Tensor) -> torch.Tensor:
        r"""Space mean
        $\langle ab\rangle = \sum_k w_k\,\mathrm{Re}(\hat a_k\overline{\hat b_k})/N^4$
        (Parseval, half plane).

        Reduces the last two axes; exact for real fields given in rfft2 layout.
        """
        prod = (a_hat * b_hat.conj()).real * self.weight
        return prod.sum(dim=(-2, -1)) / float(self.n) ** 4
