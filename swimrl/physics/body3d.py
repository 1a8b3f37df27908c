r"""The 3D swimmer's body: its unit orientation $\boldsymbol n$, the eleven flow channels,
its signals, its Heun step and its draws (:class:`Body3D`, one
:class:`~swimrl.physics.body.Body`).

The signals, in the body frame $(\boldsymbol n,\boldsymbol p_1,\boldsymbol p_2)$, in units of
$\tau_K$:

With $\boldsymbol d = \boldsymbol x - \boldsymbol x_0$ the displacement from the start point
and $\boldsymbol e_r = \boldsymbol d/|\boldsymbol d|$:

* $n_r = \boldsymbol n\cdot\boldsymbol e_r$;
* $\boldsymbol p_1$ the unit vector along
  $\boldsymbol w = \boldsymbol e_r - (\boldsymbol e_r\cdot\boldsymbol n)\,\boldsymbol n$ (the
  direction in which $\boldsymbol n$ must turn towards $\boldsymbol e_r$;
  $\boldsymbol e_r = n_r\boldsymbol n + \sqrt{1 - n_r^2}\,\boldsymbol p_1$),
  $\boldsymbol p_2 = \boldsymbol n\times\boldsymbol p_1$;
* $S_{nn} = \boldsymbol n\cdot\mathbb S\boldsymbol n\,\tau_K$,
  $S_{np_1} = \boldsymbol p_1\cdot\mathbb S\boldsymbol n\,\tau_K$,
  $S_{np_2} = \boldsymbol p_2\cdot\mathbb S\boldsymbol n\,\tau_K$;
* $\omega_n = \boldsymbol\omega\cdot\boldsymbol n\,\tau_K$,
  $\omega_{p_1} = \boldsymbol\omega\cdot\boldsymbol p_1\,\tau_K$,
  $\omega_{p_2} = \boldsymbol\omega\cdot\boldsymbol p_2\,\tau_K$.

Conventions where the frame is undefined: at the start point ($|\boldsymbol d| < 10^{-12}$ in
flow units) $\boldsymbol e_r := \boldsymbol n$ ($n_r = 1$), as in 2D
(:mod:`swimrl.physics.body2d`). Where $\boldsymbol e_r$ is parallel to $\boldsymbol n$
($|\boldsymbol w| < \sqrt\epsilon$ of the dtype: $3.5\times10^{-4}$ in float32,
$1.5\times10^{-8}$ in float64, below which the direction of $\boldsymbol w$ is not resolved to
better than $\sqrt\epsilon$ rad), $\boldsymbol p_1$ is the fixed perpendicular
$\boldsymbol f/|\boldsymbol f|$,
$\boldsymbol f = (\mathbb I - \boldsymbol n\boldsymbol n)\,\hat{\boldsymbol e}_k$,
$\hat{\boldsymbol e}_k$ the coordinate axis of the smallest $|n_k|$ (the first of equal ones).
There $\boldsymbol e_r\cdot\boldsymbol p_1 = 0$: the strain cannot turn $\boldsymbol n$ towards
$\boldsymbol e_r$ at first order, whatever $\boldsymbol p_1$ is.

In the plane ($\boldsymbol n$, $\boldsymbol d$ in the $x$-$y$ plane, $\boldsymbol\omega$ along
$z$), with the 2D $\boldsymbol p = \hat{\boldsymbol z}\times\boldsymbol n$ and
$n_\theta = \boldsymbol n\cdot(\hat{\boldsymbol z}\times\boldsymbol e_r)$:
$\boldsymbol e_r - (\boldsymbol e_r\cdot\boldsymbol n)\,\boldsymbol n
= (\boldsymbol e_r\cdot\boldsymbol p)\,\boldsymbol p = -n_\theta\,\boldsymbol p$, so
$\boldsymbol p_1 = -\mathrm{sign}(n_\theta)\,\boldsymbol p$,
$\boldsymbol p_2 = -\mathrm{sign}(n_\theta)\,\hat{\boldsymbol z}$ and
$S_{np_1} = -\mathrm{sign}(n_\theta)\,S_{np}$, $S_{np_2} = 0$,
$\omega_n = \omega_{p_1} = 0$, $\omega_{p_2} = -\mathrm{sign}(n_\theta)\,\omega$ (tested).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

from swimrl.physics.swimmer3d import channels_from_gradient, heun_step_3d, strain_dot

SIGNAL_NAMES_3D: tuple[str, ...] = (
    "n_r", "S_nn", "S_np1", "S_np2", "omega_n", "omega_p1", "omega_p2",
)
"""All 3D signal names, in the order of :func:`compute_signals_3d`."""

#: The derived signals, lever and torque (:meth:`Body3D.derived`), named as in 2D
#: (:data:`swimrl.physics.body2d.DERIVED_NAMES`).
DERIVED_NAMES: tuple[str, ...] = ("lever", "torque")

#: The rule's STO and stabilising terms (:data:`swimrl.physics.body2d.RULE_TERM_NAMES`).
RULE_TERM_NAMES: tuple[str, ...] = ("sto_term", "stab_term")


def _lever_and_torque(signals: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    r"""$(S_{np_1}^2 + S_{np_2}^2)^{1/2}$ and $S_{np_2}\omega_{p_1} - S_{np_1}\omega_{p_2}$
    (the lever and $\boldsymbol n\cdot(\boldsymbol\omega\times\mathbb S\boldsymbol n)$) from
    the seven signals, each ``(...)``."""
    s1, s2 = signals[..., 2], signals[..., 3]
    return torch.sqrt(s1 * s1 + s2 * s2), s2 * signals[..., 5] - s1 * signals[..., 6]


def _rule_terms(signals: torch.Tensor, lever: torch.Tensor, torque: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor]:
    r"""The rule's STO term $\sqrt{1 - n_r^2}\,\mathrm{sign}\,S_{np_1}$ and stabilising term
    torque/lever (0 where the lever vanishes), each ``(...)``."""
    n_r = signals[..., 0]
    stab = torch.where(lever > 0, torque / torch.where(lever > 0, lever, 1.0), 0.0)
    return torch.sqrt(torch.clamp(1 - n_r * n_r, min=0.0)) * torch.sign(signals[..., 2]), stab


def radial_direction(n: torch.Tensor, displacement: torch.Tensor) -> torch.Tensor:
    r"""$\boldsymbol e_r = \boldsymbol d/|\boldsymbol d|$, and $\boldsymbol n$ where
    $|\boldsymbol d| < 10^{-12}$ (the start point), ``(..., 3)``."""
    r = displacement.norm(dim=-1, keepdim=True)
    at_start = r < 1e-12
    return torch.where(at_start, n, displacement / torch.where(at_start, torch.ones_like(r), r))


def body_frame(n: torch.Tensor, e_r: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    r"""$(\boldsymbol p_1, \boldsymbol p_2)$: $\boldsymbol p_1$ along
    $\boldsymbol e_r - (\boldsymbol e_r\cdot\boldsymbol n)\,\boldsymbol n$ (the fixed
    perpendicular of the module docstring where that is shorter than $\sqrt\epsilon$),
    $\boldsymbol p_2 = \boldsymbol n\times\boldsymbol p_1$; each ``(..., 3)``.
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
    r"""All seven 3D signals
    $(n_r, S_{nn}, S_{np_1}, S_{np_2}, \omega_n, \omega_{p_1}, \omega_{p_2})$, the strain and
    vorticity components times $\tau_K$ (module docstring).

    Parameters
    ----------
    q
        Flow channels :data:`swimrl.physics.swimmer3d.CHANNELS_3D` at the swimmers,
        ``(..., 11)``.
    n
        Unit orientations, ``(..., 3)``.
    displacement
        $\boldsymbol x - \boldsymbol x_0$, ``(..., 3)``: its direction is $\boldsymbol e_r$
        ($\boldsymbol n$ at the start point).
    tau_k
        The flow's $\tau_K$, the unit of the strain and vorticity signals.

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


def unit_vectors(n: int, generator: torch.Generator, device, dtype) -> torch.Tensor:
    """``n`` unit vectors uniform on the sphere (normalised standard normal 3-vectors),
    ``(n, 3)``."""
    v = torch.randn(n, 3, generator=generator, device=device, dtype=dtype)
    return v / v.norm(dim=-1, keepdim=True)


class Body3D:
    r"""The spheroid in 3D: unit orientation $\boldsymbol n$ ``(..., 3)``,
    $\dot{\boldsymbol n} = \tfrac12\boldsymbol\omega\times\boldsymbol n
    + \Lambda(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n$
    (:mod:`swimrl.physics.swimmer3d`), the eleven channels
    :data:`~swimrl.physics.swimmer3d.CHANNELS_3D`, the seven signals of this module, STO
    $\Lambda = \Lambda_\max\,\mathrm{sign}(S_{np_1})$
    (:mod:`swimrl.policies.baselines`, derived there)."""

    dim = 3
    #: The axis of the upward vertical (gyrotaxis, ``task=vertical``): $z$.
    vertical_axis = 2
    #: The environment's attribute and the trajectories' key of the orientation.
    orientation_name = "orientation"
    #: Per-swimmer shape of the orientation and of one step's rotational noise.
    orientation_shape: tuple[int, ...] = (3,)
    n_channels = 11
    signal_names = SIGNAL_NAMES_3D
    #: Frame-invariant signals computed from the seven (:meth:`derived`).
    derived_names = DERIVED_NAMES + RULE_TERM_NAMES
    #: A further rate of the orientation (None; a gyrotactic body's torque,
    #: :class:`~swimrl.physics.gyrotaxis.GyrotacticBody`).
    extra_rate = None

    def channels(self, u: torch.Tensor, grad: torch.Tensor) -> torch.Tensor:
        """The eleven channels from ``u`` and ``grad``
        (:func:`~swimrl.physics.swimmer3d.channels_from_gradient`)."""
        return channels_from_gradient(u, grad)

    def heading(self, n: torch.Tensor) -> torch.Tensor:
        r"""$\boldsymbol n$ itself, ``(..., 3)``."""
        return n

    def signals(self, q: torch.Tensor, n: torch.Tensor, frame: torch.Tensor,
                tau_k: float) -> torch.Tensor:
        """The seven signals (:func:`compute_signals_3d`), ``e_r`` along ``frame``."""
        return compute_signals_3d(q, n, frame, tau_k)

    def derived(self, signals: torch.Tensor) -> torch.Tensor:
        r"""The lever $|(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n|\tau_K
        = (S_{np_1}^2 + S_{np_2}^2)^{1/2}$ and the torque
        $\boldsymbol n\cdot(\boldsymbol\omega\times\mathbb S\boldsymbol n)\tau_K^2
        = S_{np_2}\omega_{p_1} - S_{np_1}\omega_{p_2}$, then the rule's STO and stabilising
        terms (:meth:`invariant_terms`), ``(..., 4)``: all independent of the frame's rotation
        about $\boldsymbol n$."""
        lever, torque = _lever_and_torque(signals)
        return torch.stack((lever, torque, *_rule_terms(signals, lever, torque)), -1)

    def sto_sign(self, signals: torch.Tensor) -> torch.Tensor:
        r"""$\sigma = \mathrm{sign}(S_{np_1})$: STO is $\Lambda = \Lambda_\max\sigma$,
        ``(...)``."""
        return torch.sign(signals[..., 2])

    def invariant_terms(self, signals: torch.Tensor
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        r"""$(n_r,\ \sqrt{1 - n_r^2}\,\mathrm{sign}\,S_{np_1},\
        \boldsymbol n\cdot(\boldsymbol\omega\times\mathbb S\boldsymbol n)\tau_K /
        |(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n|,\ S_{nn}\tau_K)$
        (0 for the third where the lever vanishes); in the plane they are
        :meth:`Body2D.invariant_terms <swimrl.physics.body2d.Body2D.invariant_terms>`."""
        sto, stab = _rule_terms(signals, *_lever_and_torque(signals))
        return signals[..., 0], sto, stab, signals[..., 1]

    def draw_orientations(self, n: int, generator: torch.Generator, device, dtype
                          ) -> torch.Tensor:
        """``n`` orientations uniform on the sphere (:func:`unit_vectors`)."""
        return unit_vectors(n, generator, device, dtype)

    def draw_directions(self, n: int, generator: torch.Generator, device, dtype
                        ) -> torch.Tensor:
        """``n`` directions uniform on the sphere (:func:`unit_vectors`)."""
        return unit_vectors(n, generator, device, dtype)

    def heun_step(self, channels: Callable[[torch.Tensor], torch.Tensor],
                  advance: Callable[[], None], pos: torch.Tensor, n: torch.Tensor,
                  shape_factor: torch.Tensor, swim_speed: float, dt: float,
                  noise: torch.Tensor | None, rot_diffusion: float, tau_k: float,
                  extra_rate: Callable[[torch.Tensor], torch.Tensor] | None = None
                  ) -> tuple[torch.Tensor, torch.Tensor]:
        r"""One Heun step (:func:`~swimrl.physics.swimmer3d.heun_step_3d`) of swimmers
        ``(..., 3)``; ``channels(pos)`` ``(..., 11)``; with ``noise`` (standard normal,
        ``(..., 3)``) the exact spherical diffusion step, $D_r$ = ``rot_diffusion / tau_k``;
        ``extra_rate(n)`` a further angular velocity ``(..., 3)``."""
        return heun_step_3d(channels, advance, pos, n, shape_factor, swim_speed, dt, noise,
                            rot_diffusion / tau_k, extra_rate)

    def alignment_rate(self, n: torch.Tensor, direction: torch.Tensor,
                       bottom_heaviness: float) -> torch.Tensor:
        r"""The angular velocity $\boldsymbol w_g = \boldsymbol n\times\boldsymbol k/(2B)$ of a
        bottom-heavy swimmer: $\boldsymbol w_g\times\boldsymbol n = [\boldsymbol k -
        (\boldsymbol k\cdot\boldsymbol n)\boldsymbol n]/(2B)$; ``direction`` $\boldsymbol k$
        ``(..., 3)``, ``(..., 3)``."""
        return torch.linalg.cross(n, direction, dim=-1) / (2.0 * bottom_heaviness)

    def normalise(self, n: torch.Tensor) -> torch.Tensor:
        """``n`` as it is (each step normalises it)."""
        return n

    def isotropic_state(self, n: int, generator: torch.Generator, dtype: torch.dtype
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        r"""``n`` swimmers in an isotropic Gaussian velocity gradient, drawn in this order:
        $\boldsymbol n$ uniform on the sphere; $\mathbb S = [(\mathbb G + \mathbb
        G^{\mathsf T})/2 - \tfrac13\mathrm{tr}\,\mathbb G]/\sqrt{10}$, $\mathbb G$ standard
        normal ($\langle S_{ij}S_{ij}\rangle = 1/2$); $\boldsymbol\omega$ of variance 1/3
        per component; $\boldsymbol u = 0$. Returns $\boldsymbol n$ ``(n, 3)``, the channels
        ``(n, 11)`` and $\boldsymbol e_r = \hat z$."""
        g = generator
        v = torch.randn(n, 3, generator=g, dtype=dtype)
        orient = v / v.norm(dim=-1, keepdim=True)
        a = torch.randn(n, 3, 3, generator=g, dtype=dtype)
        s = 0.5 * (a + a.transpose(-1, -2))
        trace = torch.diagonal(s, dim1=-2, dim2=-1).mean(-1)[:, None, None]
        s = s - trace * torch.eye(3, dtype=dtype)
        s = s / math.sqrt(10.0)  # <S_ij S_ij> = 5 / 10
        omega = torch.randn(n, 3, generator=g, dtype=dtype) / math.sqrt(3.0)
        strain = torch.stack((s[:, 0, 0], s[:, 1, 1], s[:, 0, 1], s[:, 0, 2], s[:, 1, 2]), -1)
        q = torch.cat((torch.zeros(n, 3, dtype=dtype), strain, omega), -1)
        return orient, q, torch.tensor([0.0, 0.0, 1.0], dtype=dtype)
