r"""Training settings (``train.*``, ``loss.*``, ``optim.*``, ``model.*``) and the plan derived
from them: sizes, schedule and seeds, all checked before any compute.

Counting (all in *env-batch elements*, i.e. swimmer decisions):

* one environment step advances ``n_flows x n_swimmers`` swimmers by ``T_u``;
* a batch (one PPO update) is a rollout of ``L = rollout_length`` decisions of every swimmer
  (the input), i.e. ``frames_per_batch = n_flows n_swimmers L`` frames (derived, printed at
  the start of a run); episodes run on across batches and are truncated at ``N = T/T_u``
  decisions, then restart with a new flow realisation;
* ``n_updates = total_frames // frames_per_batch`` updates; each update makes ``epochs``
  passes, each over ``minibatches_per_epoch`` minibatches of ``minibatch_size`` frames
  drawn without replacement from the batch (default: a full pass, ``frames_per_batch //
  minibatch_size``);
* the Adam rates are ``optim.lr_actor``, ``optim.lr_critic`` (``optim.lr_scale=none``) or
  those rates stated for minibatches of ``optim.lr_reference_minibatch`` frames and scaled
  by ``sqrt(minibatch_size / lr_reference_minibatch)`` (``optim.lr_scale=sqrt``);
* an *episode* (paper) is one flow realisation with its ``n_swimmers`` swimmers for ``T``:
  ``episodes = frames / (n_swimmers N)``.

Seeds: training flows and initial conditions come from
``SeedSequence([seed, TRAIN_STREAM])``; evaluations (periodic and final) use
:func:`swimrl.evaluation.rollout.evaluate` with ``seed + EVAL_SEED_OFFSET``, whose flow chunks are
``SeedSequence([seed + EVAL_SEED_OFFSET, chunk])``: streams disjoint from training, so the
reported ``R_hat`` is measured on held-out flow realisations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from swimrl.env import EnvParams
from swimrl.errors import as_bool, as_float, as_int, keep_number_types, one_of, require
from swimrl.evaluation.rollout import SWIMMER_BYTES
from swimrl.flows.build import FLOW_WORK_BYTES, FlowSpec, flow_table_bytes
from swimrl.policies.networks import ModelSpec
from swimrl.runs.policy_files import initial_actor_weights
from swimrl.runs.spec import RunSpec
from swimrl.runtime import RUNTIME, Runtime, check_memory

#: Offset added to ``seed`` for the held-out evaluation flows.
EVAL_SEED_OFFSET = 1_000_000
#: Second word of the training seed sequence (far from any evaluation chunk index).
TRAIN_STREAM = 2**31 - 1
LOSS_CRITIC_TYPES = ("l1", "l2", "smooth_l1")
LR_SCALES = ("none", "sqrt")


def training_seed(seed: int) -> int:
    """Seed of the training environment's generator for run seed ``seed``."""
    return int(np.random.SeedSequence([int(seed), TRAIN_STREAM]).generate_state(1)[0])


