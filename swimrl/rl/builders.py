r"""Small builders of the PPO pipeline, in the style of TorchRL's ``sota-implementations/ppo``.

``make_env`` -> ``make_actor``/``make_critic`` -> ``make_collector`` -> ``make_loss``
(``ClipPPOLoss`` + ``GAE``) -> ``make_optimizers``/``make_schedulers`` -> ``make_logger``.
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

import torch
from torch.optim.lr_scheduler import LambdaLR
from torchrl.collectors import Collector
from torchrl.envs import EnvBase, RewardScaling, TransformedEnv
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import GAE
from torchrl.record.loggers.tensorboard import TensorboardLogger

from swimrl.env import EnvParams, SwimmerEnv
from swimrl.flows.build import FlowSpec
from swimrl.policies.networks import ModelSpec, tanh_normal_actor, value_critic
from swimrl.rl.plan import LossSettings, OptimSettings, TrainSettings
from swimrl.runs.layout import RunLayout
from swimrl.runtime import Runtime


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
    multiplied by ``train.reward_scale`` (None: :func:`auto_reward_scale` at ``loss.gamma``)."""
    base = SwimmerEnv.build(flow, params, runtime, train.n_flows, train.n_swimmers, seed)
    base.stagger(train.stagger)  # train.stagger groups of flows, episodes offset
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


def make_actor(model: ModelSpec, env: EnvBase, runtime: Runtime):
    """Actor on the env's observation, bounded by its action spec (the ``TanhNormal``'s
    ``low``/``high``; see :func:`swimrl.policies.networks.tanh_normal_actor`)."""
    return tanh_normal_actor(
        env.observation_spec["observation"].shape[-1],
        env.action_spec_unbatched,
        hidden=list(model.hidden),
        activation=model.activation,
        init_std=model.init_std,
        min_std=model.min_std,
        device=runtime.device,
        dtype=runtime.dtype,
    )


def make_critic(model: ModelSpec, env: EnvBase, runtime: Runtime):
    """Critic ``V(observation)``."""
    return value_critic(
        env.observation_spec["observation"].shape[-1],
        hidden=list(model.hidden),
        activation=model.activation,
        device=runtime.device,
        dtype=runtime.dtype,
    )


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


def make_loss(loss: LossSettings, actor, critic, gae_chunk: int | None
              ) -> tuple[ClipPPOLoss, GAE]:
    r"""``ClipPPOLoss`` (paper ``J(w)``, clip ``epsilon``, entropy bonus) and ``GAE``
    (``A_i = sum_k (gamma lambda)^k delta_{i+k}``, ``delta_i = r_i + gamma V(s_{i+1}) -
    V(s_i)``, bootstrapped at truncation since ``terminated`` is never set), its critic
    evaluated in chunks of ``gae_chunk`` samples (``train.gae_chunk``)."""
    gae = FiniteObservationGAE(
        gamma=loss.gamma,
        lmbda=loss.gae_lambda,
        value_network=critic,
        average_gae=False,
        value_chunk_size=gae_chunk,  # the same values, cache-sized critic calls
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
    return ppo, gae


def make_optimizers(optim: OptimSettings, actor, critic, device, cudagraphs: bool
                    ) -> tuple[torch.optim.Adam, torch.optim.Adam]:
    """Separate Adam optimisers (paper: ``4e-4`` actor, ``8e-5`` critic). Under
    ``train.cudagraphs`` the learning rates are tensors on ``device`` and the steps capturable
    (as TorchRL's ``sota-implementations/ppo``), so a captured step reads the scheduled rate."""
    eps, lrs = optim.eps, (optim.lr_actor, optim.lr_critic)
    if not cudagraphs:
        return (torch.optim.Adam(actor.parameters(), lr=lrs[0], eps=eps),
                torch.optim.Adam(critic.parameters(), lr=lrs[1], eps=eps))
    return tuple(
        torch.optim.Adam(net.parameters(), lr=torch.tensor(lr, device=device), eps=eps,
                         capturable=True)
        for net, lr in ((actor, lrs[0]), (critic, lrs[1]))
    )


def make_schedulers(optim: OptimSettings, optimizers, n_updates: int) -> list[LambdaLR]:
    """Learning rate ``lr_0 (1 - u / n_updates)`` at update ``u`` (``optim.anneal=linear``,
    reaching ``lr_0 / n_updates`` at the last update) or constant (``none``); stepped once
    per update."""
    if optim.anneal == "linear":

        def factor(u: int) -> float:
            return max(0.0, 1.0 - u / n_updates)
    else:

        def factor(u: int) -> float:
            return 1.0

    return [LambdaLR(opt, factor) for opt in optimizers]


def make_logger(run: RunLayout) -> TensorboardLogger:
    """TensorBoard logger writing under ``<run dir>/tb/ppo``."""
    return TensorboardLogger(exp_name="ppo", log_dir=str(run.tb))
