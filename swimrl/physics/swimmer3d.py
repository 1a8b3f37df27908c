r"""Spheroidal microswimmer dynamics in 3D: the paper's eqs. ``eq:eom`` with $\boldsymbol n$ a
unit vector.

$$
\frac{\mathrm d\boldsymbol x}{\mathrm dt} = \boldsymbol u(\boldsymbol x, t) + v_s\,\boldsymbol n,
\qquad
\frac{\mathrm d\boldsymbol n}{\mathrm dt} = \Omega\boldsymbol n
 + \Lambda\left[\mathbb S\boldsymbol n
 - (\boldsymbol n\cdot\mathbb S\boldsymbol n)\,\boldsymbol n\right],
\qquad
\Omega\boldsymbol n = \tfrac12\,\boldsymbol\omega\times\boldsymbol n,
$$

$A_{ij} = \partial_j u_i = S_{ij} + W_{ij}$ the velocity gradient,
$\mathbb S = (\mathbb A + \mathbb A^{\mathsf T})/2$ the strain rate,
$\mathbb W = (\mathbb A - \mathbb A^{\mathsf T})/2$ the rotation rate
($\mathbb W\boldsymbol n = \tfrac12\,\boldsymbol\omega\times\boldsymbol n$,
$\boldsymbol\omega = \nabla\times\boldsymbol u$) and
$\Lambda = (\lambda^2 - 1)/(\lambda^2 + 1)$ the shape factor. Equivalently
$\mathrm d\boldsymbol n/\mathrm dt = \boldsymbol w\times\boldsymbol n$ with the angular velocity
$\boldsymbol w = \tfrac12\,\boldsymbol\omega + \Lambda\,\boldsymbol n\times(\mathbb S\boldsymbol n)$
(:func:`angular_velocity`), since
$(\boldsymbol n\times\mathbb S\boldsymbol n)\times\boldsymbol n
= \mathbb S\boldsymbol n - (\boldsymbol n\cdot\mathbb S\boldsymbol n)\,\boldsymbol n$
for $|\boldsymbol n| = 1$.

**Flow channels.** A 3D flow gives, at each swimmer, the eleven channels of
:data:`CHANNELS_3D`: $q = (u_x, u_y, u_z, S_{xx}, S_{yy}, S_{xy}, S_{xz}, S_{yz}, \omega_x,
\omega_y, \omega_z)$, the strain traceless ($S_{zz} = -S_{xx} - S_{yy}$, incompressible flow).
The trace would not change $\mathrm d\boldsymbol n/\mathrm dt$:
$\mathbb S \to \mathbb S + c\,\mathbb I$ leaves
$\mathbb S\boldsymbol n - (\boldsymbol n\cdot\mathbb S\boldsymbol n)\,\boldsymbol n$ unchanged.

**Time integration** (:func:`heun_step_3d`). Heun's method of the 2D
:func:`swimrl.physics.swimmer.heun_step`, with the angle increment
$\delta t\,\mathrm d\theta/\mathrm dt$ replaced by a rotation $R(\boldsymbol\phi)\,\boldsymbol n$
(Rodrigues, :func:`rotate`) by the rotation vector $\boldsymbol\phi = \delta t\,\boldsymbol w$:

$$
\begin{aligned}
&\boldsymbol w_1 = \boldsymbol w(\boldsymbol x_n, \boldsymbol n_n, t_n),\quad
\tilde{\boldsymbol x} = \boldsymbol x_n + \delta t\,\boldsymbol v_1,\quad
\tilde{\boldsymbol n} = R(\delta t\,\boldsymbol w_1)\,\boldsymbol n_n,\\
&\boldsymbol w_2 = \boldsymbol w(\tilde{\boldsymbol x}, \tilde{\boldsymbol n}, t_n + \delta t),\quad
\boldsymbol x_{n+1} = \boldsymbol x_n + \delta t\,(\boldsymbol v_1 + \boldsymbol v_2)/2,\\
&\boldsymbol n_{n+1} = R\big(\delta t\,(\boldsymbol w_1 + \boldsymbol w_2)/2\big)\,\boldsymbol n_n,
\end{aligned}
$$

with $\boldsymbol v = \boldsymbol u + v_s\boldsymbol n$ and $\Lambda$ held over the step. Second
order (tested); $\boldsymbol n$ stays a unit vector by construction (it is renormalised after
each step against round-off); a constant $\boldsymbol\omega$ with no strain is integrated
exactly; and for motion in a plane ($\boldsymbol n$, $\boldsymbol u$ in the $x$-$y$ plane,
$\boldsymbol\omega$ along $z$) $\boldsymbol w$ is along $z$ and the step is the 2D Heun step of
$\theta$ to round-off.

**Rotational diffusion** (:func:`rotational_diffusion`) with coefficient $D_r$: the
Stratonovich SDE

$$
\mathrm d\boldsymbol n = \frac{\mathrm d\boldsymbol n}{\mathrm dt}\,\mathrm dt
 + \sqrt{2D_r}\,(\mathbb I - \boldsymbol n\boldsymbol n)\circ\mathrm d\boldsymbol W
$$

(Itô:
$\mathrm d\boldsymbol n = (\mathrm d\boldsymbol n/\mathrm dt - 2D_r\boldsymbol n)\,\mathrm dt +
\sqrt{2D_r}\,(\mathbb I - \boldsymbol n\boldsymbol n)\,\mathrm d\boldsymbol W$),
$\boldsymbol W$ a 3D Wiener process, whose noise part generates $D_r$ times the Laplacian on
the sphere: $\langle\boldsymbol n(t)\cdot\boldsymbol n(0)\rangle = e^{-2D_r t}$.
It is split from the drift (Lie splitting): after the Heun step $\boldsymbol n$ is turned by
an angle $\varphi$ towards a uniformly random tangent direction, with $1 - \cos\varphi$
exponentially distributed of mean $a = 1 - e^{-2D_r\delta t}$. Then
$E[\boldsymbol n'\,|\,\boldsymbol n] = e^{-2D_r\delta t}\,\boldsymbol n$ exactly, so the
correlation is exact at any $\delta t$, and the second moment of $1 - \cos\varphi$ is the
heat kernel's to $O(\delta t^3)$
($\langle P_2(\boldsymbol n'\cdot\boldsymbol n)\rangle = e^{-6D_r\delta t} + a^3$): the noise
substep is weak second order. The splitting is weak first order in general; it is the
symmetric (second-order) splitting shifted by half a noise substep, an $O(D_r\,\delta t)$
offset at the observation times that does not grow.
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
    r"""The channels :data:`CHANNELS_3D` of a velocity ``u`` ``(..., 3)`` and velocity gradient
    ``grad`` ``(..., 3, 3)``, ``grad[..., i, j]`` $= A_{ij} = \partial_j u_i$:
    $\mathbb S = (\mathbb A + \mathbb A^{\mathsf T})/2$ less its trace
    ($S_{zz} = -S_{xx} - S_{yy}$),
    $\boldsymbol\omega = (A_{zy} - A_{yz}, A_{xz} - A_{zx}, A_{yx} - A_{xy})$.

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
    r"""The strain rate $\mathbb S$ ``(..., 3, 3)`` of channels ``q`` ``(..., 11)``,
    $S_{zz} = -S_{xx} - S_{yy}$."""
    s_xx, s_yy, s_xy, s_xz, s_yz = (q[..., k] for k in range(3, 8))
    rows = (
        torch.stack((s_xx, s_xy, s_xz), -1),
        torch.stack((s_xy, s_yy, s_yz), -1),
        torch.stack((s_xz, s_yz, -s_xx - s_yy), -1),
    )
    return torch.stack(rows, -2)