@dataclass(frozen=True)
class TrainSettings:
    """``train.*``: batch and budget sizes, evaluation and checkpoint cadence (the values and
    their meaning: ``conf/train.yaml``)."""

    n_flows: int
    n_swimmers: int
    rollout_length: int  # L: decisions of every swimmer per update
    total_frames: int
    minibatch_size: int
    minibatches_per_epoch: int | None  # None: one pass over the batch
    epochs: int
    reward_scale: float | None  # None: automatic (1 - gamma) / (v_s T_u), set with the env
    eval_every: int = field(metadata=RUNTIME)
    eval_flows: int = field(metadata=RUNTIME)
    eval_swimmers: int = field(metadata=RUNTIME)
    checkpoint_every: int = field(metadata=RUNTIME)
    checkpoint_seconds: float = field(metadata=RUNTIME)
    stop_after_updates: int | None = field(metadata=RUNTIME)
    progress: bool = field(metadata=RUNTIME)
    compile: bool = field(metadata=RUNTIME)  # torch.compile of loss + backward (rl.trainer)
    # CUDA graphs of the gradient step, GAE and policy (CUDA only)
    cudagraphs: bool = field(metadata=RUNTIME)
    # critic evaluations of the GAE in chunks of this many samples
    gae_chunk: int | None = field(metadata=RUNTIME)
    compare_baselines: bool = field(metadata=RUNTIME)
    stagger: int  # groups of flows with offset episodes (SwimmerEnv.stagger)
    # warm start: the policy whose actor weights start the run (None: random initialisation)
    init_policy: str | None
    actor_frozen_updates: int  # the first updates step the critic only
    # the critic also reads the flow's velocity at the swimmer (SwimmerEnv.observe_flow_for_critic)
    critic_flow: bool

    @property
    def frames_per_batch(self) -> int:
        """Frames (decisions) per PPO update: ``n_flows x n_swimmers x rollout_length``."""
        return self.n_flows * self.n_swimmers * self.rollout_length

    @property
    def n_updates(self) -> int:
        """PPO updates of the run: ``total_frames // frames_per_batch``."""
        return self.total_frames // self.frames_per_batch

    def __post_init__(self) -> None:
        def k(key: str) -> str:
            return f"train.{key}"

        n_flows, n_swimmers = as_int(k("n_flows"), self.n_flows), as_int(k("n_swimmers"),
                                                                           self.n_swimmers)
        length = as_int(k("rollout_length"), self.rollout_length)
        fpb = n_flows * n_swimmers * length
        batch = (f"the frames per update, train.n_flows*train.n_swimmers*train.rollout_length"
                 f" = {n_flows}*{n_swimmers}*{length} = {fpb}")
        total = as_int(k("total_frames"), self.total_frames)
        require(total >= fpb, k("total_frames"), self.total_frames, f">= {batch}")
        mb = as_int(k("minibatch_size"), self.minibatch_size)
        require(mb <= fpb, k("minibatch_size"), self.minibatch_size, f"<= {batch}")
        if self.minibatches_per_epoch is not None:
            n_mb = as_int(k("minibatches_per_epoch"), self.minibatches_per_epoch)
            require(n_mb <= fpb // mb, k("minibatches_per_epoch"), self.minibatches_per_epoch,
                    f"null or <= frames_per_batch // minibatch_size = {fpb // mb}")
        as_int(k("epochs"), self.epochs)
        as_int(k("eval_every"), self.eval_every, low=0)
        as_int(k("eval_flows"), self.eval_flows)
        as_int(k("eval_swimmers"), self.eval_swimmers)
        as_int(k("checkpoint_every"), self.checkpoint_every)
        as_float(k("checkpoint_seconds"), self.checkpoint_seconds, lambda v: v > 0, "> 0 (seconds)")
        if self.stop_after_updates is not None:
            as_int(k("stop_after_updates"), self.stop_after_updates)
        if self.reward_scale is not None:
            as_float(k("reward_scale"), self.reward_scale, lambda v: v > 0,
                     "'auto' or a number > 0")
        as_bool(k("progress"), self.progress)
        as_bool(k("compile"), self.compile)
        as_bool(k("cudagraphs"), self.cudagraphs)
        if self.gae_chunk is not None:
            as_int(k("gae_chunk"), self.gae_chunk)
        as_bool(k("compare_baselines"), self.compare_baselines)
        as_bool(k("critic_flow"), self.critic_flow)
        require(as_int(k("stagger"), self.stagger) <= n_flows, k("stagger"), self.stagger,
                f"an integer in [1, train.n_flows={n_flows}]")
        if self.init_policy is not None:
            object.__setattr__(self, "init_policy", str(self.init_policy))
            require(bool(self.init_policy.strip()), k("init_policy"), self.init_policy,
                    "null or a policy: pretrained/NAME, a run directory or a policy file")
        require(as_int(k("actor_frozen_updates"), self.actor_frozen_updates, low=0)
                < self.n_updates, k("actor_frozen_updates"), self.actor_frozen_updates,
                f"an integer in [0, {self.n_updates}) (the run's updates, "
                f"train.total_frames // frames per update)")
        keep_number_types(self)


@dataclass(frozen=True)
class LossSettings:
    """``loss.*``: ``ClipPPOLoss`` and ``GAE`` settings."""

    gamma: float
    gae_lambda: float
    clip_epsilon: float
    entropy_coeff: float
    critic_coeff: float
    loss_critic_type: str
    normalize_advantage: bool

    def __post_init__(self) -> None:
        as_float("loss.gamma", self.gamma, lambda v: 0 < v <= 1, "in (0, 1]")
        as_float("loss.gae_lambda", self.gae_lambda, lambda v: 0 <= v <= 1, "in [0, 1]")
        as_float("loss.clip_epsilon", self.clip_epsilon, lambda v: 0 < v < 1, "in (0, 1)")
        as_float("loss.entropy_coeff", self.entropy_coeff, lambda v: v >= 0, ">= 0")
        as_float("loss.critic_coeff", self.critic_coeff, lambda v: v > 0, "> 0")
        one_of("loss.loss_critic_type", self.loss_critic_type, LOSS_CRITIC_TYPES)
        as_bool("loss.normalize_advantage", self.normalize_advantage)
        keep_number_types(self)


