r"""Gyrotaxis: a bottom-heavy swimmer, turned towards a direction $\boldsymbol k$ by gravity's
torque, as in Pedley & Kessler (1992), Durham et al. (2011) and Colabrese et al. (2017):

$$
\dot{\boldsymbol x} = \boldsymbol u + v_s\boldsymbol n, \qquad
\dot{\boldsymbol n} = \frac{\boldsymbol k - (\boldsymbol k\cdot\boldsymbol n)\,\boldsymbol n}{2B}
  + \tfrac12\boldsymbol\omega\times\boldsymbol n
  + \Lambda(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n,
$$

$B$ the reorientation time (``swimmer.bottom_heaviness``, units $\tau_K$), $\boldsymbol k$ the
upward vertical (a passive gyrotactic swimmer) or the direction the swimmer chooses
(``actuation=steer``: an active swimmer that sets its preferred direction $\boldsymbol k_a$,
Colabrese et al. 2017). In the plane, $\dot\theta = (k_y\cos\theta - k_x\sin\theta)/(2B) +
\omega/2 + \Lambda\,\boldsymbol p\cdot\mathbb S\boldsymbol n$; with $\boldsymbol k = \hat y$ and
$\varphi = \theta - \pi/2$ the angle from the vertical, at rest $\dot\varphi =
-\sin\varphi/(2B)$, so $\tan(\varphi/2) = \tan(\varphi_0/2)\,e^{-t/(2B)}$.

:class:`GyrotacticBody` is a :class:`~swimrl.physics.body.Body`: the body of the flow's
dimension with the torque added to both stages of its Heun step (the ``extra_rate`` of
:meth:`~swimrl.physics.body.Body.heun_step`, the form each body gives by its
:meth:`~swimrl.physics.body.Body.alignment_rate`).
"""

from __future__ import annotations

from collections.abc import Callable

import torch

from swimrl.errors import as_float


def unit_axis(dim: int, axis: int, device=None, dtype=None) -> torch.Tensor:
    """The unit vector along coordinate ``axis`` of ``dim``-space."""
    e = torch.zeros(dim, device=device, dtype=dtype)
    e[axis] = 1.0
    return e


def axis_directions(dim: int, device=None, dtype=None) -> torch.Tensor:
    r"""The $2d$ directions of a discrete steering action, ``(2 d, d)``: $+\hat e_1, \dots,
    +\hat e_d$, then $-\hat e_1, \dots, -\hat e_d$ (in 2D: right, up, left, down, Colabrese et
    al.'s four actions; in 3D the six of Gustavsson et al.)."""
    eye = torch.eye(dim, device=device, dtype=dtype)
    return torch.cat((eye, -eye), 0)


class GyrotacticBody:
    r"""A bottom-heavy swimmer (module docstring): ``base``, the body of the flow's dimension,
    with the torque $[\boldsymbol k - (\boldsymbol k\cdot\boldsymbol n)\boldsymbol n]/(2B)$
    added to its orientation's rate. Everything else (signals, channels, draws, STO) is the
    base body's.

    Parameters
    ----------
    base
        The body of the flow's dimension (:func:`~swimrl.physics.body.body`).
    bottom_heaviness
        $B > 0$ in the flow's time unit.

    Attributes
    ----------
    direction : torch.Tensor or None
        $\boldsymbol k$ of every swimmer ``(..., d)``, held over a decision interval; None:
        the upward vertical for all (:meth:`steer` sets it).
    """

    def __init__(self, base, bottom_heaviness: float):
        as_float("swimmer.bottom_heaviness", bottom_heaviness, lambda v: v > 0,
                 "> 0 (units tau_K) or null (no gyrotaxis)")
        self.base = base
        self.bottom_heaviness = float(bottom_heaviness)
        self.direction: torch.Tensor | None = None
        for name in ("dim", "vertical_axis", "orientation_name", "orientation_shape",
                     "n_channels", "signal_names", "derived_names"):
            setattr(self, name, getattr(base, name))

    def up(self, device=None, dtype=None) -> torch.Tensor:
        """The upward vertical, ``(d,)``."""
        return unit_axis(self.dim, self.vertical_axis, device, dtype)

    def steer(self, direction: torch.Tensor | None) -> None:
        r"""Hold $\boldsymbol k$ = ``direction`` ``(..., d)`` (None: the vertical) over the
        next interval."""
        self.direction = direction

    def extra_rate(self, orientation: torch.Tensor) -> torch.Tensor:
        r"""The torque's rate of ``orientation`` (flattened as the base body's Heun step
        passes it), $\boldsymbol k$ broadcast to the same swimmers."""
        batch = orientation.shape[:orientation.dim() - len(self.orientation_shape)]
        if self.direction is None:
            k = self.up(orientation.device, orientation.dtype).expand(*batch, self.dim)
        else:
            k = self.direction.reshape(*batch, self.dim)
        return self.base.alignment_rate(orientation, k, self.bottom_heaviness)

    # -- the base body's, unchanged -------------------------------------------------------
    def channels(self, u, grad):
        return self.base.channels(u, grad)

    def heading(self, orientation):
        return self.base.heading(orientation)

    def signals(self, q, orientation, frame, tau_k):
        return self.base.signals(q, orientation, frame, tau_k)

    def derived(self, signals):
        return self.base.derived(signals)

    def sto_sign(self, signals):
        return self.base.sto_sign(signals)

    def invariant_terms(self, signals):
        return self.base.invariant_terms(signals)

    def draw_orientations(self, n, generator, device, dtype):
        return self.base.draw_orientations(n, generator, device, dtype)

    def draw_directions(self, n, generator, device, dtype):
        return self.base.draw_directions(n, generator, device, dtype)

    def normalise(self, orientation):
        return self.base.normalise(orientation)

    def isotropic_state(self, n, generator, dtype):
        return self.base.isotropic_state(n, generator, dtype)

    def alignment_rate(self, orientation, direction, bottom_heaviness):
        return self.base.alignment_rate(orientation, direction, bottom_heaviness)

    def heun_step(self, channels: Callable[[torch.Tensor], torch.Tensor],
                  advance: Callable[[], None], pos: torch.Tensor, orientation: torch.Tensor,
                  shape_factor: torch.Tensor, swim_speed: float, dt: float,
                  noise: torch.Tensor | None, rot_diffusion: float, tau_k: float,
                  extra_rate: Callable[[torch.Tensor], torch.Tensor] | None = None
                  ) -> tuple[torch.Tensor, torch.Tensor]:
        """The base body's Heun step with the torque (:meth:`extra_rate`) added."""
        rate = self.extra_rate
        if extra_rate is not None:
            def rate(o: torch.Tensor) -> torch.Tensor:
                return self.extra_rate(o) + extra_rate(o)
        return self.base.heun_step(channels, advance, pos, orientation, shape_factor,
                                   swim_speed, dt, noise, rot_diffusion, tau_k, rate)