def strain_dot(q: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    r"""$\mathbb S\boldsymbol n$ ``(..., 3)`` from channels ``q`` ``(..., 11)``
    ($\mathbb S$ traceless)."""
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
    r"""The angular velocity
    $\boldsymbol w = \tfrac12\,\boldsymbol\omega +
    \Lambda\,\boldsymbol n\times(\mathbb S\boldsymbol n)$ of the Jeffery equation, so that

    $$
    \frac{\mathrm d\boldsymbol n}{\mathrm dt} = \boldsymbol w\times\boldsymbol n
    = \tfrac12\,\boldsymbol\omega\times\boldsymbol n
    + \Lambda\left[\mathbb S\boldsymbol n
    - (\boldsymbol n\cdot\mathbb S\boldsymbol n)\,\boldsymbol n\right].
    $$

    Parameters
    ----------
    q
        Flow channels :data:`CHANNELS_3D` at the swimmers, ``(..., 11)``.
    n
        Unit orientations, ``(..., 3)``.
    shape_factor
        $\Lambda$, ``(...)`` or a scalar.

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
    r"""Right-hand side $(\mathrm d\boldsymbol x/\mathrm dt, \mathrm d\boldsymbol n/\mathrm dt)$ of
    the 3D equations of motion:

    $$
    \frac{\mathrm d\boldsymbol x}{\mathrm dt} = \boldsymbol u + v_s\,\boldsymbol n,
    \qquad
    \frac{\mathrm d\boldsymbol n}{\mathrm dt} = \tfrac12\,\boldsymbol\omega\times\boldsymbol n
    + \Lambda\left[\mathbb S\boldsymbol n
    - (\boldsymbol n\cdot\mathbb S\boldsymbol n)\,\boldsymbol n\right].
    $$

    Parameters
    ----------
    q
        Flow channels :data:`CHANNELS_3D` at the swimmers, ``(..., 11)``.
    n
        Unit orientations, ``(..., 3)``.
    shape_factor
        $\Lambda$ of each swimmer, ``(...)`` (or a scalar).
    swim_speed
        $v_s$ in the flow's units.

    Returns
    -------
    tuple[torch.Tensor, torch.Tensor]
        $\mathrm d\boldsymbol x/\mathrm dt$ and $\mathrm d\boldsymbol n/\mathrm dt$, both
        ``(..., 3)``.
    """
    lam = torch.as_tensor(shape_factor, dtype=n.dtype, device=n.device).unsqueeze(-1)
    sn = strain_dot(q, n)
    nsn = (n * sn).sum(-1, keepdim=True)
    rate = 0.5 * torch.linalg.cross(q[..., 8:11], n, dim=-1) + lam * (sn - nsn * n)
    return q[..., 0:3] + swim_speed * n, rate


def rotate(n: torch.Tensor, phi: torch.Tensor) -> torch.Tensor:
    r"""$R(\boldsymbol\phi)\,\boldsymbol n$: $\boldsymbol n$ turned by the angle $|\boldsymbol\phi|$
    about $\boldsymbol\phi$ (Rodrigues),

    $$
    R(\boldsymbol\phi)\,\boldsymbol n = \boldsymbol n
    + \frac{\sin a}{a}\,\boldsymbol\phi\times\boldsymbol n
    + \frac{1 - \cos a}{a^2}\,\boldsymbol\phi\times(\boldsymbol\phi\times\boldsymbol n),
    \qquad a = |\boldsymbol\phi|,
    $$

    with $(1 - \cos a)/a^2 = \operatorname{sinc}^2(a/2)/2$, accurate at small $a$.
    """
    a = phi.norm(dim=-1, keepdim=True)
    s1 = torch.sinc(a / math.pi)
    s2 = 0.5 * torch.sinc(a / (2 * math.pi)) ** 2
    c = torch.linalg.cross(phi, n, dim=-1)
    return n + s1 * c + s2 * torch.linalg.cross(phi, c, dim=-1)


def rotational_diffusion(n: torch.Tensor, xi: torch.Tensor, d_r_dt: float) -> torch.Tensor:
    r"""One noise substep of rotational diffusion on the sphere over $\delta t$
    (``d_r_dt`` $= D_r\,\delta t$).

    With $\boldsymbol\xi\sim\mathcal N(0, \mathbb I_3)$,
    $\boldsymbol\xi_\perp = \boldsymbol\xi - (\boldsymbol\xi\cdot\boldsymbol n)\,\boldsymbol n$
    (a 2D standard normal in the tangent plane: uniform direction,
    $|\boldsymbol\xi_\perp|^2/2\sim\mathrm{Exp}(1)$), $a = 1 - e^{-2D_r\delta t}$ and
    $y = \min(a|\boldsymbol\xi_\perp|^2/2,\ 2) = 1 - \cos\varphi$:

    $$
    \boldsymbol n' = (1 - y)\,\boldsymbol n + \sqrt{a/2}\,\sqrt{2 - y}\;\boldsymbol\xi_\perp,
    $$

    i.e. $\boldsymbol n' = \boldsymbol n\cos\varphi + \boldsymbol e\sin\varphi$ with
    $\boldsymbol e = \boldsymbol\xi_\perp/|\boldsymbol\xi_\perp|$ ($|\boldsymbol n'| = 1$ exactly)
    and $E[\boldsymbol n'\,|\,\boldsymbol n] = e^{-2D_r\delta t}\,\boldsymbol n$ (up to the cut at
    $y = 2$, of probability $e^{-2/a}$).

    Parameters
    ----------
    n
        Unit orientations, ``(..., 3)``.
    xi
        Standard normal numbers $\boldsymbol\xi$, ``(..., 3)``.
    d_r_dt
        $D_r\,\delta t$.
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
    extra_rate: Callable[[torch.Tensor], torch.Tensor] | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""One Heun step of $(\boldsymbol x, \boldsymbol n)$ over $[t, t + \delta t]$, $\Lambda$ held
    (module docstring):
    $\tilde{\boldsymbol x} = \boldsymbol x + \delta t\,\boldsymbol v_1$,
    $\tilde{\boldsymbol n} = R(\delta t\,\boldsymbol w_1)\,\boldsymbol n$;
    $\boldsymbol x' = \boldsymbol x + \delta t\,(\boldsymbol v_1 + \boldsymbol v_2)/2$,
    $\boldsymbol n' = R\big(\delta t\,(\boldsymbol w_1 + \boldsymbol w_2)/2\big)\,\boldsymbol n$;
    then, with noise, :func:`rotational_diffusion`; then $\boldsymbol n'/|\boldsymbol n'|$.

    Parameters
    ----------
    sample
        ``sample(pos)``: the flow channels ``(..., 11)`` at ``pos`` at the current flow time.
    advance
        ``advance()``: moves the flow from $t$ to $t + \delta t$, between the two stages.
    pos, n
        Positions and unit orientations ``(..., 3)`` at $t$.
    shape_factor
        $\Lambda$ of each swimmer, ``(...)`` (or a scalar).
    swim_speed, dt
        $v_s$ and the step $\delta t$, in the flow's units.
    rot_noise
        Standard normal numbers ``(..., 3)`` of this step's rotational noise (or None).
    rot_diffusion
        $D_r$ in the flow's units (used with ``rot_noise``).
    extra_rate
        ``extra_rate(n)``: a further angular velocity added to $\boldsymbol w$ at both stages,
        e.g. the gyrotactic torque (:mod:`swimrl.physics.gyrotaxis`); None: none.

    Returns
    -------
    tuple[torch.Tensor, torch.Tensor]
        Positions and orientations at $t + \delta t$.
    """
    q1 = sample(pos)
    v1 = q1[..., 0:3] + swim_speed * n
    w1 = angular_velocity(q1, n, shape_factor)
    if extra_rate is not None:
        w1 = w1 + extra_rate(n)
    pos_p = pos + dt * v1
    n_p = rotate(n, dt * w1)
    advance()
    q2 = sample(pos_p)
    v2 = q2[..., 0:3] + swim_speed * n_p
    w2 = angular_velocity(q2, n_p, shape_factor)
    if extra_rate is not None:
        w2 = w2 + extra_rate(n_p)
    pos = pos + (0.5 * dt) * (v1 + v2)
    n = rotate(n, (0.5 * dt) * (w1 + w2))
    if rot_noise is not None:
        n = rotational_diffusion(n, rot_noise, rot_diffusion * dt)
    return pos, n / n.norm(dim=-1, keepdim=True)
