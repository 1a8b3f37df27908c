r"""The 3D swimmer's signals, in the body frame ``(n, p1, p2)`` and in units of ``tau_K``.

With ``d = x - x_0`` the displacement from the start point and ``e_r = d/|d|``:

* ``n_r = n.e_r``;
* ``p1`` the unit vector along ``w = e_r - (e_r.n) n`` (the direction in which ``n`` must
  turn towards ``e_r``; ``e_r = n_r n + sqrt(1 - n_r^2) p1``), ``p2 = n x p1``;
* ``S_nn = n.S n tau_K``, ``S_np1 = p1.S n tau_K``, ``S_np2 = p2.S n tau_K``;
* ``omega_n = omega.n tau_K``, ``omega_p1 = omega.p1 tau_K``, ``omega_p2 = omega.p2 tau_K``.

Conventions where the frame is undefined: at the start point (``|d| < 1e-12`` in flow
units) ``e_r := n`` (``n_r = 1``), as in 2D (:mod:`swimrl.physics.signals`). Where ``e_r``
is parallel to ``n`` (``|w| < sqrt(eps)`` of the dtype: ``3.5e-4`` in float32, ``1.5e-8`` in
float64, below which the direction of ``w`` is not resolved to better than ``sqrt(eps)``
rad), ``p1`` is the fixed perpendicular ``(I - n n) e_k / |(I - n n) e_k|``, ``e_k`` the
coordinate axis of the smallest ``|n_k|`` (the first of equal ones). There ``e_r.p1 = 0``:
the strain cannot turn ``n`` towards ``e_r`` at first order, whatever ``p1`` is.

In the plane (``n``, ``d`` in the x-y plane, ``omega`` along z), with the 2D
``p = z x n`` and ``n_theta = n.(z x e_r)``: ``e_r - (e_r.n) n = (e_r.p) p = -n_theta p``, so
``p1 = -sign(n_theta) p``, ``p2 = -sign(n_theta) z`` and ``S_np1 = -sign(n_theta) S_np``,
``S_np2 = 0``, ``omega_n = omega_p1 = 0``, ``omega_p2 = -sign(n_theta) omega`` (tested).
"""

from __future__ import annotations

import torch

from swimrl.physics.swimmer3d import strain_dot

SIGNAL_NAMES_3D: tuple[str, ...] = (
    "n_r", "S_nn", "S_np1", "S_np2", "omega_n", "omega_p1", "omega_p2",
)
"""All 3D signal names, in the order of :func:`compute_signals_3d`."""


def radial_direction(n: torch.Tensor, displacement: torch.Tensor) -> torch.Tensor:
    """``e_r = d/|d|``, and ``n`` where ``|d| < 1e-12`` (the start point), ``(..., 3)``."""
    r = displacement.norm(dim=-1, keepdim=True)
    at_start = r < 1e-12
    return torch.where(at_start, n, displacement / torch.where(at_start, torch.ones_like(r), r))


def body_frame(n: torch.Tensor, e_r: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``(p1, p2)``: ``p1`` along ``e_r - (e_r.n) n`` (the fixed perpendicular of the module
    docstring where that is shorter than ``sqrt(eps)``), ``p2 = n x p1``; each ``(..., 3)``.
    """
    w = e_r - (e_r * n).sum(-1, keepdim=True) * n
    wn = w.norm(dim=-1, keepdim=True)
    axis = torch.nn.functional.one_hot(n.abs().argmin(-1), 3).to(n.dtype)
    f = axis - (axis * n).sum(-1, keepdim=True) * n
    fixed = f / f.norm(dim=-1, keepdim=True)
    parallel = wn < torch.finfo(n.dtype).eps ** 0.5
    p1 = torch.where(parallel, fixed, w / torch.where(parallel, torch.ones_like(wn), wn))
    return p1, torch.linalg.cross(n, p1, dim=-1)


def compute_signals_3d(
    q: torch.Tensor, n: torch.Tensor, displacement: torch.Tensor, tau_k: float
) -> torch.Tensor:
    """All seven 3D signals ``(n_r, S_nn, S_np1, S_np2, omega_n, omega_p1, omega_p2)``,
    the strain and vorticity components times ``tau_K`` (module docstring).

    Parameters
    ----------
    q
        Flow channels :data:`swimrl.physics.swimmer3d.CHANNELS_3D` at the swimmers,
        ``(..., 11)``.
    n
        Unit orientations, ``(..., 3)``.
    displacement
        ``x - x_0``, ``(..., 3)``: its direction is ``e_r`` (``n`` at the start point).
    tau_k
        The flow's ``tau_K``, the unit of the strain and vorticity signals.

    Returns
    -------
    torch.Tensor
        ``(..., 7)``, in the order of :data:`SIGNAL_NAMES_3D`.
    """
    e_r = radial_direction(n, displacement)
    p1, p2 = body_frame(n, e_r)
    sn = strain_dot(q, n) * tau_k
    om = q[..., 8:11] * tau_k
    return torch.stack(
        (
            (n * e_r).sum(-1),
            (n * sn).sum(-1),
            (p1 * sn).sum(-1),
            (p2 * sn).sum(-1),
            (om * n).sum(-1),
            (om * p1).sum(-1),
            (om * p2).sum(-1),
        ),
        -1,
    )