@dataclass(frozen=True)
class OptimSettings:
    """``optim.*``: Adam learning rates and epsilon, annealing, gradient clipping."""

    lr_actor: float
    lr_critic: float
    lr_scale: str  # none | sqrt: the rates scaled to the minibatch (rates_for)
    lr_reference_minibatch: int  # the minibatch size lr_actor, lr_critic are stated for
    anneal: str
    eps: float
    max_grad_norm: float | None

    def rates_for(self, minibatch_size: int) -> tuple[float, float]:
        """Adam's initial rates ``(actor, critic)`` for minibatches of ``B`` frames:
        ``lr`` (``lr_scale=none``) or ``lr sqrt(B / B_ref)`` (``sqrt``, ``B_ref =
        lr_reference_minibatch``: the rates stated for ``B_ref``, the gradient noise kept
        constant as ``B`` grows)."""
        factor = 1.0 if self.lr_scale == "none" else math.sqrt(
            minibatch_size / self.lr_reference_minibatch)
        return self.lr_actor * factor, self.lr_critic * factor

    def __post_init__(self) -> None:
        as_float("optim.lr_actor", self.lr_actor, lambda v: v > 0, "> 0")
        as_float("optim.lr_critic", self.lr_critic, lambda v: v > 0, "> 0")
        one_of("optim.lr_scale", self.lr_scale, LR_SCALES)
        as_int("optim.lr_reference_minibatch", self.lr_reference_minibatch)
        one_of("optim.anneal", self.anneal, ("linear", "none"))
        as_float("optim.eps", self.eps, lambda v: v > 0, "> 0")
        if self.max_grad_norm is not None:
            as_float("optim.max_grad_norm", self.max_grad_norm, lambda v: v > 0, "null or > 0")
        keep_number_types(self)


@dataclass(frozen=True)
class TrainConfig:
    """``swimrl-train``: the evaluation setup (physics, flow, final evaluation) and the PPO
    settings; the attribute names follow the config groups (``cfg.loss.gamma``, ...).
    Built from a composed Hydra config by :func:`swimrl.config.train_config`, which checks
    every value first.

    Parameters
    ----------
    spec
        The flow, swimmer and episode parameters, runtime, final-evaluation sizes and seed
        (:class:`~swimrl.runs.spec.RunSpec`).
    train, loss, optim, model
        ``train.*`` (sizes, budget, cadence), ``loss.*`` (``ClipPPOLoss`` and ``GAE``),
        ``optim.*`` (Adam, annealing, clipping), ``model.*`` (networks).
    resume, overwrite
        Continue from ``<run>/checkpoints/last.pt``; or replace a previous run.
    eval_flow
        A flow for every evaluation that differs from the training flow (held-out DNS
        runs); None: the training flow with held-out seeds.
    """

    spec: RunSpec
    train: TrainSettings
    loss: LossSettings
    optim: OptimSettings
    model: ModelSpec
    resume: bool = field(metadata=RUNTIME)
    overwrite: bool = field(metadata=RUNTIME)
    eval_flow: FlowSpec | None  # None: the training flow

    @property
    def held_out(self) -> RunSpec:
        """The evaluations' setup: :attr:`evaluation` with the flow of ``eval_flow`` (held-out
        runs, ``eval_flow.*``) where one is given."""
        if self.eval_flow is None:
            return self.spec
        return replace(self.spec, flow=self.eval_flow)

    def __post_init__(self) -> None:
        as_bool("resume", self.resume)
        as_bool("overwrite", self.overwrite)
        device = self.spec.runtime.device
        require(not self.train.cudagraphs or device.type == "cuda",
                "train.cudagraphs", self.train.cudagraphs,
                f"false on device={device} (CUDA graphs need device=cuda)")
        if self.train.init_policy is not None:  # the warm start's file, signals and network
            initial_actor_weights(self.train.init_policy, self.spec.params, self.model)
        lam_max = self.spec.params.shape_factor_max
        require(not self.train.compare_baselines or lam_max >= 0.98,
                "train.compare_baselines", self.train.compare_baselines,
                f"false with swimmer.shape_factor_max={lam_max} (its naive baseline is "
                "Lambda = 0.98)")

    @property
    def seed(self) -> int:
        """The run's seed (network init, action sampling, training and evaluation flows)."""
        return self.spec.seed

    @property
    def params(self) -> EnvParams:
        return self.spec.params

    @property
    def runtime(self) -> Runtime:
        return self.spec.runtime

    @property
    def record(self) -> dict:
        """The resolved config, stored in checkpoints, policies and ``metrics.json``."""
        return self.spec.record


