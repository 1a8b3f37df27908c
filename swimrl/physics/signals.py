r"""The swimmer's signals (paper Sec. II C), in the body frame and in units of ``tau_K``.

With ``d = x - x_0`` the displacement from the start point, ``e_r = d/|d|`` and
``e_theta = z x e_r = (-e_{r,y}, e_{r,x})``:

* ``n_r = n.e_r``, ``n_theta = n.e_theta = sin(theta - phi)`` (``phi`` the polar angle of ``d``);
* ``S_nn = n.S.n tau_K``, ``S_np = n.S.p tau_K``, ``omega tau_K``.

At the start point (``|d| = 0``) the polar basis is undefined; swimrl defines
``e_r := n`` there, i.e. ``n_r = 1``, ``n_theta = 0`` (the swimmer regards its initial heading
as outward). The same rule applies whenever ``|d| < 1e-12`` in flow units.
"""

from __future__ import annotations

import torch

from swimrl.errors import ConfigError
from swimrl.physics.swimmer import strain_nn, strain_np

SIGNAL_NAMES: tuple[str, ...] = ("n_r", "n_theta", "S_nn", "S_np", "omega")
"""All signal names, in the order of the ``signals`` key of the environment."""

#: Not a flow signal: the swimmer's own shape factor, the ``Lambda`` it held over the last
#: decision interval (0 before its first decision), observable with ``signals.names`` in 2D
#: and 3D (the state of ``reward.shape_change_weight``'s cost, which depends on it).
SHAPE_SIGNAL = "Lambda"


def compute_signals(
    q: torch.Tensor, theta: torch.Tensor, displacement: torch.Tensor, tau_k: float
) -> torch.Tensor:
    """All five signals ``(n_r, n_theta, S_nn tau_K, S_np tau_K, omega tau_K)`` (Sec. II C).

    Parameters
    ----------
    q
        Flow channels ``(u_x, u_y, S_xx, S_xy, omega)`` at the swimmers, ``(..., 5)``.
    theta
        Orientation angles, ``(...)``.
    displacement
        ``x - x_0``, ``(..., 2)``: its direction is ``e_r`` (``n`` at the start point).
    tau_k
        The flow's ``tau_K``, the unit of the strain and vorticity signals.

    Returns
    -------
    torch.Tensor
        ``(..., 5)``, in the order of :data:`SIGNAL_NAMES`.
    """
    n = torch.stack((torch.cos(theta), torch.sin(theta)), -1)
    r = displacement.norm(dim=-1, keepdim=True)
    at_start = r < 1e-12
    e_r = torch.where(at_start, n, displacement / torch.where(at_start, torch.ones_like(r), r))
    n_r = (n * e_r).sum(-1)
    n_theta = n[..., 1] * e_r[..., 0] - n[..., 0] * e_r[..., 1]
    s_xx, s_xy, omega = q[..., 2], q[..., 3], q[..., 4]
    return torch.stack(
        (
            n_r,
            n_theta,
            strain_nn(theta, s_xx, s_xy) * tau_k,
            strain_np(theta, s_xx, s_xy) * tau_k,
            omega * tau_k,
        ),
        -1,
    )


def signal_indices(names, allowed: tuple[str, ...] = SIGNAL_NAMES) -> list[int]:
    """Positions of ``names`` in ``allowed`` (default :data:`SIGNAL_NAMES`; the 3D set is
    :data:`~swimrl.physics.signals3d.SIGNAL_NAMES_3D`); raises on unknown or repeated
    names."""
    names = list(names)
    if not names:
        raise ConfigError(f"signals.names is empty; choose a subset of {list(allowed)}")
    bad = [s for s in names if s not in allowed]
    if bad:
        raise ConfigError(f"signals.names has unknown {bad}; allowed: {list(allowed)}")
    if len(set(names)) != len(names):
        raise ConfigError(f"signals.names={names} repeats a signal")
    return [allowed.index(s) for s in names]
