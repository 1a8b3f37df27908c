r"""The swimmer's body: everything the dimension of space decides, in one place.

A :class:`Body` is the swimmer as the environment, the integrators and the strategies see it:
the shape of its orientation, the flow channels it needs from $(\boldsymbol u,
\nabla\boldsymbol u)$, the names and values of its signals, one Heun step of

$$
\dot{\boldsymbol x} = \boldsymbol u + v_s\boldsymbol n, \qquad
\dot{\boldsymbol n} = \tfrac12\boldsymbol\omega\times\boldsymbol n
  + \Lambda(\mathbb I - \boldsymbol n\boldsymbol n)\mathbb S\boldsymbol n
$$

(paper eqs. 1a, 1b; in the plane $\dot\theta = \omega/2 + \Lambda\,\boldsymbol p\cdot\mathbb S
\boldsymbol n$), the draws of start orientations and target directions, and the STO rule's
sign $\sigma$ ($\Lambda_\mathrm{STO} = \Lambda_\max\sigma$). Two implementations:
:class:`~swimrl.physics.body2d.Body2D` and :class:`~swimrl.physics.body3d.Body3D`.
:func:`body` is the one place where a dimension becomes a body, and :func:`body_of_signals`
the one place where a signal vector's width does; nothing else in swimrl branches on the
dimension.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

import torch

from swimrl.errors import ConfigError
from swimrl.physics.body2d import Body2D
from swimrl.physics.body3d import Body3D

#: Not a flow signal: the swimmer's own shape factor, the ``Lambda`` it held over the last
#: decision interval (0 before its first decision), observable with ``signals.names`` in 2D
#: and 3D (the state of ``reward.shape_change_weight``'s cost, which depends on it).
SHAPE_SIGNAL = "Lambda"


class Body(Protocol):
    """What the environment, the integrators and the strategies need of a swimmer
    (module docstring); :class:`~swimrl.physics.body2d.Body2D` and
    :class:`~swimrl.physics.body3d.Body3D` implement it."""

    #: The dimension of space.
    dim: int
    #: The axis of the upward vertical (the last one).
    vertical_axis: int
    #: The environment's attribute and the trajectories' key of the orientation.
    orientation_name: str
    #: Per-swimmer shape of the orientation and of one step's rotational noise.
    orientation_shape: tuple[int, ...]
    #: Width of the flow channels the body reads.
    n_channels: int
    #: All signals, in the ``signals`` key's order.
    signal_names: tuple[str, ...]
    #: Signals computed from them, observable too (:meth:`derived`).
    derived_names: tuple[str, ...]
    #: A further rate of the orientation added by the Heun step (None: none; the torque of a
    #: :class:`~swimrl.physics.gyrotaxis.GyrotacticBody`).
    extra_rate: Callable[[torch.Tensor], torch.Tensor] | None

    def channels(self, u: torch.Tensor, grad: torch.Tensor) -> torch.Tensor:
        """The channels from ``u`` ``(..., d)`` and ``A_ij = d_j u_i`` ``(..., d, d)``."""

    def heading(self, orientation: torch.Tensor) -> torch.Tensor:
        """The unit vector ``n`` of each orientation, ``(..., d)``."""

    def signals(self, q: torch.Tensor, orientation: torch.Tensor, frame: torch.Tensor,
                tau_k: float) -> torch.Tensor:
        """All signals from the channels ``q``, with ``e_r`` along ``frame`` ``(..., d)``."""

    def derived(self, signals: torch.Tensor) -> torch.Tensor:
        """The :attr:`derived_names` signals computed from ``signals``, ``(..., k')``."""

    def sto_sign(self, signals: torch.Tensor) -> torch.Tensor:
        """STO's sign ``sigma`` in ``{-1, 0, 1}``: ``Lambda_STO = Lambda_max sigma``."""

    def invariant_terms(self, signals: torch.Tensor
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """The frame-invariant terms ``(n_r, STO, stabilisation, S_nn)`` of the minimal
        model (``docs/physics.md``, "Optimised rules")."""

    def draw_orientations(self, n: int, generator: torch.Generator, device, dtype
                          ) -> torch.Tensor:
        """``n`` uniformly random orientations."""

    def draw_directions(self, n: int, generator: torch.Generator, device, dtype
                        ) -> torch.Tensor:
        """``n`` uniformly random unit vectors ``(n, d)``."""

    def heun_step(self, channels: Callable[[torch.Tensor], torch.Tensor],
                  advance: Callable[[], None], pos: torch.Tensor, orientation: torch.Tensor,
                  shape_factor: torch.Tensor, swim_speed: float, dt: float,
                  noise: torch.Tensor | None, rot_diffusion: float, tau_k: float,
                  extra_rate: Callable[[torch.Tensor], torch.Tensor] | None = None
                  ) -> tuple[torch.Tensor, torch.Tensor]:
        """One Heun step of positions and orientations, ``Lambda`` held; ``extra_rate`` a
        further rate of the orientation (an angle rate in 2D, an angular velocity in 3D)."""

    def alignment_rate(self, orientation: torch.Tensor, direction: torch.Tensor,
                       bottom_heaviness: float) -> torch.Tensor:
        """The rate of the orientation under the torque ``[k - (k.n) n] / (2B)`` of a
        bottom-heavy swimmer (the form :meth:`heun_step`'s ``extra_rate`` takes)."""

    def normalise(self, orientation: torch.Tensor) -> torch.Tensor:
        """The orientation in its canonical range (the angle mod 2 pi in 2D)."""

    def isotropic_state(self, n: int, generator: torch.Generator, dtype: torch.dtype
                        ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """``n`` orientations and channels of an isotropic Gaussian velocity gradient, and
        a fixed ``e_r``."""


#: The bodies by dimension.
BODIES: dict[int, Body] = {2: Body2D(), 3: Body3D()}


def body(dim: int) -> Body:
    """The body of a ``dim``-dimensional flow (2: :class:`~swimrl.physics.body2d.Body2D`,
    3: :class:`~swimrl.physics.body3d.Body3D`); ConfigError for any other dimension."""
    try:
        return BODIES[int(dim)]
    except (KeyError, TypeError, ValueError):
        raise ConfigError(f"a flow of dimension {dim!r} has no swimmer body: allowed "
                          f"{sorted(BODIES)}") from None


def body_of_signals(signals: torch.Tensor | Sequence[str]) -> Body:
    """The body whose full signal set is ``signals``: a tensor ``(..., k)`` (by its width
    ``k``: 5 in 2D, 7 in 3D) or a sequence of names (exactly one body's set, in order);
    ValueError naming both sets otherwise (a strategy given signals it cannot read)."""
    for b in BODIES.values():
        if isinstance(signals, torch.Tensor):
            if signals.shape[-1] == len(b.signal_names):
                return b
        elif tuple(signals) == b.signal_names:
            return b
    got = (f"{signals.shape[-1]} signal columns" if isinstance(signals, torch.Tensor)
           else f"the signals {list(signals)}")
    sets = " or ".join(f"{list(b.signal_names)} ({b.dim}D)" for b in BODIES.values())
    raise ValueError(f"{got} are no body's full signal set: a strategy reads all the signals "
                     f"of its flow, {sets}")


def signal_indices(names, allowed: tuple[str, ...]) -> list[int]:
    """Positions of ``names`` in ``allowed`` (a body's :attr:`Body.signal_names`, with
    :data:`SHAPE_SIGNAL` where observable); ConfigError on unknown or repeated names."""
    names = list(names)
    if not names:
        raise ConfigError(f"signals.names is empty; choose a subset of {list(allowed)}")
    bad = [s for s in names if s not in allowed]
    if bad:
        raise ConfigError(f"signals.names has unknown {bad}; allowed: {list(allowed)}")
    if len(set(names)) != len(names):
        raise ConfigError(f"signals.names={names} repeats a signal")
    return [allowed.index(s) for s in names]


def observable_names(body: Body) -> tuple[str, ...]:
    """Every name a policy of ``body`` may observe, in the order of :func:`observable`: the
    body's signals, the derived ones, :data:`SHAPE_SIGNAL`."""
    return body.signal_names + body.derived_names + (SHAPE_SIGNAL,)


def observable(body: Body, signals: torch.Tensor, names: Sequence[str],
               shape: torch.Tensor | None = None) -> torch.Tensor:
    """The observation ``names`` (a subset of :func:`observable_names`) from the body's
    signals ``(..., k)``, the derived signals computed only where one is observed and the
    shape held ``shape`` ``(...)`` where :data:`SHAPE_SIGNAL` is; ``(..., len(names))``."""
    parts = [signals]
    if SHAPE_SIGNAL in names or any(n in body.derived_names for n in names):
        parts.append(body.derived(signals))
    if SHAPE_SIGNAL in names:
        if shape is None:
            raise ValueError(f"{SHAPE_SIGNAL!r} is observed but no shape was given")
        parts.append(shape.unsqueeze(-1))
    full = torch.cat(parts, -1) if len(parts) > 1 else signals
    return full[..., signal_indices(names, observable_names(body))]
