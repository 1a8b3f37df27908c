r"""Validated training plan: sizes, schedule and seeds, checked before any compute.

Counting (all in *env-batch elements*, i.e. swimmer decisions):

* one environment step advances ``n_flows x n_swimmers`` swimmers by ``T_u``;
* a batch (one PPO update) is ``frames_per_batch = n_flows n_swimmers L`` frames, i.e. a
  rollout of ``L`` decisions of every swimmer (episodes run on across batches and are
  truncated at ``N = T/T_u`` decisions, then restart with a new flow realisation);
* ``n_updates = total_frames // frames_per_batch`` updates; each update makes ``epochs``
  passes, each over ``minibatches_per_epoch`` minibatches of ``minibatch_size`` frames
  drawn without replacement from the batch (default: a full pass, ``frames_per_batch //
  minibatch_size``);
* an *episode* (paper) is one flow realisation with its ``n_swimmers`` swimmers for ``T``:
  ``episodes = frames / (n_swimmers N)``.

Seeds: training flows and initial conditions come from
``SeedSequence([seed, TRAIN_STREAM])``; evaluations (periodic and final) use
:func:`swimrl.evaluate.evaluate` with ``seed + EVAL_SEED_OFFSET``, whose flow chunks are
``SeedSequence([seed + EVAL_SEED_OFFSET, chunk])``: streams disjoint from training, so the
reported ``R_hat`` is measured on held-out flow realisations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from omegaconf import DictConfig

from swimrl.config import ConfigError, EnvParams
from swimrl.evaluate import validate_eval_cfg

#: Offset added to ``seed`` for the held-out evaluation flows.
EVAL_SEED_OFFSET = 1_000_000
#: Second word of the training seed sequence (far from any evaluation chunk index).
TRAIN_STREAM = 2**31 - 1
LOSS_CRITIC_TYPES = ("l1", "l2", "smooth_l1")


def training_seed(seed: int) -> int:
    """Seed of the training environment's generator for run seed ``seed``."""
    return int(np.random.SeedSequence([int(seed), TRAIN_STREAM]).generate_state(1)[0])


def _fail(key: str, value, allowed: str) -> None:
    raise ConfigError(f"{key}={value!r} is invalid: allowed {allowed}")


def _int(cfg: DictConfig, key: str, low: int = 1) -> int:
    """``cfg[key]`` as an integer ``>= low`` (accepts ``1e6``-style floats that are whole)."""
    node = cfg
    for part in key.split("."):
        node = node[part]
    value = node
    try:
        f = float(value)
    except (TypeError, ValueError):
        _fail(key, value, f"an integer >= {low}")
    if f != int(f) or f < low:
        _fail(key, value, f"an integer >= {low}")
    return int(f)


def _float(cfg: DictConfig, key: str, cond, allowed: str) -> float:
    node = cfg
    for part in key.split("."):
        node = node[part]
    try:
        f = float(node)
    except (TypeError, ValueError):
        _fail(key, node, allowed)
    if not cond(f):
        _fail(key, node, allowed)
    return f


@dataclass(frozen=True)
class TrainPlan:
    """Everything the training loop needs to know about sizes, schedule and seeds."""

    params: EnvParams
    n_flows: int
    n_swimmers: int
    frames_per_batch: int
    rollout_steps: int
    n_updates: int
    total_frames: int
    minibatch_size: int
    minibatches_per_epoch: int
    epochs: int
    reward_scale: float | None  # None: automatic (1 - gamma) / (v_s T_u), set with the env
    eval_every: int
    eval_seed: int
    train_seed: int

    @property
    def frames_per_episode(self) -> int:
        """Frames of one paper episode: ``n_swimmers x N``."""
        return self.n_swimmers * self.params.n_decisions

    @property
    def gradient_steps_per_update(self) -> int:
        return self.epochs * self.minibatches_per_epoch


