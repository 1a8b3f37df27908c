r"""Spheroidal microswimmer dynamics in 3D: the paper's eqs. ``eq:eom`` with ``n`` a unit vector.

``dx/dt = u(x, t) + v_s n``,
``dn/dt = Omega n + Lambda (S n - (n.S n) n)``,  ``Omega n = (omega x n)/2``,

``A_ij = d_j u_i = S_ij + W_ij`` the velocity gradient, ``S = (A + A^T)/2`` the strain rate,
``W = (A - A^T)/2`` the rotation rate (``W n = (omega x n)/2``, ``omega = curl u``) and
``Lambda = (lambda^2 - 1)/(lambda^2 + 1)`` the shape factor. Equivalently
``dn/dt = w x n`` with the angular velocity ``w = omega/2 + Lambda n x (S n)``
(:func:`angular_velocity`), since ``(n x S n) x n = S n - (n.S n) n`` for ``|n| = 1``.

**Flow channels.** A 3D flow gives, at each swimmer, the eleven channels of
:data:`CHANNELS_3D`: ``q = (u_x, u_y, u_z, S_xx, S_yy, S_xy, S_xz, S_yz, omega_x, omega_y,
omega_z)``, the strain traceless (``S_zz = -S_xx - S_yy``, incompressible flow). The trace
would not change ``dn/dt``: ``S -> S + c I`` leaves ``S n - (n.S n) n`` unchanged.

**Time integration** (:func:`heun_step_3d`). Heun's method of the 2D
:func:`swimrl.physics.swimmer.heun_step`, with the angle increment ``dt dtheta/dt`` replaced
by a rotation ``R(phi) n`` (Rodrigues, :func:`rotate`) by the rotation vector ``phi = dt w``:

``w1 = w(x_n, n_n, t_n)``, ``x~ = x_n + dt v1``, ``n~ = R(dt w1) n_n``,
``w2 = w(x~, n~, t_n + dt)``, ``x_{n+1} = x_n + dt (v1 + v2)/2``,
``n_{n+1} = R(dt (w1 + w2)/2) n_n``,

with ``v = u + v_s n`` and ``Lambda`` held over the step. Second order (tested); ``n`` stays
a unit vector by construction (it is renormalised after each step against round-off); a
constant ``omega`` with no strain is integrated exactly; and for motion in a plane
(``n``, ``u`` in the x-y plane, ``omega`` along z) ``w`` is along z and the step is the 2D
Heun step of ``theta`` to round-off.

**Rotational diffusion** (:func:`rotational_diffusion`) with coefficient ``D_r``: the
Stratonovich SDE ``dn = (dn/dt) dt + sqrt(2 D_r) (I - n n) o dW`` (Ito:
``dn = (dn/dt - 2 D_r n) dt + sqrt(2 D_r) (I - n n) dW``), ``W`` a 3D Wiener process, whose
noise part generates ``D_r`` times the Laplacian on the sphere: ``<n(t).n(0)> = exp(-2 D_r t)``.
It is split from the drift (Lie splitting): after the Heun step ``n`` is turned by an angle
``phi`` towards a uniformly random tangent direction, with ``1 - cos phi`` exponentially
distributed of mean ``a = 1 - exp(-2 D_r dt)``. Then ``E[n'|n] = exp(-2 D_r dt) n`` exactly,
so the correlation is exact at any ``dt``, and the second moment of ``1 - cos phi`` is the
heat kernel's to ``O(dt^3)`` (``<P_2(n'.n)> = exp(-6 D_r dt) + a^3``): the noise substep is
weak second order. The splitting is weak first order in general; it is the symmetric
(second-order) splitting shifted by half a noise substep, an ``O(D_r dt)`` offset at the
observation times that does not grow.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

Sampler = Callable[[torch.Tensor], torch.Tensor]

CHANNELS_3D: tuple[str, ...] = (
    "u_x", "u_y", "u_z", "S_xx", "S_yy", "S_xy", "S_xz", "S_yz", "omega_x", "omega_y", "omega_z",
)
"""The eleven flow channels of a 3D flow at the swimmers, in this order (strain traceless)."""


def channels_from_gradient(u: torch.Tensor, grad: torch.Tensor) -> torch.Tensor:
    """The channels :data:`CHANNELS_3D` of a velocity ``u`` ``(..., 3)`` and velocity gradient
    ``grad[..., i, j] = d_j u_i`` ``(..., 3, 3)``: ``S = (A + A^T)/2`` less its trace
    (``S_zz = -S_xx - S_yy``), ``omega = (A_zy - A_yz, A_xz - A_zx, A_yx - A_xy)``.

    Returns
    -------
    torch.Tensor
        ``(..., 11)``.
    """
    a = grad
    tr = (a[..., 0, 0] + a[..., 1, 1] + a[..., 2, 2]) / 3
    return torch.stack(
        (
            u[..., 0], u[..., 1], u[..., 2],
            a[..., 0, 0] - tr, a[..., 1, 1] - tr,
            0.5 * (a[..., 0, 1] + a[..., 1, 0]),
            0.5 * (a[..., 0, 2] + a[..., 2, 0]),
            0.5 * (a[..., 1, 2] + a[..., 2, 1]),
            a[..., 2, 1] - a[..., 1, 2], a[..., 0, 2] - a[..., 2, 0], a[..., 1, 0] - a[..., 0, 1],
        ),
        -1,
    )


def strain_tensor(q: torch.Tensor) -> torch.Tensor:
    """The strain rate ``S`` ``(..., 3, 3)`` of channels ``q`` ``(..., 11)``,
    ``S_zz = -S_xx - S_yy``."""
    s_xx, s_yy, s_xy, s_xz, s_yz = (q[..., k] for k in range(3, 8))
    rows = (
        torch.stack((s_xx, s_xy, s_xz), -1),
        torch.stack((s_xy, s_yy, s_yz), -1),
        torch.stack((s_xz, s_yz, -s_xx - s_yy), -1),
    )
    return torch.stack(rows, -2)


def strain_dot(q: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    """``S n`` ``(..., 3)`` from channels ``q`` ``(..., 11)`` (``S`` traceless)."""
    s_xx, s_yy, s_xy, s_xz, s_yz = (q[..., k] for k in range(3, 8))
    nx, ny, nz = n[..., 0], n[..., 1], n[..., 2]
    return torch.stack(
        (
            s_xx * nx + s_xy * ny + s_xz * nz,
            s_xy * nx + s_yy * ny + s_yz * nz,
            s_xz * nx + s_yz * ny - (s_xx + s_yy) * nz,
        ),
        -1,
    )


def angular_velocity(q: torch.Tensor, n: torch.Tensor, shape_factor) -> torch.Tensor:
    """The angular velocity ``w = omega/2 + Lambda n x (S n)`` of the Jeffery equation, so that
    ``dn/dt = w x n = (omega x n)/2 + Lambda (S n - (n.S n) n)``.

    Parameters
    ----------
    q
        Flow channels :data:`CHANNELS_3D` at the swimmers, ``(..., 11)``.
    n
        Unit orientations, ``(..., 3)``.
    shape_factor
        ``Lambda``, ``(...)`` or a scalar.

    Returns
    -------
    torch.Tensor
        ``(..., 3)``.
    """
    lam = torch.as_tensor(shape_factor, dtype=n.dtype, device=n.device)
    return 0.5 * q[..., 8:11] + lam.unsqueeze(-1) * torch.linalg.cross(n, strain_dot(q, n), dim=-1)


def swimmer_rhs_3d(
    q: torch.Tensor, n: torch.Tensor, shape_factor, swim_speed: float
) -> tuple[torch.Tensor, torch.Tensor]:
    """Right-hand side ``(dx/dt, dn/dt)`` of the 3D equations of motion:

    ``dx/dt = u + v_s n``;
    ``dn/dt = (omega x n)/2 + Lambda (S n - (n.S n) n)``.

    Parameters
    ----------
    q
        Flow channels :data:`CHANNELS_3D` at the swimmers, ``(..., 11)``.
    n
        Unit orientations, ``(..., 3)``.
    shape_factor
        ``Lambda`` of each swimmer, ``(...)`` (or a scalar).
    swim_speed
        ``v_s`` in the flow's units.

    Returns
    -------
    tuple[torch.Tensor, torch.Tensor]
        ``dx/dt`` and ``dn/dt``, both ``(..., 3)``.
    """
    lam = torch.as_tensor(shape_factor, dtype=n.dtype, device=n.device).unsqueeze(-1)
    sn = strain_dot(q, n)
    nsn = (n * sn).sum(-1, keepdim=True)
    rate = 0.5 * torch.linalg.cross(q[..., 8:11], n, dim=-1) + lam * (sn - nsn * n)
    return q[..., 0:3] + swim_speed * n, rate


def rotate(n: torch.Tensor, phi: torch.Tensor) -> torch.Tensor:
    """``R(phi) n``: ``n`` turned by the angle ``|phi|`` about ``phi`` (Rodrigues),

    ``R(phi) n = n + (sin a / a) phi x n + ((1 - cos a)/a^2) phi x (phi x n)``, ``a = |phi|``,

    with ``(1 - cos a)/a^2 = sinc^2(a/2)/2``, accurate at small ``a``.
    """
    a = phi.norm(dim=-1, keepdim=True)
    s1 = torch.sinc(a / math.pi)
    s2 = 0.5 * torch.sinc(a / (2 * math.pi)) ** 2
    c = torch.linalg.cross(phi, n, dim=-1)
    return n + s1 * c + s2 * torch.linalg.cross(phi, c, dim=-1)


def rotational_diffusion(n: torch.Tensor, xi: torch.Tensor, d_r_dt: float) -> torch.Tensor:
    """One noise substep of rotational diffusion on the sphere over ``dt`` (``d_r_dt = D_r dt``).

    With ``xi ~ N(0, I_3)``, ``xi_p = xi - (xi.n) n`` (a 2D standard normal in the tangent
    plane: uniform direction, ``|xi_p|^2/2 ~ Exp(1)``), ``a = 1 - exp(-2 D_r dt)`` and
    ``y = min(a |xi_p|^2/2, 2) = 1 - cos phi``:

    ``n' = (1 - y) n + sqrt(a/2) sqrt(2 - y) xi_p``,

    i.e. ``n' = n cos phi + e sin phi`` with ``e = xi_p/|xi_p|`` (``|n'| = 1`` exactly) and
    ``E[n'|n] = exp(-2 D_r dt) n`` (up to the cut at ``y = 2``, of probability
    ``exp(-2/a)``).

    Parameters
    ----------
    n
        Unit orientations, ``(..., 3)``.
    xi
        Standard normal numbers, ``(..., 3)``.
    d_r_dt
        ``D_r dt``.
    """
    a = -math.expm1(-2.0 * d_r_dt)
    xi_p = xi - (xi * n).sum(-1, keepdim=True) * n
    y = (0.5 * a * (xi_p * xi_p).sum(-1, keepdim=True)).clamp(max=2.0)
    return (1.0 - y) * n + math.sqrt(0.5 * a) * torch.sqrt(2.0 - y) * xi_p


def heun_step_3d(
    sample: Sampler,
    advance: Callable[[], None],
    pos: torch.Tensor,
    n: torch.Tensor,
    shape_factor,
    swim_speed: float,
    dt: float,
    rot_noise: torch.Tensor | None = None,
    rot_diffusion: float = 0.0,
) -> tuple[torch.Tensor, torch.Tensor]:
    """One Heun step of ``(x, n)`` over ``[t, t + dt]``, ``Lambda`` held (module docstring):

    ``x~ = x + dt v1``, ``n~ = R(dt w1) n``; ``x' = x + dt (v1 + v2)/2``,
    ``n' = R(dt (w1 + w2)/2) n``; then, with noise, :func:`rotational_diffusion`; then
    ``n' / |n'|``.

    Parameters
    ----------
    sample
        ``sample(pos)``: the flow channels ``(..., 11)`` at ``pos`` at the current flow time.
    advance
        ``advance()``: moves the flow from ``t`` to ``t + dt``, between the two stages.
    pos, n
        Positions and unit orientations ``(..., 3)`` at ``t``.
    shape_factor
        ``Lambda`` of each swimmer, ``(...)`` (or a scalar).
    swim_speed, dt
        ``v_s`` and the step, in the flow's units.
    rot_noise
        Standard normal numbers ``(..., 3)`` of this step's rotational noise (or None).
    rot_diffusion
        ``D_r`` in the flow's units (used with ``rot_noise``).

    Returns
    -------
    tuple[torch.Tensor, torch.Tensor]
        Positions and orientations at ``t + dt``.
    """
    q1 = sample(pos)
    v1 = q1[..., 0:3] + swim_speed * n
    w1 = angular_velocity(q1, n, shape_factor)
    pos_p = pos + dt * v1
    n_p = rotate(n, dt * w1)
    advance()
    q2 = sample(pos_p)
    v2 = q2[..., 0:3] + swim_speed * n_p
    w2 = angular_velocity(q2, n_p, shape_factor)
    pos = pos + (0.5 * dt) * (v1 + v2)
    n = rotate(n, (0.5 * dt) * (w1 + w2))
    if rot_noise is not None:
        n = rotational_diffusion(n, rot_noise, rot_diffusion * dt)
    return pos, n / n.norm(dim=-1, keepdim=True)
