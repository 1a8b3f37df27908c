r"""Small builders of the PPO pipeline, in the style of TorchRL's ``sota-implementations/ppo``.

``make_env`` -> ``make_agent`` (actor and critic, ``GAE`` + ``ClipPPOLoss``, Adam and its
schedules) -> ``make_collector`` -> ``make_logger``.
Each takes the typed part of the config it needs (``cfg.model``, ``cfg.loss``, ``cfg.optim``,
``cfg.train``, the runtime), whose constructor has checked the values and their types.

Reward scaling (``train.reward_scale``): the step reward ``r_i`` (paper ``eq:reward``) is a
radial displacement, at most ``v_s T_u ~ 0.035`` flow units per decision. The training env
multiplies it by ``c`` (TorchRL ``RewardScaling``); ``auto`` takes ``c = (1 - gamma) / (v_s
T_u)``, so the discounted return ``V = sum_k gamma^k c r_{i+k}`` is a gamma-weighted average
of the radial speed in units of ``v_s``: value targets are O(1) whatever ``v_s``, ``T_u`` and
``gamma``. The scale changes neither the optimal policy nor the (per-minibatch normalised)
advantages; it only conditions the critic regression. ``distance`` and ``R_hat`` are never
scaled.
"""

from __future__ import annotations

import logging
from typing import NamedTuple

import torch
from torch.optim.lr_scheduler import LambdaLR
from torchrl.collectors import Collector
from torchrl.envs import EnvBase, RewardScaling, TransformedEnv
from torchrl.modules import ProbabilisticActor, ValueOperator
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import GAE
from torchrl.record.loggers.tensorboard import TensorboardLogger

from swimrl.env import EnvParams, SwimmerEnv, build_env
from swimrl.env.features import observe_flow_for_critic
from swimrl.flows.build import FlowSpec
from swimrl.policies.networks import ModelSpec, actor_critic
from swimrl.rl.plan import LossSettings, TrainConfig, TrainPlan, TrainSettings
from swimrl.runs.layout import RunLayout
from swimrl.runs.policy_files import initial_actor_weights, sha256_file
from swimrl.runtime import Runtime

log = logging.getLogger(__name__)


def auto_reward_scale(env: SwimmerEnv, gamma: float) -> float:
    """``(1 - gamma) / (v_s T_u)`` in the flow's units (``gamma = 1``: ``1 / (v_s T)``)."""
    per_step = env.swim_speed * env.params.update_interval * env.tau_k
    if per_step <= 0:
        return 1.0
    if gamma >= 1.0:
        return 1.0 / (per_step * env.params.n_decisions)
    return (1.0 - gamma) / per_step


def make_env(flow: FlowSpec, params: EnvParams, runtime: Runtime, train: TrainSettings,
             loss: LossSettings, seed: int) -> TransformedEnv:
    """Training env: ``train.n_flows x train.n_swimmers`` swimmers in ``flow``, seeded with
    ``seed`` (the training stream, :func:`~swimrl.rl.plan.training_seed`), episodes staggered
    in ``train.stagger`` groups (:meth:`~swimrl.env.SwimmerEnv.stagger`), with the reward
    multiplied by ``train.reward_scale`` (None: :func:`auto_reward_scale` at ``loss.gamma``);
    with ``train.critic_flow`` its observations carry ``critic_observation``
    (:func:`~swimrl.env.features.observe_flow_for_critic`)."""
    base = build_env(flow, params, runtime, train.n_flows, train.n_swimmers, seed,
                     stagger=train.stagger)
    if train.critic_flow:
        observe_flow_for_critic(base)
    scale = train.reward_scale
    if scale is None:
        scale = auto_reward_scale(base, loss.gamma)
    return TransformedEnv(base, RewardScaling(loc=0.0, scale=scale))


def base_env(env: EnvBase) -> SwimmerEnv:
    """The :class:`SwimmerEnv` under any transforms."""
    return env.base_env if isinstance(env, TransformedEnv) else env


def reward_scale_of(env: TransformedEnv) -> float:
    """The reward multiplier applied by :func:`make_env`."""
    return float(env.transform.scale)


def make_actor_critic(model: ModelSpec, env: EnvBase, runtime: Runtime):
    """Actor and critic on the env's observation, the actor read from its action spec
    (``env.action_spec_unbatched``): a ``TanhNormal`` within the ``Bounded`` spec's
    ``low``/``high`` (the shape factor, a steering vector, or both), or a ``Categorical`` of a
    discrete one (:func:`swimrl.policies.networks.actor_critic`); the critic on
    ``critic_observation`` where the env has it (``train.critic_flow``)."""
    spec = env.observation_spec
    has = "critic_observation" in spec.keys()  # noqa: SIM118
    critic_key = "critic_observation" if has else "observation"
    return actor_critic(model, spec["observation"].shape[-1], env.action_spec_unbatched,
                        device=runtime.device, dtype=runtime.dtype,
                        critic_obs=(critic_key, spec[critic_key].shape[-1]))


def make_collector(env: EnvBase, actor, train: TrainSettings, total_frames: int,
                   device) -> Collector:
    """TorchRL ``Collector`` over the batched env, ``train.frames_per_batch`` frames per
    batch; output batches ``(F, S, L)`` (time last).

    The env truncates episodes itself after ``N`` decisions; the collector resets the done
    swimmers (partial ``_reset``), so rollouts run across episode boundaries. On CUDA
    (``train.cudagraphs``) the collector captures the policy in a CUDA graph, compiled first
    under ``train.compile`` (TorchRL's ``cudagraph_policy`` / ``compile_policy``).
    """
    return Collector(
        env,
        actor,
        frames_per_batch=train.frames_per_batch,
        total_frames=total_frames,
        device=device,
        storing_device=device,
        auto_register_policy_transforms=False,
        trust_policy=True,
        compile_policy={"mode": "default"} if train.cudagraphs and train.compile else None,
        cudagraph_policy=train.cudagraphs,
    )


