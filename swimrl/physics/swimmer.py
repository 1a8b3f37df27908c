r"""Spheroidal microswimmer dynamics in 2D (paper eqs. ``eq:eom`` and ``eq:thetaDot``).

$$
\frac{\mathrm d\boldsymbol x}{\mathrm dt} = \boldsymbol u(\boldsymbol x, t) + v_s\,\boldsymbol n,
\quad \boldsymbol n = (\cos\theta, \sin\theta),
\qquad
\frac{\mathrm d\theta}{\mathrm dt} = \frac{\omega}{2}
 + \Lambda\,\boldsymbol p\cdot\mathbb S\cdot\boldsymbol n,
\quad \boldsymbol p = (-\sin\theta, \cos\theta),
$$

with $\boldsymbol p\cdot\mathbb S\cdot\boldsymbol n = S_{xy}\cos 2\theta - S_{xx}\sin 2\theta$
for the traceless 2D strain. Time integration is Heun's method (explicit trapezoidal rule,
second order):

$$
\boldsymbol k_1 = f(\boldsymbol x_n, t_n),\quad
\tilde{\boldsymbol x} = \boldsymbol x_n + \delta t\,\boldsymbol k_1,\quad
\boldsymbol k_2 = f(\tilde{\boldsymbol x}, t_n + \delta t),\quad
\boldsymbol x_{n+1} = \boldsymbol x_n + \delta t\,(\boldsymbol k_1 + \boldsymbol k_2)/2,
$$

with $\Lambda$ held over the step. Optional rotational diffusion adds
$\sqrt{2D_r\,\delta t}\,\xi$ ($\xi\sim\mathcal N(0,1)$) to $\theta$ in both predictor and
corrector (App. "Robustness"); for this additive noise the scheme is the stochastic Heun
method, strong order 1 and weak order 2.
"""

from __future__ import annotations

from collections.abc import Callable

import torch

Sampler = Callable[[torch.Tensor], torch.Tensor]


def strain_np(theta: torch.Tensor, s_xx: torch.Tensor, s_xy: torch.Tensor) -> torch.Tensor:
    r"""Body-frame strain $S_{np} = \boldsymbol n\cdot\mathbb S\cdot\boldsymbol p
    = S_{xy}\cos 2\theta - S_{xx}\sin 2\theta$."""
    return s_xy * torch.cos(2 * theta) - s_xx * torch.sin(2 * theta)


def strain_nn(theta: torch.Tensor, s_xx: torch.Tensor, s_xy: torch.Tensor) -> torch.Tensor:
    r"""Body-frame strain $S_{nn} = \boldsymbol n\cdot\mathbb S\cdot\boldsymbol n
    = S_{xx}\cos 2\theta + S_{xy}\sin 2\theta$."""
    return s_xx * torch.cos(2 * theta) + s_xy * torch.sin(2 * theta)


def swimmer_rhs(
    q: torch.Tensor, theta: torch.Tensor, shape_factor: torch.Tensor, swim_speed: float
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""Right-hand side $(\mathrm d\boldsymbol x/\mathrm dt, \mathrm d\theta/\mathrm dt)$ of the
    paper's eqs. (1a) and (2).

    $$
    \frac{\mathrm d\boldsymbol x}{\mathrm dt} = \boldsymbol u + v_s\,(\cos\theta, \sin\theta),
    \qquad
    \frac{\mathrm d\theta}{\mathrm dt} = \frac{\omega}{2}
     + \Lambda\,(S_{xy}\cos 2\theta - S_{xx}\sin 2\theta).
    $$

    Parameters
    ----------
    q
        Flow channels $(u_x, u_y, S_{xx}, S_{xy}, \omega)$ at the swimmers, ``(P, 5)``.
    theta
        Orientation angles, ``(P,)``.
    shape_factor
        $\Lambda$ of each swimmer, ``(P,)`` (or a scalar).
    swim_speed
        $v_s$ in the flow's units.

    Returns
    -------
    tuple[torch.Tensor, torch.Tensor]
        $\mathrm d\boldsymbol x/\mathrm dt$ ``(P, 2)`` and $\mathrm d\theta/\mathrm dt$ ``(P,)``.
    """
    c, s = torch.cos(theta), torch.sin(theta)
    vel = q[:, 0:2] + swim_speed * torch.stack((c, s), -1)
    c2, s2 = c * c - s * s, 2 * s * c
    rate = 0.5 * q[:, 4] + shape_factor * (q[:, 3] * c2 - q[:, 2] * s2)
    return vel, rate


def heun_step(
    sample: Sampler,
    advance: Callable[[], None],
    pos: torch.Tensor,
    theta: torch.Tensor,
    shape_factor: torch.Tensor,
    swim_speed: float,
    dt: float,
    rot_kick: torch.Tensor | None = None,
    extra_rate: Callable[[torch.Tensor], torch.Tensor] | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""One Heun step of $(\boldsymbol x, \theta)$ over $[t, t + \delta t]$, $\Lambda$ held.

    Parameters
    ----------
    sample
        ``sample(pos)``: the flow channels ``(P, 5)`` at ``pos`` at the current flow time.
    advance
        ``advance()``: moves the flow from $t$ to $t + \delta t$, between the two stages.
    pos, theta
        Positions ``(P, 2)`` and orientation angles ``(P,)`` at $t$.
    shape_factor
        $\Lambda$ of each swimmer.
    swim_speed, dt
        $v_s$ and the step $\delta t$, in the flow's units.
    rot_kick
        The rotational noise increment $\sqrt{2D_r\,\delta t}\,\xi$ of this step (or None).
    extra_rate
        ``extra_rate(theta)``: a further term of $\mathrm d\theta/\mathrm dt$ added at both
        stages, e.g. the gyrotactic torque (:mod:`swimrl.physics.gyrotaxis`); None: none.

    Returns
    -------
    tuple[torch.Tensor, torch.Tensor]
        Positions and angles at $t + \delta t$.
    """
    v1, w1 = swimmer_rhs(sample(pos), theta, shape_factor, swim_speed)
    if extra_rate is not None:
        w1 = w1 + extra_rate(theta)
    pos_p = pos + dt * v1
    theta_p = theta + dt * w1
    if rot_kick is not None:
        theta_p = theta_p + rot_kick
    advance()
    v2, w2 = swimmer_rhs(sample(pos_p), theta_p, shape_factor, swim_speed)
    if extra_rate is not None:
        w2 = w2 + extra_rate(theta_p)
    pos = pos + (0.5 * dt) * (v1 + v2)
    theta = theta + (0.5 * dt) * (w1 + w2)
    if rot_kick is not None:
        theta = theta + rot_kick
    return pos, theta
