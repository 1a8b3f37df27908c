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

from dataclasses import dataclass

import torch

from swimrl.physics.body import body


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
    :meth:`~swimrl.physics.body.Body.signals` with ``x - x_0`` along ``e_r``
    (:meth:`~swimrl.physics.body.Body.isotropic_state` draws them)."""
    g = torch.Generator().manual_seed(int(seed))
    body_ = body(dim)
    orient, q, e_r = body_.isotropic_state(n, g, torch.float64)
    signals = body_.signals(q, orient, e_r.expand(n, dim), 1.0)
    return GaussianStates(dim, q, orient, e_r, signals)
