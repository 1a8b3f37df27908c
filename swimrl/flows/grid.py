r"""Doubly periodic square grid and spectral derivatives.

Nodes sit at $x_j = jh$, $j = 0, \dots, N-1$, with $h = L/N$. Wavenumbers are
$k = 2\pi m/L$ with $m$ in FFT order. Derivatives are exact for band-limited
fields: $\partial_x f = \mathrm{IFFT}(ik_x\,\mathrm{FFT}(f))$.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch


@dataclass(frozen=True)
class PeriodicGrid:
    """A square periodic grid of ``n`` x ``n`` nodes on a box of side ``length``."""

    n: int
    length: float

    def __post_init__(self) -> None:
        if self.n < 4 or self.n % 2:
            raise ValueError(f"grid n={self.n} must be an even integer >= 4")
        if not self.length > 0:
            raise ValueError(f"grid length={self.length} must be > 0")

    @property
    def spacing(self) -> float:
        """Grid spacing $h = L/N$."""
        return self.length / self.n

    def coords(self, device: torch.device | str = "cpu", dtype=torch.float64) -> torch.Tensor:
        """Node coordinates $x_j = jh$ (1D, length ``n``)."""
        return torch.arange(self.n, device=device, dtype=dtype) * self.spacing

    def wavenumbers(
        self, device: torch.device | str = "cpu", dtype=torch.float64
    ) -> tuple[torch.Tensor, torch.Tensor]:
        r"""Full-FFT wavenumber grids $(k_x, k_y)$ of shape ``(n, n)``, indexed ``[iy, ix]``.

        $k = 2\pi m/L$ with ``m = fftfreq(n) * n``. The Nyquist mode $m = -n/2$ is
        kept as is; fields generated here have negligible power there.
        """
        k = torch.fft.fftfreq(self.n, d=self.spacing, device=device, dtype=dtype) * (2 * math.pi)
        ky, kx = torch.meshgrid(k, k, indexing="ij")
        return kx, ky