class FiniteObservationGAE(GAE):
    """TorchRL's ``GAE``, unchanged but for one step it skips: ``_sanitize_next_obs_nan``.

    That step replaces NaN next-observations (written by ``NextStateReconstructor`` with a
    collector's ``compact_obs=True``) by the root observation, and to find them it calls
    ``torch.isnan(next_obs).any()`` and branches on the result in Python: a host
    synchronisation, which invalidates a CUDA-graph capture of the GAE
    (``cudaErrorStreamCaptureInvalidated``) and is a graph break for ``torch.compile``.
    Here it can only ever be a no-op: :class:`~swimrl.env.SwimmerEnv` writes every
    observation from finite flow fields and swimmer states (the finiteness of the results is
    checked separately, :meth:`~swimrl.env.SwimmerEnv.check_displacement` and the trainer's
    non-finite checks), and the collector is not built with ``compact_obs``. The advantages
    are therefore those of ``GAE`` bit for bit (``tests/test_capture.py``)."""

    @staticmethod
    def _sanitize_next_obs_nan(data, in_keys):
        return data


class Agent(NamedTuple):
    """What PPO trains and how: actor, critic, ``ClipPPOLoss`` and its ``GAE``, the two Adam
    optimisers and their schedulers."""

    actor: ProbabilisticActor
    critic: ValueOperator
    loss: ClipPPOLoss
    gae: GAE
    optimizers: tuple[torch.optim.Adam, torch.optim.Adam]
    schedulers: list[LambdaLR]


def make_agent(cfg: TrainConfig, plan: TrainPlan, env: EnvBase) -> Agent:
    r"""The :class:`Agent` of a training run on ``env``, each piece under its comment.

    * actor and critic: :func:`make_actor_critic` (``model.*``); the actor's weights from
      ``train.init_policy`` where one is given (a warm start; the critic starts fresh);
    * ``GAE`` (``A_i = sum_k (gamma lambda)^k delta_{i+k}``, ``delta_i = r_i + gamma
      V(s_{i+1}) - V(s_i)``, bootstrapped at truncation since ``terminated`` is never set;
      :class:`FiniteObservationGAE`), its critic evaluated in chunks of ``train.gae_chunk``
      samples, and ``ClipPPOLoss`` (paper ``J(w)``, clip ``epsilon``, entropy bonus);
    * separate Adam optimisers at the plan's initial rates (paper: ``4e-4``, ``8e-5``;
      :meth:`~swimrl.rl.plan.OptimSettings.rates_for`); under ``train.cudagraphs`` the rates
      are tensors on the device and the steps capturable (as TorchRL's
      ``sota-implementations/ppo``), so a captured step reads the scheduled rate;
    * their schedulers: rate ``lr_0 (1 - u / n_updates)`` at update ``u``
      (``optim.anneal=linear``, reaching ``lr_0 / n_updates`` at the last update) or constant
      (``none``), stepped once per update; the actor's rate is 0 for the first
      ``train.actor_frozen_updates`` updates (the critic learns alone).
    """
    rt, t, loss, optim = cfg.runtime, cfg.train, cfg.loss, cfg.optim
    # actor and critic (the actor from train.init_policy's weights, a warm start)
    actor, critic = make_actor_critic(cfg.model, env, rt)
    if t.init_policy is not None:
        path, weights = initial_actor_weights(t.init_policy, cfg.params, cfg.model)
        actor.load_state_dict(weights)
        log.info("actor initialised from %s (sha256 %s)", path, sha256_file(path)[:12])
    # the advantage and the loss
    gae = FiniteObservationGAE(
        gamma=loss.gamma,
        lmbda=loss.gae_lambda,
        value_network=critic,
        average_gae=False,
        value_chunk_size=t.gae_chunk,  # the same values, cache-sized critic calls
    )
    ppo = ClipPPOLoss(
        actor,
        critic,
        clip_epsilon=loss.clip_epsilon,
        entropy_bonus=loss.entropy_coeff > 0,  # no Monte-Carlo entropy sample when unused
        entropy_coeff=loss.entropy_coeff,
        critic_coeff=loss.critic_coeff,
        loss_critic_type=loss.loss_critic_type,
        normalize_advantage=loss.normalize_advantage,
    )
    # the optimisers
    nets = ((actor, plan.lr_actor), (critic, plan.lr_critic))
    if t.cudagraphs:
        optimizers = tuple(torch.optim.Adam(net.parameters(), eps=optim.eps, capturable=True,
                                            lr=torch.tensor(lr, device=rt.device))
                           for net, lr in nets)
    else:
        optimizers = tuple(torch.optim.Adam(net.parameters(), lr=lr, eps=optim.eps)
                           for net, lr in nets)
    # their learning-rate schedules
    n_updates = plan.n_updates
    if optim.anneal == "linear":

        def factor(u: int) -> float:
            return max(0.0, 1.0 - u / n_updates)
    else:

        def factor(u: int) -> float:
            return 1.0

    def actor_factor(u: int) -> float:  # rate 0 while the critic learns alone
        return 0.0 if u < t.actor_frozen_updates else factor(u)

    schedulers = [LambdaLR(optimizers[0], actor_factor), LambdaLR(optimizers[1], factor)]
    return Agent(actor, critic, ppo, gae, optimizers, schedulers)


def make_logger(run: RunLayout) -> TensorboardLogger:
    """TensorBoard logger writing under ``<run dir>/tb/ppo``."""
    return TensorboardLogger(exp_name="ppo", log_dir=str(run.tb))
