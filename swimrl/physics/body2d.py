r"""The 2D swimmer's body: its orientation angle $\theta$, the five flow channels, its
signals (paper Sec. II C), its Heun step and its draws (:class:`Body2D`, one
:class:`~swimrl.physics.body.Body`).

The signals, in the body frame and in units of $\tau_K$:

With $\boldsymbol d = \boldsymbol x - \boldsymbol x_0$ the displacement from the start point,
$\boldsymbol e_r = \boldsymbol d/|\boldsymbol d|$ and
$\boldsymbol e_\theta = \hat{\boldsymbol z}\times\boldsymbol e_r = (-e_{r,y}, e_{r,x})$:

* $n_r = \boldsymbol n\cdot\boldsymbol e_r$,
  $n_\theta = \boldsymbol n\cdot\boldsymbol e_\theta = \sin(\theta - \phi)$ ($\phi$ the polar
  angle of $\boldsymbol d$);
* $S_{nn}\tau_K = \boldsymbol n\cdot\mathbb S\cdot\boldsymbol n\,\tau_K$,
  $S_{np}\tau_K = \boldsymbol n\cdot\mathbb S\cdot\boldsymbol p\,\tau_K$, $\omega\tau_K$.

At the start point ($|\boldsymbol d| = 0$) the polar basis is undefined; swimrl defines
$\boldsymbol e_r := \boldsymbol n$ there, i.e. $n_r = 1$, $n_\theta = 0$ (the swimmer regards
its initial heading as outward). The same rule applies whenever $|\boldsymbol d| < 10^{-12}$
in flow units.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

from swimrl.physics.swimmer import heun_step, strain_nn, strain_np

SIGNAL_NAMES: tuple[str, ...] = ("n_r", "n_theta", "S_nn", "S_np", "omega")
"""All signal names, in the order of the ``signals`` key of the environment."""

#: Signals computed from the flow signals, the same in 2D and 3D and independent of how the
#: frame $(\boldsymbol p_1, \boldsymbol p_2)$ spins about $\boldsymbol n$: the strain's lever
#: $|(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n|\tau_K$ and the vorticity's
#: torque on it $\boldsymbol n\cdot(\boldsymbol\omega\times\mathbb S\boldsymbol n)\tau_K^2$, whose
#: ratio gives the tumbling-minimising shape $\Lambda^* = \mathrm{torque}/(2\,\mathrm{lever}^2)$
#: (:mod:`swimrl.physics.tumbling`); observable with ``signals.names`` (``signals=invariant``).
DERIVED_NAMES: tuple[str, ...] = ("lever", "torque")

#: The two frame-invariant terms of the optimised rule (``docs/physics.md``, "Optimised
#: rules"), the same in 2D and 3D: the STO term $\sqrt{1 - n_r^2}\,\mathrm{sign}\,S_{np_1}$
#: ($-n_\theta\,\mathrm{sign}\,S_{np}$ in the plane) and the stabilising term
#: $\mathrm{torque}/\mathrm{lever}$ ($-\omega\tau_K\,\mathrm{sign}\,S_{np}$ in the plane;
#: 0 where the lever vanishes); observable with ``signals=rule_terms``.
RULE_TERM_NAMES: tuple[str, ...] = ("sto_term", "stab_term")

#: Colabrese et al.'s (2017) twelve states, one-hot (:func:`twelve_states`).
STATE12_NAMES: tuple[str, ...] = tuple(f"state12_{i}" for i in range(12))

#: The vorticity bins' edge in units of $1/\tau_K$: $|\omega|\tau_K = 2/3$, i.e.
#: $|\omega| = \omega_0/3$ in the Taylor-Green flow ($\omega_0\tau_K = 2$).
STATE12_VORTICITY = 2.0 / 3.0


def twelve_states(signals: torch.Tensor) -> torch.Tensor:
    r"""Colabrese et al.'s (2017) discrete state, one-hot ``(..., 12)``: index
    $4 b_\omega + b_n$ with the vorticity bin $b_\omega$ = 0, 1, 2 for
    $\omega\tau_K < -2/3$, within $\pm 2/3$, $> 2/3$ (:data:`STATE12_VORTICITY`) and the heading
    sector $b_n$ = 0, 1, 2, 3 for $\boldsymbol n$ within $\pm45°$ of $+\boldsymbol e_r$,
    $-\boldsymbol e_\theta$, $-\boldsymbol e_r$, $+\boldsymbol e_\theta$. With
    ``task=vertical`` ($\boldsymbol e_r = \hat y$, $\boldsymbol e_\theta = -\hat x$) the
    sectors are up, right, down, left."""
    n_r, n_th, omega = signals[..., 0], signals[..., 1], signals[..., 4]
    b_w = (omega > -STATE12_VORTICITY).long() + (omega > STATE12_VORTICITY).long()
    along, across = n_r.abs() >= n_th.abs(), n_th.abs() > n_r.abs()
    b_n = torch.where(along & (n_r >= 0), 0, torch.where(across & (n_th < 0), 1,
                      torch.where(along, 2, 3)))
    return torch.nn.functional.one_hot(4 * b_w + b_n, 12).to(signals.dtype)


def compute_signals(
    q: torch.Tensor, theta: torch.Tensor, displacement: torch.Tensor, tau_k: float
) -> torch.Tensor:
    r"""All five signals $(n_r, n_\theta, S_{nn}\tau_K, S_{np}\tau_K, \omega\tau_K)$ (Sec. II C).

    Parameters
    ----------
    q
        Flow channels $(u_x, u_y, S_{xx}, S_{xy}, \omega)$ at the swimmers, ``(..., 5)``.
    theta
        Orientation angles, ``(...)``.
    displacement
        $\boldsymbol x - \boldsymbol x_0$, ``(..., 2)``: its direction is $\boldsymbol e_r$
        ($\boldsymbol n$ at the start point).
    tau_k
        The flow's $\tau_K$, the unit of the strain and vorticity signals.

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


