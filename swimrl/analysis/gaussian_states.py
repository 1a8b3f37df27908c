r"""Isotropic Gaussian swimmer states, the mechanism probe's model of what a swimmer senses
(:mod:`.mechanism_probe`): $\boldsymbol n$ uniform on the circle (2D) or the sphere (3D),
$\boldsymbol e_r$ fixed ($\hat{\boldsymbol x}$, $\hat{\boldsymbol z}$); in 2D $S_{xx}$,
$S_{xy}$ of variance 1/8 (so $S_{nn}$, $S_{np}$ too) and $\omega$ of variance 1; in 3D a
traceless symmetric strain
$\mathbb S = [(\mathbb G + \mathbb G^{\mathsf T})/2 - \tfrac13\mathrm{tr}\,\mathbb G]/\sqrt{10}$,
$\mathbb G$ of independent standard normal entries ($\langle S_{ij}S_{ij}\rangle = 1/2$;
isotropic: $\langle S_{nn}^2\rangle = 1/15$, $\langle S_{np_1}^2\rangle = 1/20$), and
vorticity components of variance 1/3; $\tau_K = 1$."""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from swimrl.physics.signals import compute_signals
from swimrl.physics.signals3d import compute_signals_3d


@dataclass(frozen=True)
class GaussianStates:
    """Isotropic Gaussian swimmer states (module docstring): the flow channels ``q``
    (``(n, 5)``, :func:`~swimrl.physics.swimmer.swimmer_rhs`'s, or ``(n, 11)``,
    :data:`~swimrl.physics.swimmer3d.CHANNELS_3D`; zero velocity), the orientation
    (``theta`` ``(n,)`` in 2D, the unit vector ``(n, 3)`` in 3D), ``e_r`` ``(2,)`` or
    ``(3,)`` and the signals ``(n, 5 | 7)`` at ``tau_K = 1``, float64."""

    dim: int
    q: torch.Tensor
    orientation: torch.Tensor
    e_r: torch.Tensor
    signals: torch.Tensor


def gaussian_states(dim: int, n: int, seed: int) -> GaussianStates:
    """``n`` isotropic Gaussian states of dimension ``dim`` (module docstring), drawn from
    ``torch.Generator().manual_seed(seed)``; the signals are those of
    :func:`~swimrl.physics.signals.compute_signals` /
    :func:`~swimrl.physics.signals3d.compute_signals_3d` with ``x - x_0`` along ``e_r``."""
    g = torch.Generator().manual_seed(int(seed))
    f64 = torch.float64

    def normal(*shape):
        return torch.randn(*shape, generator=g, dtype=f64)

    if dim == 3:
        v = normal(n, 3)
        orient = v / v.norm(dim=-1, keepdim=True)
        a = normal(n, 3, 3)
        s = 0.5 * (a + a.transpose(-1, -2))
        trace = torch.diagonal(s, dim1=-2, dim2=-1).mean(-1)[:, None, None]
        s = s - trace * torch.eye(3, dtype=f64)
        s = s / math.sqrt(10.0)  # <S_ij S_ij> = 5 / 10
        omega = normal(n, 3) / math.sqrt(3.0)
        strain = torch.stack((s[:, 0, 0], s[:, 1, 1], s[:, 0, 1], s[:, 0, 2], s[:, 1, 2]), -1)
        q = torch.cat((torch.zeros(n, 3, dtype=f64), strain, omega), -1)
        e_r = torch.tensor([0.0, 0.0, 1.0], dtype=f64)
        signals = compute_signals_3d(q, orient, e_r.expand(n, 3), 1.0)
    else:
        orient = torch.rand(n, generator=g, dtype=f64) * (2 * math.pi)
        strain = normal(n, 2) / math.sqrt(8.0)
        omega = normal(n, 1)
        q = torch.cat((torch.zeros(n, 2, dtype=f64), strain, omega), -1)
        e_r = torch.tensor([1.0, 0.0], dtype=f64)
        signals = compute_signals(q, orient, e_r.expand(n, 2), 1.0)
    return GaussianStates(dim, q, orient, e_r, signals)
