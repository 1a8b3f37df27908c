"""The core environment: :class:`SwimmerEnv`, its specs, reset, step, task and costs, for
swimmers in a gridded flow (:class:`~swimrl.flows.base.GriddedFlow`); the flows evaluated at
points subclass it (:mod:`swimrl.env.point`). The keys and conventions: :mod:`swimrl.env`."""

from __future__ import annotations

import math

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

import swimrl.physics.body as bodies
from swimrl.conf_values import yaml_value
from swimrl.env import accounting, features, vertical
from swimrl.env.actuation import action_spec, controls
from swimrl.env.integrity import check_displacement
from swimrl.env.params import EnvParams, clock_offsets
from swimrl.env.target import step_target
from swimrl.errors import ConfigError
from swimrl.flows.base import GriddedFlow
from swimrl.physics.body import SHAPE_SIGNAL, Body, signal_indices
from swimrl.physics.integrator import select_kernel


class SwimmerEnv(EnvBase):
    """Shape-changing spheroidal swimmers maximising their distance from the start point
    (``task=displacement``) or reaching a target (``task=target``).

    A TorchRL ``EnvBase`` of batch ``(n_flows, n_swimmers)``; one step is one decision
    interval (module docstring for the keys). Usually made by :func:`~swimrl.env.build.build_env`
    from a flow spec; the constructor takes a flow already built (any
    :class:`~swimrl.flows.base.GriddedFlow`, ``docs/extending.md``). The swimmer is a
    :class:`~swimrl.physics.body.Body`: the flow's (``flow.dim``; 2 for a gridded flow) unless
    one is given.

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
    body
        The swimmer (default: :func:`~swimrl.physics.body.body` of the flow's dimension).

    Examples
    --------
    A shipped policy over one episode, with TorchRL's ``rollout``:

    >>> from swimrl import EnvParams, Runtime, StochasticSpec, build_env, load_policy
    >>> params = EnvParams()
    >>> env = build_env(StochasticSpec(kubo=10.0), params,
    ...                 Runtime.from_names("cpu", "float32", 1), 2, 100, seed=0)
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
        body: Body | None = None,
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
        #: The swimmer: orientation, channels, signals, Heun step, draws.
        self.body = body if body is not None else params.body(getattr(flow, "dim", 2),
                                                              flow.tau_k)
        #: The space dimension (2 for every gridded flow).
        self.dim = self.body.dim
        #: The signals of the ``signals`` key (all of the body's), in order.
        self.signal_names = self.body.signal_names
        try:
            self._obs_idx = signal_indices(params.signals, bodies.observable_names(self.body))
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
        #: The orientations: angles ``(F, S)`` in 2D, unit vectors ``(F, S, 3)`` in 3D.
        self.orientation = torch.zeros(batch + self.body.orientation_shape, device=dev,
                                       dtype=dtype)
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
        #: ``S_hat`` so far: ``(1/T) int n . e_r dt``, the swimmer's own share of ``R_hat``.
        self.alignment = torch.zeros(batch, device=dev, dtype=dtype)
        #: The previous decision's ``Lambda`` (NaN before the first; the shape-change cost).
        self.last_action = torch.full(batch, math.nan, device=dev, dtype=dtype)
        #: ``task=vertical``'s measuring window (:class:`~swimrl.env.vertical.Window`).
        self.window = vertical.Window(batch, dev, dtype, vertical.burn_in_steps(
            params.task.burn_in, params.update_interval))
        #: Upper bound of ``max_x |u(x, t)|`` of each flow since its last reset, ``(F,)``.
        self.max_flow_speed = torch.zeros(flow.n_flows, device=dev, dtype=dtype)
        self._flows = torch.arange(flow.n_flows, device=dev)
        #: Clock offsets ``(F,)`` added at the next reset of the flows (:meth:`stagger`).
        self._clock_offset: torch.Tensor | None = None
        #: What the action sets (:mod:`swimrl.actuation`).
        self.actuation = params.actuation
        self.action_spec = action_spec(params.actuation, params.shape_factor_max, d, batch, dev,
                                       dtype)
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
        if self.task.vertical:
            self.observation_spec["rise"] = Unbounded(shape=batch + (1,), device=dev,
                                                      dtype=dtype)
        self.reward_spec = Unbounded(shape=batch + (1,), device=dev, dtype=dtype)
        #: Observations carry ``critic_observation`` (``features.observe_flow_for_critic``).
        self.critic_flow = False
        self.done_spec = Composite(
            done=Categorical(2, shape=batch + (1,), dtype=torch.bool, device=dev),
            terminated=Categorical(2, shape=batch + (1,), dtype=torch.bool, device=dev),
            truncated=Categorical(2, shape=batch + (1,), dtype=torch.bool, device=dev),
            shape=batch,
            device=dev,
        )

    def flow_velocity(self) -> torch.Tensor:
        """The flow's velocity at the swimmers, ``(F, S, d)`` (the body's first channels)."""
        q = self.flow.sample(self._flow_index, self.pos.view(-1, self.dim))
        return q[:, : self.dim].reshape(*self.batch_size, self.dim)

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
    @property
    def theta(self) -> torch.Tensor:
        """The 2D orientation angles ``(F, S)``: :attr:`orientation` of a planar body."""
        if self.body.orientation_name != "theta":
            raise AttributeError(f"a {self.dim}D swimmer has no angle theta: its orientation is "
                                 "the unit vector env.orientation")
        return self.orientation

    @staticmethod
    def velocity_unit(flow) -> float:
        """The unit of ``swimmer.swim_speed``: the flow's ``u_rms``."""
        return flow.u_rms

    def _select_kernel(self, kernel: str, device: torch.device):
        """The integration function (:func:`~swimrl.physics.integrator.select_kernel`; only the
        eager one where the body has a torque)."""
        return select_kernel(kernel, device, torque=self.body.extra_rate is not None)

    @property
    def n_swimmers(self) -> int:
        return self.batch_size[1]

    def state(self) -> tuple[torch.Tensor, ...]:
        """The tensors an arrived swimmer keeps (``task=target``): position, image counts and
        orientation."""
        return self.pos, self.image, self.orientation

    def start_box(self) -> float:
        """The side ``L`` of the cube ``[0, L)^d`` the swimmers start in: the grid's period."""
        return self.flow.grid.length

    def length_resolution(self) -> float:
        """The flow's smallest resolved length (the grid spacing), for float tolerances."""
        return self.flow.grid.spacing

    def start_position(self) -> torch.Tensor:
        """The unwrapped start ``x_0 = p_0 + L m_0``, ``(F, S, d)``."""
        return self.start_pos + self.flow.grid.length * self.start_image.to(self.pos.dtype)

    def displacement(self) -> torch.Tensor:
        """The unwrapped displacement from the start ``x - x_0 = (p - p_0) + L (m - m_0)``,
        ``(F, S, 2)`` in the flow's length unit."""
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
        """The vector whose direction is the signals' ``e_r``, ``(F, S, d)``: ``x - x_0``
        (``task=displacement``), ``X - x``, towards the target (``task=target``) or the upward
        vertical (``task=vertical``); a new task overrides it (``docs/extending.md``).
        ``displacement``: ``x - x_0`` if at hand."""
        if displacement is None:
            displacement = self.displacement()
        if self.task.vertical:
            up = torch.zeros_like(displacement)
            up[..., self.body.vertical_axis] = 1.0
            return up
        return self.target - displacement if self.task.target else displacement

    def signals(self, displacement: torch.Tensor | None = None) -> torch.Tensor:
        """All the body's signals at the current state, in the task's frame (:meth:`frame`),
        ``(F, S, k)`` in the order of :attr:`signal_names`
        (:meth:`~swimrl.physics.body.Body.signals`); ``displacement``: ``x - x_0`` if at
        hand."""
        q = self.flow.sample(self._flow_index, self.pos.view(-1, self.dim))
        return self.body.signals(q.view(*self.batch_size, self.body.n_channels),
                                 self.orientation, self.frame(displacement), self.tau_k)

    def _observe(self, disp: torch.Tensor | None = None) -> TensorDict:
        if disp is None:  # x - x_0, unless the step computed it already
            disp = self.displacement()
        sig = self.signals(disp)
        ended = (self.flow_step >= self.params.n_decisions).unsqueeze(1)
        truncated = ended.expand(self.batch_size).unsqueeze(-1)
        shape = None
        if SHAPE_SIGNAL in self.params.signals:  # the shape held: last_action, 0 at the start
            shape = self.last_action.nan_to_num(nan=0.0)
        out = {
            "observation": bodies.observable(self.body, sig, self.params.signals, shape),
            "signals": sig,
            "distance": disp.norm(dim=-1, keepdim=True),
            "done": truncated.clone(),
            "terminated": torch.zeros_like(truncated),
            "truncated": truncated,
        }
        if self.task.vertical:
            out["rise"] = vertical.rise(disp, self.body.vertical_axis).unsqueeze(-1)
        if self.critic_flow:
            flow = features.flow_features(self.flow_velocity(), self.body.heading(
                self.orientation), self.frame(disp), self.swim_speed)
            out["critic_observation"] = torch.cat((out["observation"], flow), -1)
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
        if self.task.vertical:
            return self.window.vertical_velocity(td.get("rise").squeeze(-1), self.swim_speed,
                                                 self.window_time())
        return td.get("distance").squeeze(-1) / self.reference_distance

    def window_time(self) -> float:
        """``T - T_b`` in flow units (``task=vertical``)."""
        p = self.params
        return (p.n_decisions - self.window.start_step) * p.update_interval * self.tau_k

    def outcomes(self) -> dict[str, torch.Tensor]:
        """Per-swimmer results besides :meth:`score`, ``(F, S)`` each
        (:func:`~swimrl.env.accounting.outcomes`: energy, shape change and the task's)."""
        return accounting.outcomes(self)

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
            self.alignment[mask] = 0
            self.shape_change[mask] = 0
            self.window.reset(mask)
            self.last_action[mask] = math.nan
        return self._observe()

    def _draw_starts(self, n: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | None]:
        """``n`` new swimmers: positions uniform in ``[0, L)^d`` (:meth:`start_box`), orientations
        uniform (:meth:`~swimrl.physics.body.Body.draw_orientations`) and (``task=target``)
        targets ``X - x_0 = D e``, ``e`` a uniform direction, drawn in this order from the
        environment's generator."""
        g, dev, dt = self.generator, self.device, self.pos.dtype
        new_pos = torch.rand(n, self.dim, generator=g, device=dev, dtype=dt) * self.start_box()
        new_orient = self.body.draw_orientations(n, g, dev, dt)
        target = None
        if self.task.target:
            target = self.target_distance * self.body.draw_directions(n, g, dev, dt)
        return new_pos, new_orient, target

    def cell_size(self) -> float:
        """One cell of the flow (``task=vertical``'s trapping scale): the flow's
        ``cell_size`` where it has one, else its length ``ell_f``."""
        return float(getattr(self.flow, "cell_size", self.flow.ell_f))

    def _progress(self, displacement: torch.Tensor) -> torch.Tensor:
        """What the reward counts the increase of, ``(F, S)``: ``|x - x_0|``, or the rise
        ``z - z_0`` (``task=vertical``)."""
        if self.task.vertical:
            return vertical.rise(displacement, self.body.vertical_axis)
        return displacement.norm(dim=-1)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action, direction = controls(self.actuation, tensordict.get("action"),
                                     self.params.shape_factor_max, self.batch_size, self.dim,
                                     self.pos.dtype)
        if direction is not None:
            self.body.steer(direction)
        if self.task.target:
            return step_target(self, action)
        disp = self.displacement()
        aligned = self.swim_alignment(disp)
        before = self._progress(disp)
        self.integrate(action)
        self.step_count += 1
        self.flow_step += 1
        shape = action.view(self.batch_size)
        cost = self._cost(shape, torch.ones_like(self.arrived))
        disp = self.displacement()
        after = self._progress(disp)
        if self.task.vertical:
            self.window.update(after, self.step_count)
        out = self._observe(disp)
        aligned = 0.5 * (aligned + self.swim_alignment(disp))  # n_r over the decision
        self.alignment += aligned / self.params.n_decisions
        if self.params.reward.progress == "swimming":  # v_s T_u (n_r(t_{i-1}) + n_r(t_i)) / 2
            reward = self.decision_length * aligned
        else:
            reward = after - before
        out.set("reward", (reward if cost is None else reward - cost).unsqueeze(-1))
        return out

    def swim_alignment(self, displacement: torch.Tensor) -> torch.Tensor:
        """``n_r`` in the task's frame, ``(F, S)`` (:mod:`~swimrl.env.features`)."""
        return features.radial_alignment(self.body.heading(self.orientation),
                                         self.frame(displacement))

    def _cost(self, shape: torch.Tensor, moving: torch.Tensor) -> torch.Tensor | None:
        """Account the decision just taken (:func:`~swimrl.env.accounting.account`)."""
        return accounting.account(self, shape, moving)

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
        theta = self.orientation.view(-1)
        kicks = None
        if self.rot_kick_std > 0:
            kicks = self.rot_kick_std * torch.randn(
                (k,) + theta.shape, generator=self.generator, device=self.device, dtype=theta.dtype
            )
        grid = self.flow.grid
        torque = {} if self.body.extra_rate is None else {"extra_rate": self.body.extra_rate}
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
            **torque,
        )
        self.pos.copy_(pos.view_as(self.pos))
        self.orientation.copy_(self.body.normalise(theta).view_as(self.orientation))
        self._wrap()

    def check_displacement(self, slack: float = 1e-3) -> None:
        """Refuse a physically impossible state
        (:func:`~swimrl.env.integrity.check_displacement`): ``|x(t) - x_0| <= (v_s + U_f) t``
        for every swimmer, else one :class:`~swimrl.errors.IntegrityError` line."""
        check_displacement(self, slack)

    def _set_seed(self, seed: int | None) -> None:
        if seed is None:
            seed = int(torch.empty((), dtype=torch.int64).random_().item())
        self.generator.manual_seed(int(seed))