@dataclass(frozen=True)
class TrainPlan:
    """What the training loop derives from :class:`TrainSettings` (read the settings
    themselves, ``cfg.train.n_flows``, ..., from there): rollout length, updates, the
    minibatches of an epoch, the episode size and the seeds."""

    rollout_steps: int
    """``L = train.rollout_length``: decisions of every swimmer per batch."""
    n_updates: int
    """``total_frames // frames_per_batch``."""
    total_frames: int
    """Frames the run trains on: ``n_updates x frames_per_batch`` (``train.total_frames``
    rounded down to whole batches)."""
    minibatches_per_epoch: int
    """``train.minibatches_per_epoch``, or one pass (``frames_per_batch // minibatch_size``)."""
    gradient_steps_per_update: int
    """``epochs x minibatches_per_epoch``."""
    frames_per_episode: int
    """Frames of one paper episode: ``n_swimmers x N``."""
    lr_actor: float
    """Adam's initial actor rate (:meth:`OptimSettings.rates_for` the minibatch size)."""
    lr_critic: float
    """Adam's initial critic rate."""
    eval_seed: int
    train_seed: int


def make_plan(cfg: TrainConfig) -> TrainPlan:
    """Derived sizes: ``n_updates = total // frames_per_batch`` (``F S L``; both properties
    of the settings), minibatches per epoch (default: a full pass), the learning rates, and the
    training and evaluation seeds."""
    t = cfg.train
    fpb, n_updates = t.frames_per_batch, t.n_updates
    n_mb = fpb // t.minibatch_size if t.minibatches_per_epoch is None else t.minibatches_per_epoch
    lr_actor, lr_critic = cfg.optim.rates_for(t.minibatch_size)
    return TrainPlan(
        rollout_steps=t.rollout_length,
        n_updates=n_updates,
        total_frames=n_updates * fpb,
        minibatches_per_epoch=n_mb,
        gradient_steps_per_update=t.epochs * n_mb,
        frames_per_episode=t.n_swimmers * cfg.params.n_decisions,
        lr_actor=lr_actor,
        lr_critic=lr_critic,
        eval_seed=cfg.seed + EVAL_SEED_OFFSET,
        train_seed=training_seed(cfg.seed),
    )


#: Bytes per frame of a rollout batch (observations, signals, actions, log-probabilities,
#: values, advantages, their ``next`` copies and the loss's temporaries; an upper estimate).
FRAME_BYTES = 1024


def check_train_memory(cfg: TrainConfig) -> None:
    """Refuse (one line naming the key of the largest part) a run whose training flows and
    swimmers, rollout batch (:data:`FRAME_BYTES` per frame) and held-out evaluation chunk
    exceed the device's available memory (:func:`~swimrl.runtime.check_memory`)."""
    dtype, interval = cfg.runtime.dtype, cfg.params.update_interval
    held = cfg.held_out
    eval_flows = min(held.sizes.flows_per_batch, held.sizes.n_flows)
    t = cfg.train
    parts = {
        "train.n_flows": flow_table_bytes(cfg.spec.flow, t.n_flows, dtype, interval)
        + t.n_flows * t.n_swimmers * SWIMMER_BYTES,
        "train.rollout_length": t.frames_per_batch * FRAME_BYTES,
        "eval.flows_per_batch": flow_table_bytes(held.flow, eval_flows, dtype, interval)
        + eval_flows * held.sizes.n_swimmers * SWIMMER_BYTES,
    }
    key = max(parts, key=parts.get)
    value = {"train.n_flows": t.n_flows, "train.rollout_length": t.rollout_length,
             "eval.flows_per_batch": held.sizes.flows_per_batch}[key]
    what = ", ".join(f"{k.split('.')[-1]} {v / 2**30:.1f} GiB" for k, v in parts.items())
    check_memory(sum(parts.values()) + FLOW_WORK_BYTES, cfg.runtime.device, key, value,
                 f"the training flows and swimmers, rollout batch and evaluation chunk ({what})")
