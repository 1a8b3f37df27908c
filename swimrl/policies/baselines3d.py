r"""Baseline strategies of the 3D swimmer, on the signals of
:func:`swimrl.physics.signals3d.compute_signals_3d` (all seven, in
:data:`~swimrl.physics.signals3d.SIGNAL_NAMES_3D` order), as ``signals -> action`` modules:

* naive: ``Lambda = const`` (:func:`naive_3d`; :class:`swimrl.policies.baselines.NaiveShape`
  reads no signal and serves in 3D as it is);
* STO in 3D (:func:`short_time_optimal_3d`): ``Lambda = Lambda_max sign(S_np1)``.

**STO in 3D**, derived as ``eq:sto``: with ``r = |x - x_0|``, ``e_r = (x - x_0)/r``,

``d(n.e_r)/dt = e_r.dn/dt + n.de_r/dt``,  ``de_r/dt = (I - e_r e_r) dx/dt / r``,

and ``dx/dt = u + v_s n`` does not contain ``Lambda``, so neither does ``de_r/dt``; of
``dn/dt = (omega x n)/2 + Lambda (I - n n) S n`` only the strain term does, and
``e_r.(I - n n) S n = (e_r - (e_r.n) n).S n = sqrt(1 - n_r^2) p1.S n``:

``d(n.e_r)/dt = Lambda sqrt(1 - n_r^2) S_np1 + (Lambda-independent terms)``.

The same factor is the shape-dependent term of the distance (``eq:sto``'s expansion):
``r(t + dt) = (v_s Lambda dt^2/2) e_r.(I - n n).S.n + ... = (v_s Lambda dt^2/2)
sqrt(1 - n_r^2) S_np1 + ...``. Linear in ``Lambda`` with a coefficient of the sign of
``S_np1`` (``sqrt(1 - n_r^2) >= 0``), both are maximised over ``[-Lambda_max, Lambda_max]``
by ``Lambda = Lambda_max sign(S_np1)``; where ``n`` is parallel to ``e_r`` (``n_r = +-1``)
or ``S_np1 = 0`` every ``Lambda`` is optimal (the rule gives ``Lambda_max`` or 0). In the plane
(``p1 = -sign(n_theta) p``) this is the 2D rule ``Lambda = -Lambda_max sign(n_theta)
sign(S_np)``.
"""

from __future__ import annotations

import torch
from torch import nn

from swimrl.physics.signals3d import SIGNAL_NAMES_3D

S_NP1 = SIGNAL_NAMES_3D.index("S_np1")


def short_time_optimal_3d(signals: torch.Tensor, shape_factor_max: float) -> torch.Tensor:
    """STO in 3D: ``Lambda = Lambda_max sign(S_np1)`` (module docstring) of ``signals``
    ``(..., 7)``; returns ``(...)``."""
    return shape_factor_max * torch.sign(signals[..., S_NP1])


def naive_3d(signals: torch.Tensor, shape_factor: float) -> torch.Tensor:
    """The naive strategy: ``Lambda = shape_factor`` for each swimmer of ``signals``
    ``(..., 7)``; returns ``(...)``."""
    return torch.full_like(signals[..., 0], float(shape_factor))


class ShortTimeOptimal3D(nn.Module):
    """STO in 3D as a ``signals -> action`` module: ``Lambda = Lambda_max sign(S_np1)``,
    ``(..., 1)``; with ``amplitudes = (a_+, a_-)``: ``a_+`` where ``S_np1 > 0``, ``-a_-``
    where ``S_np1 < 0`` (as the 2D :class:`~swimrl.policies.baselines.ShortTimeOptimal`).
    """

    def __init__(self, shape_factor_max: float,
                 amplitudes: tuple[float, float] | None = None):
        super().__init__()
        self.shape_factor_max = float(shape_factor_max)
        self.amplitudes = None if amplitudes is None else tuple(float(a) for a in amplitudes)

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        if self.amplitudes is None:
            return short_time_optimal_3d(signals, self.shape_factor_max).unsqueeze(-1)
        s, (prolate, oblate) = signals[..., S_NP1], self.amplitudes
        lam = torch.where(s > 0, prolate, torch.where(s < 0, -oblate, 0.0))
        return lam.to(signals.dtype).unsqueeze(-1)
