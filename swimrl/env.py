r"""TorchRL environment: batched swimmers in batched flows.

Batch shape ``(n_flows, n_swimmers)``: swimmer ``(f, s)`` moves in flow realisation ``f``.
One environment step is one decision interval $T_u$: the action $\Lambda$ (shape factor,
bounded to $[-\Lambda_\mathrm{max}, \Lambda_\mathrm{max}]$) is held while the dynamics
(:mod:`swimrl.physics.swimmer`) is integrated over $T_u / \delta t$ Heun steps. Reward
(``eq:reward``, ``task=displacement``):

$$
r_i = |\boldsymbol x(t_i) - \boldsymbol x_0| - |\boldsymbol x(t_{i-1}) - \boldsymbol x_0|,
$$

so the undiscounted return telescopes to $|\boldsymbol x(t_N) - \boldsymbol x_0|$ (flow length
units); with ``task=target`` it is the decrease of the distance to the target, and
``reward.*`` adds the energy costs (:mod:`swimrl.task`). Episodes are truncated when their
flow has run $N = T / T_u$ decisions; with ``task=target`` a swimmer that arrives is
terminated. Keys:

* ``observation`` – the configured signal subset (``signals.names``), ``(F, S, k)``;
* ``signals`` – all five signals in :data:`swimrl.physics.signals.SIGNAL_NAMES` order (baselines);
* ``distance`` – ``|x - x_0|``, ``(F, S, 1)``;
* ``target_distance`` – ``task=target`` only: ``|X - x|``, ``(F, S, 1)``;
* ``action`` – ``Lambda``, ``(F, S, 1)``; ``reward``; ``done``/``terminated``/``truncated``.

Partial resets (``_reset`` mask ``(F, S, 1)``) start new swimmers at uniformly random
positions and orientations (and targets); a flow whose swimmers all reset also gets a new
realisation, and a swimmer started in a running flow ends with it (the flow's clock
truncates every episode in it, so the flows of a batch renew together, or in
:meth:`~SwimmerEnv.stagger`'s groups).
With ``ic_blocks = B > 1`` the ``S`` swimmers of a flow are ``B`` blocks of ``S / B`` that
start from the same positions and orientations (common random numbers: one block per
strategy in a paired comparison); the draws are those of an environment of ``S / B``
swimmers.
Positions are kept as a wrapped coordinate in ``[0, L)`` plus integer image counts, so the
unbounded displacement

$$
\boldsymbol x - \boldsymbol x_0
  = (\boldsymbol p - \boldsymbol p_0) + L (\boldsymbol m - \boldsymbol m_0)
$$

keeps float32 resolution of the grid cell however far the swimmer goes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

from swimrl.conf_values import yaml_value
from swimrl.errors import (
    ConfigError,
    IntegrityError,
    as_float,
    keep_number_types,
    one_of,
    require,
)
from swimrl.flows.base import GriddedFlow
from swimrl.flows.build import FlowSpec, build_flow
from swimrl.flows.pointwise import PointFlow, channels_2d
from swimrl.flows.registry import POINT_KERNELS
from swimrl.flows.stochastic3d import StochasticFlow3D
from swimrl.physics.energy import drag_factor
from swimrl.physics.integrator import integrate_interval_3d_fused, select_kernel
from swimrl.physics.signals import SHAPE_SIGNAL, SIGNAL_NAMES, compute_signals, signal_indices
from swimrl.physics.signals3d import SIGNAL_NAMES_3D, compute_signals_3d
from swimrl.physics.swimmer import heun_step
from swimrl.physics.swimmer3d import channels_from_gradient, heun_step_3d
from swimrl.runtime import Runtime
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
        :data:`~swimrl.physics.signals.SIGNAL_NAMES` (2D) or
        :data:`~swimrl.physics.signals3d.SIGNAL_NAMES_3D` (3D), and optionally
        :data:`~swimrl.physics.signals.SHAPE_SIGNAL` (the shape held).
    task
        The task (``task.*``): displacement (the paper's) or target.
    reward
        The energy costs added to the reward (``reward.*``; none by default).

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
        signal_indices(self.signals,
                       tuple(dict.fromkeys(SIGNAL_NAMES + SIGNAL_NAMES_3D + (SHAPE_SIGNAL,))))
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


def clock_offsets(n_flows: int, n_decisions: int, groups: int, device=None
                  ) -> torch.Tensor | None:
    """The clock of flow ``f`` at the first reset: ``(f mod groups) floor(N / groups)``
    (:meth:`SwimmerEnv.stagger`); None for ``groups = 1`` (no offset)."""
    if groups < 1 or groups > n_flows:
        raise ValueError(f"groups={groups} must be in [1, n_flows={n_flows}]")
    if groups == 1:
        return None
    return (torch.arange(n_flows, device=device) % groups) * (n_decisions // groups)


class SwimmerEnv(EnvBase):
    """Shape-changing spheroidal swimmers maximising their distance from the start point
    (``task=displacement``) or reaching a target (``task=target``).

    A TorchRL ``EnvBase`` of batch ``(n_flows, n_swimmers)``; one step is one decision
    interval (module docstring for the keys). Usually made by :meth:`build` from a flow
    spec; the constructor takes a flow already built (any
    :class:`~swimrl.flows.base.GriddedFlow`, ``docs/extending.md``).

    Parameters
    ----------
    flow
        ``n_flows`` realisations of a flow; the batch's first dimension.
    n_swimmers
        Swimmers per flow, the batch's second dimension.
    params
        Swimmer and episode parameters.
    generator
        The random generator of initial conditions, flows and noise (default: the flow's,
        else a new one).
    kernel
        The integration kernel: ``auto`` | ``eager`` | ``fused`` | ``compiled``
        (:func:`~swimrl.physics.integrator.select_kernel`).
    ic_blocks
        Blocks of ``n_swimmers / ic_blocks`` swimmers per flow with identical initial
        conditions (common random numbers for paired comparisons).

    Examples
    --------
    A shipped policy over one episode, with TorchRL's ``rollout``:

    >>> from swimrl import EnvParams, Runtime, StochasticSpec, SwimmerEnv, load_policy
    >>> params = EnvParams()
    >>> env = SwimmerEnv.build(StochasticSpec(kubo=10.0), params,
    ...                        Runtime.from_names("cpu", "float32", 1), 2, 100, seed=0)
    >>> td = env.rollout(params.n_decisions, load_policy("pretrained/ku10", params))
    >>> r_hat = env.score(td[..., -1]["next"])          # (2, 100)
    """

    def __init__(
        self,
        flow: GriddedFlow,
        n_swimmers: int,
        params: EnvParams,
        generator: torch.Generator | None = None,
        kernel: str = yaml_value("evaluate", "kernel"),
        ic_blocks: int = 1,
    ):
        if n_swimmers < 1:
            raise ValueError(f"n_swimmers={n_swimmers} must be >= 1")
        if ic_blocks < 1 or n_swimmers % ic_blocks:
            raise ValueError(f"ic_blocks={ic_blocks} must be >= 1 and divide "
                             f"n_swimmers={n_swimmers}")
        batch = torch.Size([flow.n_flows, n_swimmers])
        super().__init__(device=flow.device, batch_size=batch)
        self.ic_blocks = ic_blocks
        self.flow = flow
        self.params = params
        self.generator = generator if generator is not None else flow.generator
        if self.generator is None:
            self.generator = torch.Generator(device=flow.device)
        self.flow.generator = self.generator
        #: The space dimension (2 for every gridded flow).
        self.dim = int(getattr(flow, "dim", 2))
        #: The signals of the ``signals`` key (all of this dimension), in order.
        self.signal_names = SIGNAL_NAMES_3D if self.dim == 3 else SIGNAL_NAMES
        try:
            self._obs_idx = signal_indices(params.signals, self.signal_names + (SHAPE_SIGNAL,))
        except ConfigError as err:
            raise ConfigError(f"{err} (the flow is {self.dim}D)") from None
        self._kernel = self._select_kernel(kernel, flow.device)
        dtype = flow.dtype
        # physical units of the flow
        self.tau_k = flow.tau_k
        self.swim_speed = params.swim_speed * self.velocity_unit(flow)
        self.dt = params.dt * flow.tau_k
        self.rot_kick_std = math.sqrt(2 * params.rot_diffusion / flow.tau_k * self.dt)
        self.reference_distance = self.swim_speed * params.duration * flow.tau_k  # v_s T
        self.task = params.task
        #: ``D`` and the arrival radius in flow units (``task.*`` are in units of ``ell_f``)
        self.target_distance = params.task.distance * flow.ell_f
        self.arrival_radius = params.task.arrival_radius * flow.ell_f
        self.decision_length = self.swim_speed * params.update_interval * flow.tau_k  # v_s T_u
        dev = flow.device
        self._flow_index = torch.arange(flow.n_flows, device=dev).repeat_interleave(n_swimmers)
        d = self.dim
        self.pos = torch.zeros(batch + (d,), device=dev, dtype=dtype)
        self.image = torch.zeros(batch + (d,), device=dev, dtype=torch.int64)
        self.start_pos = torch.zeros_like(self.pos)
        self.start_image = torch.zeros_like(self.image)
        self.theta = torch.zeros(batch, device=dev, dtype=dtype)
        self.step_count = torch.zeros(batch, device=dev, dtype=torch.int64)
        #: Decisions since each flow's last reset, ``(F,)``: the clock that truncates episodes.
        self.flow_step = torch.zeros(flow.n_flows, device=dev, dtype=torch.int64)
        #: ``X - x_0`` of each swimmer's target (``task=target``), ``(F, S, d)``.
        self.target = torch.zeros(batch + (d,), device=dev, dtype=dtype)
        #: Arrived swimmers and the decision at which they arrived (-1: not yet).
        self.arrived = torch.zeros(batch, device=dev, dtype=torch.bool)
        self.arrival_step = torch.full(batch, -1, device=dev, dtype=torch.int64)
        #: ``E_hat`` so far: ``(1/T) int K(Lambda) dt`` (:mod:`swimrl.physics.energy`).
        self.energy = torch.zeros(batch, device=dev, dtype=dtype)
        #: ``C_hat`` so far: ``(1/T) sum_i |Lambda_i - Lambda_{i-1}| T_u`` (the shape change).
        self.shape_change = torch.zeros(batch, device=dev, dtype=dtype)
        #: The previous decision's ``Lambda`` (NaN before the first; the shape-change cost).
        self.last_action = torch.full(batch, math.nan, device=dev, dtype=dtype)
        #: Upper bound of ``max_x |u(x, t)|`` of each flow since its last reset, ``(F,)``.
        self.max_flow_speed = torch.zeros(flow.n_flows, device=dev, dtype=dtype)
        self._flows = torch.arange(flow.n_flows, device=dev)
        #: Clock offsets ``(F,)`` added at the next reset of the flows (:meth:`stagger`).
        self._clock_offset: torch.Tensor | None = None
        lam = params.shape_factor_max
        self.action_spec = Bounded(low=-lam, high=lam, shape=batch + (1,), device=dev, dtype=dtype)
        self.observation_spec = Composite(
            observation=Unbounded(shape=batch + (len(self._obs_idx),), device=dev, dtype=dtype),
            signals=Unbounded(shape=batch + (len(self.signal_names),), device=dev, dtype=dtype),
            distance=Unbounded(shape=batch + (1,), device=dev, dtype=dtype),
            shape=batch,
            device=dev,
        )
        if self.task.target:
            self.observation_spec["target_distance"] = Unbounded(
                shape=batch + (1,), device=dev, dtype=dtype)
        self.reward_spec = Unbounded(shape=batch + (1,), device=dev, dtype=dtype)
        self.done_spec = Composite(
            done=Categorical(2, shape=batch + (1,), dtype=torch.bool, device=dev),
            terminated=Categorical(2, shape=batch + (1,), dtype=torch.bool, device=dev),
            truncated=Categorical(2, shape=batch + (1,), dtype=torch.bool, device=dev),
            shape=batch,
            device=dev,
        )

    @classmethod
    def build(
        cls,
        flow: FlowSpec,
        params: EnvParams,
        runtime: Runtime,
        n_flows: int,
        n_swimmers: int,
        seed: int,
        ic_blocks: int = 1,
        stagger: int = 1,
    ) -> SwimmerEnv:
        """Environment of ``n_flows x n_swimmers`` swimmers in new realisations of ``flow``;
        all randomness (flows, initial conditions, noise) from ``seed``; ``ic_blocks`` blocks
        of swimmers per flow with identical initial conditions.

        Parameters
        ----------
        flow
            The flow: :class:`~swimrl.flows.build.StochasticSpec` (the paper's),
            :class:`~swimrl.flows.build.StoredRunSpec` (stored DNS runs) or
            :class:`~swimrl.flows.build.LiveDNSSpec`.
        params
            Swimmer and episode parameters.
        runtime
            Device, dtype and integration kernel (its threads are not applied here).
        n_flows, n_swimmers
            The batch shape.
        seed
            Seeds the one generator of the flows, the initial conditions and the noise.
        ic_blocks
            Blocks of swimmers per flow that start from the same positions and orientations.
        stagger
            Groups of flows whose episodes are offset (:meth:`stagger`; 1: none).

        Returns
        -------
        SwimmerEnv
            The environment, not reset yet (TorchRL's ``reset`` or ``rollout`` does it).
        """
        device, dtype = runtime.device, runtime.dtype
        offset = clock_offsets(n_flows, params.n_decisions, stagger, device)
        gen = torch.Generator(device=device).manual_seed(int(seed))
        realisations = build_flow(
            flow, n_flows, device, dtype, gen, params.update_interval, params.duration
        )
        env = cls.build_from(realisations, n_swimmers, params, generator=gen,
                             kernel=runtime.kernel, ic_blocks=ic_blocks)
        env._clock_offset = offset
        return env

    @classmethod
    def build_from(cls, flow, n_swimmers: int, params: EnvParams, **kwargs) -> SwimmerEnv:
        """The environment of a flow already built: a :class:`SwimmerEnv` for a
        :class:`~swimrl.flows.base.GriddedFlow`, a :class:`PointSwimmerEnv` for a
        :class:`~swimrl.flows.pointwise.PointFlow` (``kwargs``: the constructor's)."""
        env_cls = PointSwimmerEnv if cls is SwimmerEnv and isinstance(flow, PointFlow) else cls
        return env_cls(flow, n_swimmers, params, **kwargs)

    def stagger(self, groups: int) -> None:
        """Offset the episodes of ``groups`` groups of flows (flow ``f`` in group ``f mod
        groups``) by ``N / groups`` decisions from each other: at the next reset, the clock
        of a flow of group ``g`` starts at ``g floor(N / groups)``, so its first episode is
        that much shorter and its later episodes end (and its flow is redrawn) a fixed
        fraction of an episode after the previous group's. A training env's episode ends
        then redraw ``1/groups`` of the flows at a time instead of all at once, and a batch
        holds flows at ``groups`` phases of their episodes. ``groups = 1``: no offset."""
        self._clock_offset = clock_offsets(self.flow.n_flows, self.params.n_decisions, groups,
                                           self._flows.device)

    # -- state helpers ------------------------------------------------------------------------
    @staticmethod
    def velocity_unit(flow) -> float:
        """The unit of ``swimmer.swim_speed``: the flow's ``u_rms``."""
        return flow.u_rms

    def _select_kernel(self, kernel: str, device: torch.device):
        """The integration function (:func:`~swimrl.physics.integrator.select_kernel`)."""
        return select_kernel(kernel, device)

    @property
    def n_swimmers(self) -> int:
        return self.batch_size[1]

    def state(self) -> tuple[torch.Tensor, ...]:
        """The tensors an arrived swimmer keeps (``task=target``): position, image counts and
        orientation."""
        return self.pos, self.image, self.theta

    def length_resolution(self) -> float:
        """The flow's smallest resolved length (the grid spacing), for float tolerances."""
        return self.flow.grid.spacing

    def start_position(self) -> torch.Tensor:
        """The unwrapped start ``x_0 = p_0 + L m_0``, ``(F, S, d)``."""
        return self.start_pos + self.flow.grid.length * self.start_image.to(self.pos.dtype)

    def displacement(self) -> torch.Tensor:
        """The unwrapped displacement from the start ``x - x_0 = (p - p_0) + L (m - m_0)``.

        Returns
        -------
        torch.Tensor
            ``(F, S, 2)``, in the flow's length unit.
        """
        length = self.flow.grid.length
        return (self.pos - self.start_pos) + length * (self.image - self.start_image).to(
            self.pos.dtype
        )

    def _wrap(self) -> None:
        """Fold positions back into ``[0, L)`` and count the images crossed."""
        length = self.flow.grid.length
        shift = torch.floor(self.pos / length)
        self.pos.sub_(shift * length)
        self.image.add_(shift.to(torch.int64))

    def frame(self, displacement: torch.Tensor | None = None) -> torch.Tensor:
        """The vector whose direction is the signals' ``e_r``: ``x - x_0``
        (``task=displacement``) or ``X - x``, towards the target (``task=target``).

        A new task overrides it (``docs/extending.md``).

        Parameters
        ----------
        displacement
            ``x - x_0`` if already at hand, ``(F, S, 2)``.

        Returns
        -------
        torch.Tensor
            ``(F, S, 2)``.
        """
        if displacement is None:
            displacement = self.displacement()
        return self.target - displacement if self.task.target else displacement

    def signals(self, displacement: torch.Tensor | None = None) -> torch.Tensor:
        """All five signals at the current state, in the task's frame (:meth:`frame`).

        Parameters
        ----------
        displacement
            ``x - x_0`` if already at hand, ``(F, S, 2)``.

        Returns
        -------
        torch.Tensor
            ``(F, S, 5)``, in the order of :data:`~swimrl.physics.signals.SIGNAL_NAMES`
            (:func:`~swimrl.physics.signals.compute_signals`).
        """
        q = self.flow.sample(self._flow_index, self.pos.view(-1, 2))
        return compute_signals(q.view(*self.batch_size, 5), self.theta,
                               self.frame(displacement), self.tau_k)

    def _observe(self) -> TensorDict:
        disp = self.displacement()
        sig = self.signals(disp)
        ended = (self.flow_step >= self.params.n_decisions).unsqueeze(1)
        truncated = ended.expand(self.batch_size).unsqueeze(-1)
        observable = sig
        if SHAPE_SIGNAL in self.params.signals:  # the shape held: last_action, 0 at the start
            shape = self.last_action.nan_to_num(nan=0.0).unsqueeze(-1)
            observable = torch.cat((sig, shape), -1)
        out = {
            "observation": observable[..., self._obs_idx],
            "signals": sig,
            "distance": disp.norm(dim=-1, keepdim=True),
            "done": truncated.clone(),
            "terminated": torch.zeros_like(truncated),
            "truncated": truncated,
        }
        if self.task.target:
            arrived = self.arrived.unsqueeze(-1)
            out.update(target_distance=(self.target - disp).norm(dim=-1, keepdim=True),
                       terminated=arrived.clone(), done=truncated | arrived)
        return TensorDict(out, batch_size=self.batch_size, device=self.device)

    def score(self, td: TensorDictBase) -> torch.Tensor:
        """The performance index of every swimmer in ``td`` (an observation): the undiscounted
        task return over ``v_s T`` (no energy cost), ``R_hat = |x - x_0| / (v_s T)`` (the
        paper's eq. 6) or ``(D - |X - x|) / (v_s T)``.

        Parameters
        ----------
        td
            An observation, e.g. ``td[..., -1]["next"]`` of a rollout: the state after the
            last decision.

        Returns
        -------
        torch.Tensor
            ``(F, S)``.
        """
        if self.task.target:
            remaining = td.get("target_distance").squeeze(-1)
            return (self.target_distance - remaining) / self.reference_distance
        return td.get("distance").squeeze(-1) / self.reference_distance

    def outcomes(self) -> dict[str, torch.Tensor]:
        """Per-swimmer results besides :meth:`score`.

        Returns
        -------
        dict[str, torch.Tensor]
            ``(F, S)`` each: ``energy`` (``E_hat``, :mod:`swimrl.physics.energy`),
            ``shape_change`` (``C_hat = (1/T) sum_i |Lambda_i - Lambda_{i-1}| T_u``, the
            quantity ``reward.shape_change_weight`` prices) and, for
            ``task=target``, ``arrived`` (0/1), ``arrival_time`` (units ``tau_K``; NaN where
            not arrived) and ``final_distance`` (``|X - x|``, units ``ell_f``).
        """
        out = {"energy": self.energy.clone(), "shape_change": self.shape_change.clone()}
        if self.task.target:
            time = self.arrival_step.to(self.energy.dtype) * self.params.update_interval
            rho = (self.target - self.displacement()).norm(dim=-1)
            out.update(arrived=self.arrived.to(self.energy.dtype),
                       arrival_time=torch.where(self.arrived, time, math.nan),
                       final_distance=rho / self.flow.ell_f)
        return out

    # -- EnvBase API ---------------------------------------------------------------------------
    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        mask = None
        if tensordict is not None and "_reset" in tensordict.keys():  # noqa: SIM118
            mask = tensordict.get("_reset").reshape(self.batch_size)
        if mask is None:
            mask = torch.ones(self.batch_size, dtype=torch.bool, device=self.device)
        flows = mask.all(dim=1)
        if flows.any():
            self.flow.reset(flows)
            self.max_flow_speed[flows] = 0
            self.flow_step[flows] = 0
            if self._clock_offset is not None:  # stagger(): once, at the first reset
                self.flow_step.add_(torch.where(flows, self._clock_offset, 0))
                self._clock_offset = None
        k = int(mask.sum())
        if k:
            blocks = self.ic_blocks
            if blocks > 1 and not bool((mask == flows.unsqueeze(1)).all()):
                raise ValueError("ic_blocks > 1 needs whole-flow resets")
            n = k // blocks  # swimmers drawn; each block of a flow gets the same draws
            new_pos, new_orient, new_target = self._draw_starts(n)
            if blocks > 1:
                per_block = self.n_swimmers // blocks

                def repeat(x: torch.Tensor) -> torch.Tensor:
                    x = x.view(-1, 1, per_block, *x.shape[1:])
                    return x.expand(-1, blocks, *x.shape[2:]).reshape(k, *x.shape[3:])

                new_pos, new_orient = repeat(new_pos), repeat(new_orient)
                if new_target is not None:
                    new_target = repeat(new_target)
            self.pos[mask] = new_pos
            self.start_pos[mask] = new_pos
            self.image[mask] = 0
            self.start_image[mask] = 0
            self.state()[2][mask] = new_orient
            self.step_count[mask] = 0
            if new_target is not None:
                self.target[mask] = new_target
            self.arrived[mask] = False
            self.arrival_step[mask] = -1
            self.energy[mask] = 0
            self.shape_change[mask] = 0
            self.last_action[mask] = math.nan
        return self._observe()

    def _draw_starts(self, n: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
        """``n`` new swimmers: positions uniform in the box ``[0, L)^2``, angles uniform in
        ``[0, 2 pi)`` and (``task=target``) targets ``X - x_0 = D (cos phi, sin phi)``,
        ``phi`` uniform, drawn in this order from the environment's generator."""
        g, dev, dt = self.generator, self.device, self.pos.dtype
        new_pos = torch.rand(n, 2, generator=g, device=dev, dtype=dt) * self.flow.grid.length
        new_theta = torch.rand(n, generator=g, device=dev, dtype=dt) * (2 * math.pi)
        target = None
        if self.task.target:
            angle = torch.rand(n, generator=g, device=dev, dtype=dt) * (2 * math.pi)
            target = self.target_distance * torch.stack((torch.cos(angle), torch.sin(angle)),
                                                        -1)
        return new_pos, new_theta, target

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        lam_max = self.params.shape_factor_max
        action = tensordict.get("action").reshape(-1).clamp(-lam_max, lam_max)
        if self.task.target:
            return self._step_target(action)
        dist_before = self.displacement().norm(dim=-1)
        self.integrate(action)
        self.step_count += 1
        self.flow_step += 1
        shape = action.view(self.batch_size)
        cost = self._cost(shape, torch.ones_like(self.arrived))
        out = self._observe()
        reward = out.get("distance").squeeze(-1) - dist_before
        out.set("reward", (reward if cost is None else reward - cost).unsqueeze(-1))
        return out

    def _step_target(self, action: torch.Tensor) -> TensorDictBase:
        """One decision of ``task=target``: arrived swimmers stay where they are (no motion,
        reward or energy); ``r_i = rho(t_{i-1}) - rho(t_i)`` for the others, who arrive when
        ``rho <= task.arrival_radius``."""
        moving = ~self.arrived
        rho_before = (self.target - self.displacement()).norm(dim=-1)
        # the arrived swimmers' state put back after the interval, with no branch on whether
        # there are any (a branch on a tensor value would wait for the device)
        frozen = [x.clone() for x in self.state()]
        self.integrate(action)
        for x, old in zip(self.state(), frozen, strict=True):
            keep = self.arrived.view(*self.batch_size, *([1] * (x.dim() - 2)))
            x.copy_(torch.where(keep, old, x))
        self.step_count += 1
        self.flow_step += 1
        rho = (self.target - self.displacement()).norm(dim=-1)
        now = moving & (rho <= self.arrival_radius)
        self.arrived |= now
        self.arrival_step.copy_(torch.where(now, self.step_count, self.arrival_step))
        cost = self._cost(action.view(self.batch_size), moving)
        reward = torch.where(moving, rho_before - rho, torch.zeros_like(rho))
        out = self._observe()
        out.set("reward", (reward if cost is None else reward - cost).unsqueeze(-1))
        return out

    def _cost(self, shape: torch.Tensor, moving: torch.Tensor) -> torch.Tensor | None:
        """Account the decision just taken by the ``moving`` swimmers with shape factor
        ``shape`` (``(F, S)``): ``E_hat += K(Lambda) T_u / T``,
        ``C_hat += |Lambda - Lambda_prev| T_u / T`` (0 at the first decision); returns the
        reward's cost ``w K(Lambda) v_s T_u + w_c |Lambda - Lambda_prev| v_s T_u`` (None when
        both weights are 0)."""
        drag = drag_factor(shape)
        zero = torch.zeros_like(drag)
        self.energy += torch.where(moving, drag, zero) / self.params.n_decisions
        w, w_c = self.params.reward.energy_weight, self.params.reward.shape_change_weight
        change = (shape - self.last_action).abs().nan_to_num(nan=0.0)
        self.shape_change += torch.where(moving, change, zero) / self.params.n_decisions
        self.last_action = torch.where(moving, shape, self.last_action)
        if w == 0 and w_c == 0:
            return None
        cost = (w * drag + w_c * change) * self.decision_length
        return torch.where(moving, cost, zero)

    def integrate(self, shape_factor: torch.Tensor) -> None:
        """Advance all swimmers and flows by one decision interval with ``Lambda`` held fixed.

        ``T_u / dt`` Heun steps of the paper's eqs. (1a) and (2) by the environment's kernel
        (:mod:`swimrl.physics.integrator`). A new swimmer model overrides it
        (``docs/extending.md``).

        Parameters
        ----------
        shape_factor
            ``Lambda`` of every swimmer, ``(F * S,)``.
        """
        k = self.params.n_substeps
        path = self.flow.coefficient_path(k, self.dt)
        bound = self.flow.speed_bound(path)[self.flow.rows(self._flows)]
        torch.maximum(self.max_flow_speed, bound, out=self.max_flow_speed)
        theta = self.theta.view(-1)
        kicks = None
        if self.rot_kick_std > 0:
            kicks = self.rot_kick_std * torch.randn(
                (k,) + theta.shape, generator=self.generator, device=self.device, dtype=theta.dtype
            )
        grid = self.flow.grid
        pos, theta = self._kernel(
            self.flow.table,
            path,
            self.flow.rows(self._flow_index),
            self.pos.view(-1, 2),
            theta,
            shape_factor,
            kicks,
            grid.n,
            grid.spacing,
            self.swim_speed,
            self.dt,
        )
        self.pos.copy_(pos.view_as(self.pos))
        self.theta.copy_(torch.remainder(theta, 2 * math.pi).view_as(self.theta))
        self._wrap()

    def check_displacement(self, slack: float = 1e-3) -> None:
        """Refuse a physically impossible state: every swimmer obeys
        ``|x(t) - x_0| <= (v_s + U_f) t``, with ``t`` its time since its start and ``U_f`` the
        bound of ``max_x |u|`` of its flow over that time (:attr:`max_flow_speed`), since
        ``dx/dt = u + v_s n`` and the Heun steps average two such velocities. ``slack``
        (relative) covers float rounding. Raises :class:`~swimrl.errors.IntegrityError` (one
        line naming the worst swimmer and the bound) otherwise, NaN included."""
        t = self.step_count.to(self.pos.dtype) * (self.params.update_interval * self.tau_k)
        bound = (self.swim_speed + self.max_flow_speed).unsqueeze(1) * t
        dist = self.displacement().norm(dim=-1)
        bad = ~(dist <= bound * (1 + slack) + 1e-6 * self.length_resolution())
        if bool(bad.any()):
            excess = torch.where(bad, dist / bound.clamp_min(1e-30), torch.zeros_like(dist))
            excess = excess.nan_to_num(nan=math.inf)
            f, s = divmod(int(excess.argmax()), self.n_swimmers)
            raise IntegrityError(
                f"impossible result: swimmer {s} of flow {f} is {float(dist[f, s]):.4g} from "
                f"its start after t = {float(t[f, s]):.4g}, beyond (v_s + max|u|) t = "
                f"{float(bound[f, s]):.4g} (v_s = {self.swim_speed:.4g}, max|u| <= "
                f"{float(self.max_flow_speed[f]):.4g}); {int(bad.sum())} swimmers affected, "
                "nothing written"
            )

    def _set_seed(self, seed: int | None) -> None:
        if seed is None:
            seed = int(torch.empty((), dtype=torch.int64).random_().item())
        self.generator.manual_seed(int(seed))


class PointSwimmerEnv(SwimmerEnv):
    r"""The swimmers of :class:`SwimmerEnv` in a flow evaluated at their positions
    (:class:`~swimrl.flows.pointwise.PointFlow`: the analytic flows and the 3D stochastic
    flow), in 2D or 3D; made by :meth:`SwimmerEnv.build` for such a flow.

    The flow is unbounded: positions are not wrapped (the image counts stay 0), swimmers start
    uniformly in the cube ``[0, flow.start_box)^d`` (at the origin for a linear flow). In 2D
    the state and the signals are those of :class:`SwimmerEnv` (the angle ``theta``, the five
    signals of :mod:`swimrl.physics.signals`, channels from ``(u, A)`` by
    :func:`~swimrl.flows.pointwise.channels_2d`); in 3D the orientation is the unit vector
    :attr:`orientation` ``n`` ``(F, S, 3)``, started uniform on the sphere, integrated by
    :func:`~swimrl.physics.swimmer3d.heun_step_3d`
    (``dn/dt = omega x n / 2 + Lambda (S n - (n.S n) n)``), the signals the seven of
    :mod:`swimrl.physics.signals3d` and a target's direction uniform on the sphere. Every
    decision integrates ``T_u / dt`` Heun steps eagerly; ``kernel=compiled`` (``auto`` on a
    GPU) evaluates the 3D stochastic flow by its compiled mode sum; ``kernel=fused`` (the 3D
    stochastic flow on the CPU) runs the whole interval in the fused C++ kernel
    (:func:`~swimrl.physics.integrator.integrate_interval_3d_fused`), the flow's coefficients
    at the step times drawn first, in the eager path's order.
    """

    def __init__(self, flow: PointFlow, n_swimmers: int, params: EnvParams,
                 generator: torch.Generator | None = None,
                 kernel: str = yaml_value("evaluate", "kernel"), ic_blocks: int = 1):
        super().__init__(flow, n_swimmers, params, generator=generator, kernel=kernel,
                         ic_blocks=ic_blocks)
        #: Unit orientations ``n`` in 3D, ``(F, S, 3)`` (2D: :attr:`theta`).
        self.orientation = torch.zeros(self.batch_size + (3,), device=self.device,
                                       dtype=self.pos.dtype)

    @staticmethod
    def velocity_unit(flow) -> float:
        """``u_rms`` of the flow, or ``ell_f / tau_K`` for a flow without one (linear)."""
        return flow.u_rms if flow.u_rms is not None else flow.ell_f / flow.tau_k

    def _select_kernel(self, kernel: str, device: torch.device):
        """``compiled`` (and ``auto`` on a device other than the CPU): the flow's compiled
        sampler where it has one (:meth:`~swimrl.flows.pointwise.PointFlow.compile_sampler`);
        the Heun steps stay eager (returns None). ``fused``: the 3D stochastic flow on the CPU
        only, the interval in :func:`~swimrl.physics.integrator.integrate_interval_3d_fused`
        (returned). ``auto`` on the CPU stays eager (the committed 3D records' path)."""
        one_of("kernel", kernel, (*POINT_KERNELS, "fused"))
        if kernel == "fused":
            require(isinstance(self.flow, StochasticFlow3D), "kernel", kernel,
                    "one of ['auto', 'eager', 'compiled'] for this flow (fused: "
                    "flow=stochastic3d on the CPU)")
            require(device.type == "cpu", "kernel", kernel,
                    f"one of ['auto', 'eager', 'compiled'] on device={device} (fused: the CPU)")
            require(self.flow.dtype in (torch.float32, torch.float64), "kernel", kernel,
                    f"one of ['auto', 'eager', 'compiled'] with dtype {self.flow.dtype} "
                    "(fused: float32 or float64)")
            return integrate_interval_3d_fused
        if kernel == "compiled" or (kernel == "auto" and device.type != "cpu"):
            self.flow.compile_sampler()
        return None

    def state(self) -> tuple[torch.Tensor, ...]:
        return (self.pos, self.image, self.orientation if self.dim == 3 else self.theta)

    def displacement(self) -> torch.Tensor:
        """``x - x_0`` ``(F, S, d)``: positions are not wrapped."""
        return self.pos - self.start_pos

    def start_position(self) -> torch.Tensor:
        return self.start_pos

    def length_resolution(self) -> float:
        return self.flow.ell_f

    def _wrap(self) -> None:
        """Nothing: the flow is unbounded."""

    def _draw_starts(self, n: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
        """Positions uniform in ``[0, start_box)^d``; angles uniform (2D) or orientations
        uniform on the sphere (3D, normalised Gaussian vectors); targets at distance ``D`` in a
        uniform direction; drawn in this order."""
        g, dev, dt, d = self.generator, self.device, self.pos.dtype, self.dim
        box = float(self.flow.start_box)
        pos = torch.rand(n, d, generator=g, device=dev, dtype=dt) * box

        def direction() -> torch.Tensor:
            v = torch.randn(n, 3, generator=g, device=dev, dtype=dt)
            return v / v.norm(dim=-1, keepdim=True)

        if d == 3:
            orient = direction()
        else:
            orient = torch.rand(n, generator=g, device=dev, dtype=dt) * (2 * math.pi)
        target = None
        if self.task.target:
            if d == 3:
                target = self.target_distance * direction()
            else:
                angle = torch.rand(n, generator=g, device=dev, dtype=dt) * (2 * math.pi)
                target = self.target_distance * torch.stack((angle.cos(), angle.sin()), -1)
        return pos, orient, target

    def _channels(self, pos: torch.Tensor) -> torch.Tensor:
        """The flow channels at ``pos`` ``(F, S, d)``: the five 2D ones or the eleven of
        :data:`~swimrl.physics.swimmer3d.CHANNELS_3D`, ``(F, S, c)``."""
        u, grad = self.flow.sample(pos)
        return channels_from_gradient(u, grad) if self.dim == 3 else channels_2d(u, grad)

    def _channels_flat(self, pos: torch.Tensor) -> torch.Tensor:
        """The 2D channels at ``pos`` ``(F S, 2)``, ``(F S, 5)``."""
        return self._channels(pos.view(*self.batch_size, 2)).view(-1, 5)

    def signals(self, displacement: torch.Tensor | None = None) -> torch.Tensor:
        """All signals of the dimension (:attr:`signal_names`) in the task's frame."""
        q = self._channels(self.pos)
        frame = self.frame(displacement)
        if self.dim == 3:
            return compute_signals_3d(q, self.orientation, frame, self.tau_k)
        return compute_signals(q, self.theta, frame, self.tau_k)

    def _track_speed(self) -> None:
        bound = self.flow.speed_bound()
        if bound is not None:
            torch.maximum(self.max_flow_speed, bound.to(self.max_flow_speed.dtype),
                          out=self.max_flow_speed)

    def integrate(self, shape_factor: torch.Tensor) -> None:
        """``T_u / dt`` Heun steps (:func:`~swimrl.physics.swimmer.heun_step` in 2D,
        :func:`~swimrl.physics.swimmer3d.heun_step_3d` in 3D), the flow advanced between the
        stages, ``Lambda`` ``(F * S,)`` held; with rotational diffusion, an angle kick
        ``sqrt(2 D_r dt) xi`` (2D) or the exact spherical step (3D) each step."""
        f, s, d = *self.batch_size, self.dim
        lam = shape_factor.view(f, s)
        d_r = self.params.rot_diffusion / self.tau_k
        pos = self.pos
        orient = self.orientation if d == 3 else self.theta
        self._track_speed()
        if self._kernel is not None:
            self._integrate_fused(lam, d_r)
            return
        for _ in range(self.params.n_substeps):
            noise = None
            if d_r > 0:
                shape = (f, s, 3) if d == 3 else (f, s)
                noise = torch.randn(shape, generator=self.generator, device=self.device,
                                    dtype=pos.dtype)
            if d == 3:
                pos, orient = heun_step_3d(self._channels, self._advance, pos, orient, lam,
                                           self.swim_speed, self.dt, noise, d_r)
            else:
                kick = None if noise is None else self.rot_kick_std * noise.view(-1)
                flat, angle = heun_step(self._channels_flat, self._advance, pos.view(-1, 2),
                                        orient.view(-1), lam.view(-1), self.swim_speed,
                                        self.dt, kick)
                pos, orient = flat.view(f, s, 2), angle.view(f, s)
            self._track_speed()
        self.pos.copy_(pos)
        if d == 3:
            self.orientation.copy_(orient)
        else:
            self.theta.copy_(torch.remainder(orient, 2 * math.pi))

    def _integrate_fused(self, lam: torch.Tensor, d_r: float) -> None:
        """:meth:`integrate` by the fused 3D kernel: the flow is advanced through the interval
        first (its coefficients at the ``K + 1`` step times kept, the speed bound tracked),
        the rotational noise of each step drawn just before that step's flow advance, as the
        eager loop draws them (one generator: the same numbers in the same order)."""
        flow = self.flow
        path = [flow.coeffs.clone()]
        noise = []
        for _ in range(self.params.n_substeps):
            if d_r > 0:
                noise.append(torch.randn(self.batch_size + (3,), generator=self.generator,
                                         device=self.device, dtype=self.pos.dtype))
            self._advance()
            path.append(flow.coeffs.clone())
            self._track_speed()
        # a fixed basis is one row for every flow
        rows = self._flow_index if flow.wavevectors.shape[0] > 1 else self._flow_index * 0
        pos, orient = self._kernel(
            flow.wavevectors, flow.table, torch.stack(path), rows, self._flow_index,
            self.pos.view(-1, 3), self.orientation.view(-1, 3), lam.reshape(-1),
            torch.stack(noise) if noise else None, flow.n_waves, self.swim_speed, self.dt, d_r)
        self.pos.copy_(pos.view_as(self.pos))
        self.orientation.copy_(orient.view_as(self.orientation))

    def _advance(self) -> None:
        self.flow.advance(self.dt)

    def check_displacement(self, slack: float = 1e-3) -> None:
        """:meth:`SwimmerEnv.check_displacement` where the flow bounds its speed; for a flow
        without a bound (linear), only that every displacement is finite."""
        if self.flow.speed_bound() is not None:
            super().check_displacement(slack)
            return
        dist = self.displacement().norm(dim=-1)
        if not bool(torch.isfinite(dist).all()):
            raise IntegrityError(
                f"impossible result: {int((~torch.isfinite(dist)).sum())} swimmers have a "
                "non-finite displacement, nothing written")