def channels_2d(u: torch.Tensor, grad: torch.Tensor) -> torch.Tensor:
    r"""The five 2D channels $(u_x, u_y, S_{xx}, S_{xy}, \omega)$ of
    :data:`swimrl.flows.base.CHANNELS` from ``u`` ``(..., 2)`` and
    $A_{ij} = \partial_j u_i$ ``(..., 2, 2)``:
    $S_{xx} = A_{xx}$, $S_{xy} = (A_{xy} + A_{yx})/2$, $\omega = A_{yx} - A_{xy}$
    (incompressible: $S_{yy} = A_{yy} = -S_{xx}$)."""
    return torch.stack((u[..., 0], u[..., 1], grad[..., 0, 0],
                        0.5 * (grad[..., 0, 1] + grad[..., 1, 0]),
                        grad[..., 1, 0] - grad[..., 0, 1]), -1)


class Body2D:
    r"""The planar spheroid: orientation $\boldsymbol n = (\cos\theta, \sin\theta)$ stored as the
    angle $\theta$ ``(...)``, $\dot\theta = \omega/2 + \Lambda\,\boldsymbol p\cdot\mathbb S
    \boldsymbol n$ (:mod:`swimrl.physics.swimmer`), the five channels and signals of this
    module, STO $\Lambda = -\Lambda_\max\,\mathrm{sign}(n_\theta)\,\mathrm{sign}(S_{np})$
    (``eq:sto``)."""

    dim = 2
    #: The axis of the upward vertical (gyrotaxis, ``task=vertical``): $y$.
    vertical_axis = 1
    #: The environment's attribute and the trajectories' key of the orientation.
    orientation_name = "theta"
    #: Per-swimmer shape of the orientation and of one step's rotational noise.
    orientation_shape: tuple[int, ...] = ()
    n_channels = 5
    signal_names = SIGNAL_NAMES
    #: Frame-invariant signals and the twelve states computed from the five (:meth:`derived`).
    derived_names = DERIVED_NAMES + STATE12_NAMES + RULE_TERM_NAMES
    #: A further rate of the orientation (None; a gyrotactic body's torque,
    #: :class:`~swimrl.physics.gyrotaxis.GyrotacticBody`).
    extra_rate = None

    def channels(self, u: torch.Tensor, grad: torch.Tensor) -> torch.Tensor:
        """The five channels from ``u`` and ``grad`` (:func:`channels_2d`)."""
        return channels_2d(u, grad)

    def heading(self, theta: torch.Tensor) -> torch.Tensor:
        r"""$\boldsymbol n = (\cos\theta, \sin\theta)$, ``(..., 2)``."""
        return torch.stack((torch.cos(theta), torch.sin(theta)), -1)

    def signals(self, q: torch.Tensor, theta: torch.Tensor, frame: torch.Tensor,
                tau_k: float) -> torch.Tensor:
        """The five signals (:func:`compute_signals`), ``e_r`` along ``frame``."""
        return compute_signals(q, theta, frame, tau_k)

    def derived(self, signals: torch.Tensor) -> torch.Tensor:
        r"""The lever $|(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n|\tau_K
        = |S_{np}|\tau_K$ and the torque
        $\boldsymbol n\cdot(\boldsymbol\omega\times\mathbb S\boldsymbol n)\tau_K^2
        = -\omega S_{np}\tau_K^2$ (in the plane, $\boldsymbol\omega = \omega\hat z$), the 3D
        :meth:`Body3D.derived <swimrl.physics.body3d.Body3D.derived>` in the plane; then the
        twelve one-hot states (:func:`twelve_states`); then the rule's STO and stabilising
        terms (:meth:`invariant_terms`), ``(..., 16)``."""
        s_np = signals[..., 3]
        _, sto, stab, _ = self.invariant_terms(signals)
        return torch.cat((torch.stack((s_np.abs(), -signals[..., 4] * s_np), -1),
                          twelve_states(signals), torch.stack((sto, stab), -1)), -1)

    def sto_sign(self, signals: torch.Tensor) -> torch.Tensor:
        r"""$\sigma = -\mathrm{sign}(n_\theta)\,\mathrm{sign}(S_{np})$: STO is
        $\Lambda = \Lambda_\max\sigma$ (``eq:sto``), ``(...)``."""
        return -(torch.sign(signals[..., 1]) * torch.sign(signals[..., 3]))

    def invariant_terms(self, signals: torch.Tensor
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        r"""$(n_r,\ -n_\theta\,\mathrm{sign}\,S_{np},\ -\omega\tau_K\,\mathrm{sign}\,S_{np},
        \ S_{nn}\tau_K)$: the terms of the minimal model that do not depend on the frame's
        orientation (the 3D ones in the plane, :class:`~swimrl.physics.body3d.Body3D`)."""
        sgn = torch.sign(signals[..., 3])
        return signals[..., 0], -signals[..., 1] * sgn, -signals[..., 4] * sgn, signals[..., 2]

    def draw_orientations(self, n: int, generator: torch.Generator, device, dtype
                          ) -> torch.Tensor:
        r"""``n`` angles uniform in $[0, 2\pi)$."""
        return torch.rand(n, generator=generator, device=device, dtype=dtype) * (2 * math.pi)

    def draw_directions(self, n: int, generator: torch.Generator, device, dtype
                        ) -> torch.Tensor:
        r"""``n`` unit vectors $(\cos\phi, \sin\phi)$, $\phi$ uniform, ``(n, 2)``."""
        angle = torch.rand(n, generator=generator, device=device, dtype=dtype) * (2 * math.pi)
        return torch.stack((torch.cos(angle), torch.sin(angle)), -1)

    def heun_step(self, channels: Callable[[torch.Tensor], torch.Tensor],
                  advance: Callable[[], None], pos: torch.Tensor, theta: torch.Tensor,
                  shape_factor: torch.Tensor, swim_speed: float, dt: float,
                  noise: torch.Tensor | None, rot_diffusion: float, tau_k: float,
                  extra_rate: Callable[[torch.Tensor], torch.Tensor] | None = None
                  ) -> tuple[torch.Tensor, torch.Tensor]:
        r"""One Heun step (:func:`~swimrl.physics.swimmer.heun_step`) of swimmers ``(..., 2)``,
        ``theta`` ``(...)``; ``channels(pos)`` ``(..., 5)``; with ``noise`` (standard normal,
        ``(...)``) the angle kick $\sqrt{2 D_r\,\delta t}\,\xi$,
        $D_r$ = ``rot_diffusion / tau_k``; ``extra_rate(theta)`` a further
        $\mathrm d\theta/\mathrm dt$ (angles flattened to ``(P,)``)."""
        batch = theta.shape
        kick = None
        if noise is not None:
            kick = math.sqrt(2 * rot_diffusion / tau_k * dt) * noise.reshape(-1)

        def flat(p: torch.Tensor) -> torch.Tensor:
            return channels(p.view(*batch, 2)).view(-1, 5)

        pos, theta = heun_step(flat, advance, pos.reshape(-1, 2), theta.reshape(-1),
                               shape_factor.reshape(-1), swim_speed, dt, kick, extra_rate)
        return pos.view(*batch, 2), theta.view(batch)

    def alignment_rate(self, theta: torch.Tensor, direction: torch.Tensor,
                       bottom_heaviness: float) -> torch.Tensor:
        r"""The rotation of $\boldsymbol n$ towards $\boldsymbol k$ by the torque of a bottom-heavy
        swimmer, $\dot{\boldsymbol n} = [\boldsymbol k - (\boldsymbol k\cdot\boldsymbol n)
        \boldsymbol n]/(2B)$, as an angle rate:
        $\dot\theta = (\boldsymbol n\times\boldsymbol k)_z/(2B)
        = (k_y\cos\theta - k_x\sin\theta)/(2B)$; ``direction`` $\boldsymbol k$
        ``(..., 2)``, ``(...)``."""
        return (direction[..., 1] * torch.cos(theta)
                - direction[..., 0] * torch.sin(theta)) / (2.0 * bottom_heaviness)

    def normalise(self, theta: torch.Tensor) -> torch.Tensor:
        r"""$\theta \bmod 2\pi$."""
        return torch.remainder(theta, 2 * math.pi)

    def isotropic_state(self, n: int, generator: torch.Generator, dtype: torch.dtype
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        r"""``n`` swimmers in an isotropic Gaussian velocity gradient, drawn in this order:
        $\theta$ uniform; $S_{xx}, S_{xy}$ of variance $1/8$ each
        ($\langle S_{ij}S_{ij}\rangle = 1/2$); $\omega$ of variance 1; $\boldsymbol u = 0$.
        Returns the angles ``(n,)``, the channels ``(n, 5)`` and $\boldsymbol e_r = \hat x$."""
        theta = torch.rand(n, generator=generator, dtype=dtype) * (2 * math.pi)
        strain = torch.randn(n, 2, generator=generator, dtype=dtype) / math.sqrt(8.0)
        omega = torch.randn(n, 1, generator=generator, dtype=dtype)
        q = torch.cat((torch.zeros(n, 2, dtype=dtype), strain, omega), -1)
        return theta, q, torch.tensor([1.0, 0.0], dtype=dtype)
