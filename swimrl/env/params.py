"""The environment's parameters: the swimmer and the episode (:class:`EnvParams`), and the
clocks of staggered flows (:func:`clock_offsets`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import torch

from swimrl.actuation import ActuationSpec
from swimrl.conf_values import yaml_value
from swimrl.errors import ConfigError, as_float, keep_number_types, require
from swimrl.physics.body import BODIES, Body, body, observable_names, signal_indices
from swimrl.physics.body2d import SIGNAL_NAMES
from swimrl.physics.gyrotaxis import GyrotacticBody
from swimrl.task import RewardSpec, TaskSpec


def _ratio(num: float, den: float, key: str, value: float, what: str) -> int:
    """Integer ``num/den``, or a ConfigError naming ``key``."""
    r = num / den
    k = round(r)
    if k < 1 or abs(r - k) > 1e-6 * max(1.0, r):
        raise ConfigError(
            f"{key}={value!r} is invalid: allowed values making {what} (now {r:.6g}) a positive "
            "integer"
        )
    return k


@dataclass(frozen=True)
class EnvParams:
    """Swimmer and episode parameters (dimensionless: times / tau_K, speeds / u_rms).

    ``shape_factor_max`` (``Lambda_max``) bounds the action: the environment's action spec is
    ``[-Lambda_max, Lambda_max]``, from which actors and baselines read it. ``task`` and
    ``reward``: :mod:`swimrl.task`. The defaults (for library calls) are read from the
    configs' ``swimmer.*``, ``episode.*``, ``signals=all``, ``task=displacement`` and
    ``reward.*`` (:mod:`swimrl.conf_values`): ``EnvParams()`` is the paper's swimmer and
    episode.
    A value out of range raises :class:`~swimrl.errors.ConfigError` naming its config key.

    Parameters
    ----------
    swim_speed
        ``v_s / u_rms`` (``swimmer.swim_speed``; the paper: 0.707).
    rot_diffusion
        Rotational diffusion ``D_r tau_K`` (``swimmer.rot_diffusion``; 0: none).
    duration
        Episode length ``T / tau_K`` (``episode.duration``; the paper: 200).
    update_interval
        Decision interval ``T_u / tau_K`` (``episode.update_interval``; the paper: 0.1).
    dt
        Heun step ``dt / tau_K`` (``episode.dt``; the paper: 0.01); ``update_interval / dt``
        and ``duration / update_interval`` must be integers.
    shape_factor_max
        ``Lambda_max`` in ``(0, 1)`` (``swimmer.shape_factor_max``; the paper: 0.98).
    signals
        The signals the policy observes (``signals.names``): names of
        :data:`~swimrl.physics.body2d.SIGNAL_NAMES` (2D) or
        :data:`~swimrl.physics.body3d.SIGNAL_NAMES_3D` (3D), and optionally
        :data:`~swimrl.physics.body.SHAPE_SIGNAL` (the shape held).
    task
        The task (``task.*``): displacement (the paper's) or target.
    reward
        The energy costs added to the reward (``reward.*``; none by default).
    bottom_heaviness
        The gyrotactic reorientation time ``B / tau_K`` (``swimmer.bottom_heaviness``; None:
        no gyrotaxis), :mod:`swimrl.physics.gyrotaxis`.
    actuation
        What the action sets (``actuation.*``): the shape (the paper's), the direction, or
        both (:mod:`swimrl.actuation`).

    Attributes
    ----------
    n_substeps : int
        Heun steps per decision, ``T_u / dt`` (10).
    n_decisions : int
        Decisions per episode, ``N = T / T_u`` (2000).
    """

    swim_speed: float = yaml_value("evaluate", "swimmer.swim_speed")
    rot_diffusion: float = yaml_value("evaluate", "swimmer.rot_diffusion")
    duration: float = yaml_value("evaluate", "episode.duration")
    update_interval: float = yaml_value("evaluate", "episode.update_interval")
    dt: float = yaml_value("evaluate", "episode.dt")
    shape_factor_max: float = yaml_value("evaluate", "swimmer.shape_factor_max")
    signals: tuple[str, ...] = SIGNAL_NAMES
    task: TaskSpec = TaskSpec()
    reward: RewardSpec = RewardSpec()
    bottom_heaviness: float | None = yaml_value("evaluate", "swimmer.bottom_heaviness")
    actuation: ActuationSpec = ActuationSpec()
    n_substeps: int = field(init=False)
    n_decisions: int = field(init=False)

    def __post_init__(self) -> None:
        as_float("swimmer.swim_speed", self.swim_speed, lambda v: v > 0, "> 0 (units u_rms)")
        as_float("swimmer.rot_diffusion", self.rot_diffusion, lambda v: v >= 0,
                 ">= 0 (units 1/tau_K)")
        as_float("episode.duration", self.duration, lambda v: v > 0, "> 0 (units tau_K)")
        as_float("episode.dt", self.dt, lambda v: v > 0, "> 0 (units tau_K)")
        as_float("episode.update_interval", self.update_interval,
                 lambda v: 0 < v <= self.duration, f"in (0, episode.duration={self.duration}]")
        as_float("swimmer.shape_factor_max", self.shape_factor_max, lambda v: 0 < v < 1,
                 "in (0, 1)")
        if self.bottom_heaviness is not None:
            as_float("swimmer.bottom_heaviness", self.bottom_heaviness, lambda v: v > 0,
                     "> 0 (units tau_K) or null (no gyrotaxis)")
        require(not self.actuation.steers or self.bottom_heaviness is not None,
                "actuation.name", self.actuation.name,
                "'shape' without swimmer.bottom_heaviness (a preferred direction steers through "
                "the gyrotactic torque: set swimmer.bottom_heaviness > 0)")
        require(not (self.task.target and self.reward.progress != "distance"),
                "reward.progress", self.reward.progress,
                "'distance' with task=target (its reward and arrival count the distance)")
        if self.task.vertical:
            as_float("task.burn_in", self.task.burn_in, lambda v: v < self.duration,
                     f"in [0, episode.duration={self.duration}) (units tau_K)")
        every = tuple(name for b in BODIES.values() for name in observable_names(b))
        signal_indices(self.signals, tuple(dict.fromkeys(every)))
        object.__setattr__(
            self,
            "n_substeps",
            _ratio(self.update_interval, self.dt, "episode.dt", self.dt, "update_interval/dt"),
        )
        object.__setattr__(
            self,
            "n_decisions",
            _ratio(
                self.duration,
                self.update_interval,
                "episode.update_interval",
                self.update_interval,
                "duration/update_interval",
            ),
        )
        keep_number_types(self)

    def body(self, dim: int, tau_k: float) -> Body:
        """The swimmer of a ``dim``-dimensional flow of time unit ``tau_k``: the body of the
        dimension (:func:`~swimrl.physics.body.body`), bottom-heavy
        (:class:`~swimrl.physics.gyrotaxis.GyrotacticBody`, ``B`` in flow units) where
        ``bottom_heaviness`` is set. A new object for a gyrotactic swimmer (it holds the
        swimmers' preferred directions)."""
        base = body(dim)
        if self.bottom_heaviness is None:
            return base
        return GyrotacticBody(base, self.bottom_heaviness * tau_k)


def clock_offsets(n_flows: int, n_decisions: int, groups: int, device=None
                  ) -> torch.Tensor | None:
    """The clock of flow ``f`` at the first reset: ``(f mod groups) floor(N / groups)``
    (:meth:`SwimmerEnv.stagger`); None for ``groups = 1`` (no offset)."""
    if groups < 1 or groups > n_flows:
        raise ValueError(f"groups={groups} must be in [1, n_flows={n_flows}]")
    if groups == 1:
        return None
    return (torch.arange(n_flows, device=device) % groups) * (n_decisions // groups)