def validate_train_cfg(cfg: DictConfig) -> TrainPlan:
    """All checks of a training config (physics, evaluation, PPO, sizes); one-line errors."""
    params = validate_eval_cfg(cfg)
    t = cfg.train
    n_flows, n_swimmers = _int(cfg, "train.n_flows"), _int(cfg, "train.n_swimmers")
    fpb = _int(cfg, "train.frames_per_batch")
    batch = n_flows * n_swimmers
    if fpb % batch:
        _fail(
            "train.frames_per_batch",
            t.frames_per_batch,
            f"a multiple of train.n_flows*train.n_swimmers={batch}",
        )
    total = _int(cfg, "train.total_frames")
    if total < fpb:
        _fail("train.total_frames", t.total_frames, f">= train.frames_per_batch={fpb}")
    mb = _int(cfg, "train.minibatch_size")
    if mb > fpb:
        _fail("train.minibatch_size", t.minibatch_size, f"<= train.frames_per_batch={fpb}")
    full = fpb // mb
    if t.minibatches_per_epoch is None:
        n_mb = full
    else:
        n_mb = _int(cfg, "train.minibatches_per_epoch")
        if n_mb > full:
            _fail(
                "train.minibatches_per_epoch",
                t.minibatches_per_epoch,
                f"null or <= frames_per_batch // minibatch_size = {full}",
            )
    epochs = _int(cfg, "train.epochs")
    eval_every = _int(cfg, "train.eval_every", low=0)
    _int(cfg, "train.eval_flows")
    _int(cfg, "train.eval_swimmers")
    _int(cfg, "train.checkpoint_every")
    _float(cfg, "train.checkpoint_seconds", lambda v: v > 0, "> 0 (seconds)")
    if t.stop_after_updates is not None:
        _int(cfg, "train.stop_after_updates")
    if t.reward_scale in (None, "auto"):
        scale = None
    else:
        scale = _float(cfg, "train.reward_scale", lambda v: v > 0, "'auto' or a number > 0")
    _float(cfg, "loss.gamma", lambda v: 0 < v <= 1, "in (0, 1]")
    _float(cfg, "loss.gae_lambda", lambda v: 0 <= v <= 1, "in [0, 1]")
    _float(cfg, "loss.clip_epsilon", lambda v: 0 < v < 1, "in (0, 1)")
    _float(cfg, "loss.entropy_coeff", lambda v: v >= 0, ">= 0")
    _float(cfg, "loss.critic_coeff", lambda v: v > 0, "> 0")
    if cfg.loss.loss_critic_type not in LOSS_CRITIC_TYPES:
        _fail("loss.loss_critic_type", cfg.loss.loss_critic_type, f"one of {LOSS_CRITIC_TYPES}")
    _float(cfg, "optim.lr_actor", lambda v: v > 0, "> 0")
    _float(cfg, "optim.lr_critic", lambda v: v > 0, "> 0")
    if cfg.optim.anneal not in ("linear", "none"):
        _fail("optim.anneal", cfg.optim.anneal, "'linear' or 'none'")
    if cfg.optim.max_grad_norm is not None:
        _float(cfg, "optim.max_grad_norm", lambda v: v > 0, "null or > 0")
    _float(cfg, "model.init_std", lambda v: v > 0, "> 0")
    hidden = list(cfg.model.hidden)
    if not hidden or any(int(h) < 1 for h in hidden):
        _fail("model.hidden", hidden, "a non-empty list of positive layer widths")
    if cfg.model.activation not in ("tanh", "relu", "elu"):
        _fail("model.activation", cfg.model.activation, "'tanh', 'relu' or 'elu'")
    return TrainPlan(
        params=params,
        n_flows=n_flows,
        n_swimmers=n_swimmers,
        frames_per_batch=fpb,
        rollout_steps=fpb // batch,
        n_updates=total // fpb,
        total_frames=(total // fpb) * fpb,
        minibatch_size=mb,
        minibatches_per_epoch=n_mb,
        epochs=epochs,
        reward_scale=scale,
        eval_every=eval_every,
        eval_seed=int(cfg.seed) + EVAL_SEED_OFFSET,
        train_seed=training_seed(int(cfg.seed)),
    )
