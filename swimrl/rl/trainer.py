r"""The PPO training loop: collect -> GAE -> epochs of clipped-PPO minibatch steps -> log.

One *update* ``u``:

1. the collector returns a batch ``(F, S, L)`` of ``L`` decisions of every swimmer, sampled
   from the stochastic policy (``ExplorationType.RANDOM``);
2. ``GAE`` (with the critic before the update) writes ``advantage`` and ``value_target``;
3. ``epochs`` passes over a fresh random permutation of the flattened batch, each of
   ``minibatches_per_epoch`` minibatches: loss ``= loss_objective + loss_entropy +
   loss_critic`` (``ClipPPOLoss``, advantages normalised per minibatch), one backward, the
   gradient norm of actor and critic clipped separately, one Adam step each;
4. both learning rates step (the schedulers of ``make_agent``): constant, or down linearly
   (``optim.anneal``).

Periodic deterministic evaluations (``Lambda = Lambda_max tanh(mu)``) on held-out flows use
:func:`swimrl.evaluation.rollout.evaluate` (``seed + EVAL_SEED_OFFSET``, the same flows every time,
so successive points share their randomness); update 0 is the initial policy.

Resume: the state after an update is checkpointed atomically; ``resume=true`` reloads it
(networks, optimisers, schedulers, RNGs, counters) and continues with update ``u + 1``; a
preemption signal (:mod:`swimrl.runs.jobs`) stops the loop after the update in flight,
or inside a periodic evaluation before its next decision, with a checkpoint; an evaluation
stopped so is marked in the checkpoint (``counters["eval_pending"]``) and made first on resume.
Collector and environment are *not* checkpointed mid-episode: the resumed run starts fresh
episodes (new flow realisations drawn from the restored env generator), so the frames
collected after the last checkpoint and the unfinished episodes of the killed process are
discarded, never counted twice. Finished updates are never redone.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import replace
from pathlib import Path

import torch
from tensordict import TensorDict
from torch.profiler import record_function
from tqdm.auto import tqdm

from swimrl.errors import NonFiniteError
from swimrl.evaluation.rollout import evaluate
from swimrl.policies.networks import deterministic_actor, policy_std
from swimrl.rl import builders as rlb
from swimrl.rl.plan import TrainConfig, TrainPlan
from swimrl.runs.checkpoint import capture_rng, restore_rng, save_checkpoint
from swimrl.runs.curves import read_curves_csv, write_curves
from swimrl.runs.jobs import EvaluationInterruptedError, Preemption
from swimrl.runs.layout import RunLayout
from swimrl.runs.policy_files import load_file, policy_meta, save_policy
from swimrl.runs.spec import RunSpec

log = logging.getLogger(__name__)

#: Loss outputs averaged over the minibatches of an update and logged under ``train/``.
LOSS_LOG_KEYS = (
    "loss_objective",
    "loss_critic",
    "loss_entropy",
    "entropy",
    "kl_approx",
    "clip_fraction",
    "ESS",
    "explained_variance",
)


class PPOTrainer:
    """Owns env, networks, loss, optimisers and counters of one training run."""

    def __init__(self, cfg: TrainConfig, plan: TrainPlan, run_dir: Path,
                 state: dict | None = None):
        """A fresh trainer, or (``state``: a checkpoint's content,
        :func:`~swimrl.runs.checkpoint.load_checkpoint`) one that continues from it."""
        self.cfg, self.plan, self.run = cfg, plan, RunLayout(run_dir)
        rt, t = cfg.runtime, cfg.train
        self.device, self.dtype = rt.device, rt.dtype
        torch.manual_seed(cfg.seed)  # network init, action sampling, minibatch order
        self.env = rlb.make_env(cfg.spec.flow, cfg.params, rt, t, cfg.loss, plan.train_seed)
        self.swimmer_env = rlb.base_env(self.env)
        self.reward_scale = rlb.reward_scale_of(self.env)
        (self.actor, self.critic, self.loss, self.gae, self.optimizers,
         self.schedulers) = rlb.make_agent(cfg, plan, self.env)
        self.policy = deterministic_actor(self.actor)
        self.counters = {"frames": 0, "updates": 0, "wall_s": 0.0}
        self.config = cfg.record
        self._loss_fn = None  # built on the first update (see _compiled_loss_backward)
        self._step_fn = None  # the gradient step, built on the first update (_step_function)
        self._gae_fn = self.gae  # captured in a CUDA graph under train.cudagraphs
        self.logger = None
        self.last_eval: dict | None = None
        self.last_train_r_hat: float | None = None
        self.curve_base: dict[int, dict[str, float]] | None = None  # see restore
        #: Read between the decisions of every evaluation (set by :meth:`train`).
        self.preemption: Preemption | None = None
        #: A periodic evaluation was started and not finished (a signal stopped it).
        self.eval_pending = False
        if state is not None:
            self.load_state(state)

    # -- state --------------------------------------------------------------------------------
    @property
    def meta(self) -> dict:
        """What a policy file records to rebuild the actor (:func:`policy_meta`)."""
        return policy_meta(self.cfg.params, self.cfg.model,
                           str(self.dtype).replace("torch.", ""),
                           self.env.action_spec_unbatched)

    @property
    def finished_training(self) -> bool:
        return self.counters["updates"] >= self.plan.n_updates

    @property
    def episodes(self) -> float:
        """Paper episodes so far: ``frames / (n_swimmers N)``."""
        return self.counters["frames"] / self.plan.frames_per_episode

    def save_checkpoint(self) -> Path:
        path = save_checkpoint(
            self.run,
            actor=self.actor,
            critic=self.critic,
            optimizers=self.optimizers,
            schedulers=self.schedulers,
            rng=capture_rng(self.swimmer_env.generator),
            counters={**self.counters, **({"eval_pending": True} if self.eval_pending else {})},
            config=self.config,
            meta={**self.meta, "reward_scale": self.reward_scale},
        )
        if self.logger is not None:
            self.logger.experiment.flush()
            write_curves(self.run.root, base=self.curve_base)
        return path

    def restore(self, path: Path) -> dict:
        """Load the training state written by :meth:`save_checkpoint` from ``path``."""
        ck = load_file(path, map_location=self.device)
        self.load_state(ck)
        return ck

    def load_state(self, ck: dict) -> None:
        """Continue from a checkpoint's content (:meth:`save_checkpoint`): networks,
        optimisers, schedulers, RNG states, counters and the curve up to it."""
        self.actor.load_state_dict(ck["actor"])
        self.critic.load_state_dict(ck["critic"])
        for opt, st in zip(self.optimizers, ck["optimizers"], strict=True):
            opt.load_state_dict(st)
        for sch, st in zip(self.schedulers, ck["schedulers"], strict=True):
            sch.load_state_dict(st)
        self._match_optimizers_to_device()
        restore_rng(ck["rng"], self.swimmer_env.generator)
        self.counters = dict(ck["counters"])
        self.eval_pending = bool(self.counters.pop("eval_pending", False))
        # the curve up to the checkpoint, kept where the event files may be gone (a run
        # resumed from its committed record: checkpoint + curves.csv)
        curves = self.run.curves
        if curves.is_file():
            self.curve_base = {step: row for step, row in read_curves_csv(curves).items()
                               if step <= self.counters["frames"]}

    def _match_optimizers_to_device(self) -> None:
        """After loading optimiser states written by another path: learning rates as device
        tensors and capturable steps under ``train.cudagraphs``, plain floats otherwise (a
        checkpoint moves between the CPU and a CUDA-graphed run)."""
        graphs = self.cfg.train.cudagraphs
        for opt in self.optimizers:
            for group in opt.param_groups:
                for key in ("lr", "initial_lr"):
                    if key in group:
                        lr = float(group[key])
                        group[key] = torch.tensor(lr, device=self.device) if graphs else lr
                group["capturable"] = graphs
            for state in opt.state.values():
                if "step" in state:
                    state["step"] = state["step"].to(
                        self.device if graphs else "cpu", torch.float32)
        for sch in self.schedulers:  # lr = base_lr * factor, written into the groups above
            sch.base_lrs = [float(b) for b in sch.base_lrs]

    def save_policy(self, path: Path | None = None) -> Path:
        """The deterministic policy as ``<run>/policy.pt`` (or ``path``)."""
        return save_policy(
            self.run.policy if path is None else path,
            actor=self.actor,
            counters=self.counters,
            config=self.config,
            meta=self.meta,
        )

    # -- evaluation ---------------------------------------------------------------------------
    def evaluate(self, setup: RunSpec | None = None,
                 preemption: Preemption | None = None) -> dict:
        """Deterministic policy on held-out flows (``seed + EVAL_SEED_OFFSET``); default: the
        periodic evaluation's ``train.eval_flows x train.eval_swimmers``. ``preemption``
        (default :attr:`preemption`) stops it between two decisions
        (:class:`~swimrl.runs.jobs.EvaluationInterruptedError`)."""
        if setup is None:
            t = self.cfg.train
            setup = self.cfg.held_out.resized(t.eval_flows, t.eval_swimmers)
        return evaluate(replace(setup, seed=self.plan.eval_seed), self.policy, "policy",
                        preemption=self.preemption if preemption is None else preemption)

    def _periodic_eval(self) -> bool:
        """The periodic held-out evaluation of the current policy, logged at the current frame
        count; marked pending (:attr:`eval_pending`) until it has finished. False when a
        preemption signal stopped it (it stays pending), True when it finished."""
        self.eval_pending = True
        t0 = time.perf_counter()
        # the policy evaluated, kept so that a policy can be chosen afterwards on flows of a
        # separate validation seed (the periodic evaluation's flows are the final one's)
        self.save_policy(self.run.periodic_policy(self.counters["frames"]))
        try:
            m = self.evaluate()
        except EvaluationInterruptedError:
            return False
        self.last_eval = m
        step = self.counters["frames"]
        self.logger.log_scalar("eval/R_hat", m["R_hat_mean"], step)
        self.logger.log_scalar("eval/R_hat_sem", m["R_hat_sem"], step)
        for tag, key in (("eval/energy", "energy_mean"), ("eval/shape_change", "shape_change_mean"),
                         ("eval/arrival", "arrival_mean")):
            if key in m:  # E_hat, C_hat always; the arrival probability with task=target
                self.logger.log_scalar(tag, m[key], step)
        self.logger.log_scalar("eval/time_s", time.perf_counter() - t0, step)
        self.logger.log_scalar("eval/R_hat_vs_episodes", m["R_hat_mean"], round(self.episodes))
        self.eval_pending = False
        return True

    # -- one update ---------------------------------------------------------------------------
    def _loss(self, batch: TensorDict) -> tuple[torch.Tensor, TensorDict]:
        """``ClipPPOLoss`` on one minibatch: ``loss_objective + loss_entropy + loss_critic``
        and the detached loss terms."""
        out = self.loss(batch)
        total = out["loss_objective"] + out["loss_critic"]
        if "loss_entropy" in out.keys():  # noqa: SIM118 (TensorDict)
            total = total + out["loss_entropy"]
        return total, out.detach()

    def _loss_backward(self, batch: TensorDict) -> TensorDict:
        """:meth:`_loss` and the backward pass of the total; returns the detached terms."""
        total, out = self._loss(batch)
        total.backward()
        return out

    def _compiled_loss_backward(self):
        """:meth:`_loss_backward`, with :meth:`_loss` compiled by ``torch.compile`` when
        ``train.compile`` is set (as TorchRL's ``sota-implementations/ppo``; compiled lazily,
        on the first minibatch), else eager. The backward pass stays outside the compiled
        function (Dynamo cannot trace ``Tensor.backward``): AOTAutograd's compiled backward
        graph runs there, and the call is one graph, one guard check."""
        if self._loss_fn is None:
            self._loss_fn = self._loss_backward
            if self.cfg.train.compile:
                loss = torch.compile(self._loss, dynamic=False)

                def loss_backward(batch: TensorDict) -> TensorDict:
                    total, out = loss(batch)
                    total.backward()
                    return out

                self._loss_fn = loss_backward
        return self._loss_fn

    def _gradient_step(self, loss_backward) -> TensorDict:
        """One clipped-PPO gradient step: ``loss_backward`` on a minibatch, the gradient norm of
        actor and critic clipped separately, one Adam step each, gradients released."""
        clip = self.cfg.optim.max_grad_norm
        groups = [list(self.actor.parameters()), list(self.critic.parameters())]

        def step(batch: TensorDict) -> TensorDict:
            with record_function("ppo/loss_backward"):
                out = loss_backward(batch)
            with record_function("ppo/clip_optimizer"):
                if clip is not None:
                    for g in groups:
                        torch.nn.utils.clip_grad_norm_(g, clip)
                for opt in self.optimizers:
                    opt.step()
                    opt.zero_grad(set_to_none=True)
            return out

        return step

    def _step_function(self):
        """The gradient step of :meth:`update`, built once:

        * eager, or with the loss compiled (``train.compile``, the CPU path): loss + backward
          (:meth:`_compiled_loss_backward`), clipping and Adam as separate calls;
        * ``train.cudagraphs`` (CUDA): the whole step (loss, backward, clipping, both Adam
          steps) compiled (``train.compile``) and captured in one CUDA graph by tensordict's
          ``CudaGraphModule``, as TorchRL's ``sota-implementations/ppo`` does; the GAE is
          captured too. A step is then one graph replay: no host synchronisation and no
          Python work per kernel inside an update.
        """
        if self._step_fn is not None:
            return self._step_fn
        if not self.cfg.train.cudagraphs:
            self._step_fn = self._gradient_step(self._compiled_loss_backward())
            return self._step_fn
        from tensordict.nn import CudaGraphModule
        from torchrl._utils import compile_with_warmup

        step = self._gradient_step(self._loss_backward)
        gae = self.gae
        if self.cfg.train.compile:
            step = compile_with_warmup(step, mode="default", warmup=1)
            gae = compile_with_warmup(gae, mode="default", warmup=1)
        self._step_fn = CudaGraphModule(step, in_keys=[], out_keys=[], warmup=5)
        self._gae_fn = CudaGraphModule(gae)
        return self._step_fn

    def update(self, data: TensorDict) -> dict[str, torch.Tensor]:
        """GAE + ``epochs x minibatches`` clipped-PPO steps on one batch; mean loss terms.

        Each epoch gathers the samples of its minibatches once, in a fresh random order, and
        takes the minibatches as consecutive slices; the loss terms are stacked and averaged
        once per update."""
        plan, mb = self.plan, self.cfg.train.minibatch_size
        step = self._step_function()
        with torch.no_grad(), record_function("ppo/gae"):
            data = self._gae_fn(data)
        flat = data.select(*self._loss_keys(data), strict=False).reshape(-1)
        n = flat.numel()
        terms: list[TensorDict] = []
        log_keys: list[str] | None = None
        for _ in range(self.cfg.train.epochs):
            with record_function("ppo/minibatch"):
                used = torch.randperm(n, device=flat.device)[: plan.minibatches_per_epoch * mb]
                shuffled = flat[used]
            for k in range(plan.minibatches_per_epoch):
                out = step(shuffled[k * mb : (k + 1) * mb])
                if log_keys is None:
                    log_keys = [key for key in LOSS_LOG_KEYS if key in out.keys()]  # noqa: SIM118
                terms.append(out.select(*log_keys))
        for sch in self.schedulers:
            sch.step()
        assert log_keys is not None  # epochs >= 1 and minibatches_per_epoch >= 1 (TrainPlan)
        stacked = torch.stack(terms)  # (gradient steps,) + the loss terms' shapes
        return {k: stacked[k].float().reshape(len(terms), -1).mean() for k in log_keys}

    def _loss_keys(self, data: TensorDict) -> list:
        keys = set(self.loss.in_keys) | {"advantage", "value_target", "state_value"}
        return [k for k in keys if k in data.keys(include_nested=True)]

    # -- main loop ----------------------------------------------------------------------------
    def train(self, stop_after: int | None = None,
              preemption: Preemption | None = None) -> bool:
        """Run updates until the plan is done (returns True), ``stop_after`` updates were
        made in this call, or ``preemption`` was requested (a signal, checked after each
        update and between the decisions of a periodic evaluation: the update in flight is
        finished, an evaluation in flight is left pending); then the state is checkpointed
        and :attr:`finished_training` returned."""
        cfg, plan, fpb = self.cfg, self.plan, self.cfg.train.frames_per_batch
        self.preemption = preemption
        if self.logger is None:
            self.logger = rlb.make_logger(self.run)
        first = self.counters["updates"] == 0 and cfg.train.eval_every
        if (first or self.eval_pending) and not self._periodic_eval():
            self.save_checkpoint()  # a signal stopped the evaluation: it stays pending
            return self.finished_training
        remaining = plan.n_updates - self.counters["updates"]
        if remaining <= 0:
            return True
        n_run = remaining if stop_after is None else min(remaining, stop_after)
        stop_at = self.counters["updates"] + n_run
        collector = rlb.make_collector(self.env, self.actor, cfg.train, n_run * fpb, self.device)
        bar = tqdm(
            total=plan.total_frames,
            initial=self.counters["frames"],
            unit="frame",
            unit_scale=True,
            desc="train",
            disable=not cfg.train.progress,
            mininterval=5.0,
        )
        t_ckpt = t_prev = time.perf_counter()
        try:
            for data in collector:
                t_collected = time.perf_counter()
                done = data["next", "done"].squeeze(-1)
                r_hat_train = None
                # task=vertical scores from the env's measuring window of the swimmers now
                # running (SwimmerEnv.score takes (F, S)): no score of the finished episodes
                # of a batch; its R_hat is the periodic evaluation's alone
                if bool(done.any()) and not self.swimmer_env.task.vertical:
                    r_hat_train = float(self.swimmer_env.score(data["next"])[done].mean())
                lrs = [float(s.get_last_lr()[0]) for s in self.schedulers]
                action = data["action"]  # an int64 index for a discrete action
                action_abs = (action if action.is_floating_point() else action.double()
                              ).abs().mean()
                stats = self.update(data)
                self._stop_if_nonfinite(stats)
                collector.update_policy_weights_()
                t_done = time.perf_counter()
                self.counters["frames"] += fpb
                self.counters["updates"] += 1
                self.counters["wall_s"] += t_done - t_prev
                u, step = self.counters["updates"], self.counters["frames"]
                logs = {f"train/{k}": float(v) for k, v in stats.items()}
                logs.update(
                    {
                        "train/lr_actor": lrs[0],
                        "train/lr_critic": lrs[1],
                        "train/episodes": self.episodes,
                        # NaN (not logged) for a categorical actor, which has no sigma
                        "policy/std": float(policy_std(self.actor).mean()),
                        "policy/abs_action_mean": float(action_abs),
                        "time/collect_s": t_collected - t_prev,
                        "time/update_s": t_done - t_collected,
                        "time/env_frames_per_s": fpb / (t_collected - t_prev),
                        "time/frames_per_s": fpb / (t_done - t_prev),
                    }
                )
                if r_hat_train is not None:
                    logs["train/R_hat"] = self.last_train_r_hat = r_hat_train
                for k, v in logs.items():
                    if math.isfinite(v):
                        self.logger.log_scalar(k, v, step)
                bar.update(fpb)
                every = cfg.train.eval_every
                due = bool(every) and (u % every == 0 or u == plan.n_updates)
                interrupted = due and not self._periodic_eval()  # a signal: checkpoint now
                post = {"upd": u, "fps": f"{logs['time/frames_per_s']:.0f}"}
                if self.last_train_r_hat is not None:
                    post["R_train"] = f"{self.last_train_r_hat:.3f}"
                if self.last_eval is not None:
                    post["R_eval"] = f"{self.last_eval['R_hat_mean']:.3f}"
                bar.set_postfix(post, refresh=False)
                last = (interrupted or u >= stop_at
                        or (preemption is not None and preemption.requested))
                if (
                    last
                    or u % cfg.train.checkpoint_every == 0
                    or time.perf_counter() - t_ckpt >= cfg.train.checkpoint_seconds
                ):
                    self.save_checkpoint()
                    t_ckpt = time.perf_counter()
                t_prev = time.perf_counter()
                if last:
                    break
        finally:
            bar.close()
            collector.shutdown()
        return self.finished_training

    def _stop_if_nonfinite(self, stats: dict[str, torch.Tensor]) -> None:
        """:class:`NonFiniteError` at the first NaN/inf loss term or parameter; the last
        checkpoint (written before this update) is kept as it is."""
        bad = [f"{k}={float(v)}" for k, v in stats.items() if not torch.isfinite(v).all()]
        for net, module in (("actor", self.actor), ("critic", self.critic)):
            bad += [f"{net} parameter {name}" for name, p in module.named_parameters()
                    if not torch.isfinite(p).all()]
        if bad:
            ck = self.run.checkpoint
            kept = f"the last good checkpoint {ck} is kept" if ck.exists() else "no checkpoint"
            raise NonFiniteError(
                f"training stopped at update {self.counters['updates'] + 1}: "
                f"{', '.join(bad[:3])} not finite; {kept} (lower optim.lr_actor / "
                "optim.lr_critic, or check the flow and swimmer parameters)"
            )

    def close(self) -> None:
        if self.logger is not None:
            self.logger.experiment.flush()
            self.logger.experiment.close()
