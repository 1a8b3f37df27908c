r"""A training run in a directory: fresh start, resume, final evaluation, ``metrics.json``.

Rules for the run directory (checked before any compute):

* one process at a time: a run holds the directory's lock
  (:func:`~swimrl.runs.jobs.run_lock`), taken before the rules below are checked again;
  a second process is refused (one line naming the holder's PID);
* ``metrics.json`` exists (the run finished): error unless ``overwrite=true``, which deletes
  the run's outputs (``checkpoints/``, ``policy.pt``, ``metrics.json``, ``tb/``) and trains
  from scratch;
  ``resume=true`` on a finished run prints "already finished" and does nothing (exit 0);
* ``checkpoints/last.pt`` exists: error unless ``resume=true`` (continue) or
  ``overwrite=true`` (start again). ``resume=true`` without a checkpoint starts fresh, so a
  sweep can always be (re)launched with ``resume=true``: finished jobs are skipped, killed
  ones continue, missing ones start;
* a resumed run must have the same config as the checkpoint (whose renamed keys are first
  moved to their current names, :func:`~swimrl.runs.checkpoint.upgrade_config`), except for
  the runtime keys in :data:`RESUME_FREE_KEYS`, the ``eval.*`` / periodic evaluation
  sizes and, for a constant-rate run (``optim.anneal=none``), a larger
  ``train.total_frames`` (the run continues to the larger budget; to extend a finished run,
  copy its directory without ``metrics.json`` and ``policy.pt`` and resume the copy).
"""

from __future__ import annotations

import logging
import shutil
from dataclasses import replace
from pathlib import Path

from swimrl.errors import ConfigError
from swimrl.evaluation.compare import CompareConfig, compare, strategy_variants
from swimrl.rl.plan import TrainConfig, TrainPlan, TrainSettings, check_train_memory, make_plan
from swimrl.rl.trainer import PPOTrainer
from swimrl.runs.checkpoint import load_checkpoint, upgrade_config
from swimrl.runs.jobs import (
    EvaluationInterruptedError,
    preemption_signals,
    refuse_if_locked,
    run_lock,
)
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import flatten, summary_line, write_comparison, write_json
from swimrl.runtime import Runtime, runtime_keys

log = logging.getLogger(__name__)

#: Keys that may differ between a checkpoint and the config resuming it: the fields marked
#: :data:`~swimrl.runtime.RUNTIME` (device, threads, kernel, resume, overwrite, and the
#: ``train.*`` keys of speed, output and cadence), and ``policy`` (a key of
#: ``conf/evaluate.yaml`` that ``swimrl-train`` does not read).
RESUME_FREE_KEYS = (runtime_keys(Runtime) | runtime_keys(TrainConfig)
                    | runtime_keys(TrainSettings, "train.") | {"policy"})
RESUME_FREE_PREFIXES = ("eval.", "eval_flow.", "hydra.")


def config_differences(old: dict, new: dict) -> list[str]:
    """``key: old -> new`` for the keys that matter to the training trajectory.

    ``train.total_frames`` may grow when both configs keep the rates constant
    (``optim.anneal=none``): no schedule depends on the budget then, so the frames already
    trained are those of the longer run, and a run is continued to a larger budget."""
    a, b = flatten(old), flatten(new)
    extendable = (a.get("optim.anneal") == b.get("optim.anneal") == "none"
                  and b.get("train.total_frames", 0) >= a.get("train.total_frames", 0))
    diffs = []
    for key in sorted(set(a) | set(b)):
        if key in RESUME_FREE_KEYS or key.startswith(RESUME_FREE_PREFIXES):
            continue
        if key == "train.total_frames" and extendable:
            continue
        if a.get(key, "<missing>") != b.get(key, "<missing>"):
            diffs.append(f"{key}: {a.get(key, '<missing>')!r} -> {b.get(key, '<missing>')!r}")
    return diffs


def clean_run_dir(out: Path) -> None:
    """Delete the outputs of a previous run in ``out`` (``overwrite=true``):
    :attr:`~swimrl.runs.layout.RunLayout.training_outputs`."""
    for path in RunLayout(out).training_outputs:
        if path.is_dir():
            shutil.rmtree(path)
        else:
            path.unlink(missing_ok=True)


def run_dir_state(cfg: TrainConfig, out: Path) -> str:
    """What a run in ``out`` does under the run-directory rules, without touching ``out``:
    ``"fresh"``, ``"resume"``, ``"finished"`` (``resume=true`` on a finished run: nothing to
    do) or ``"overwrite"``; raises ``FileExistsError`` for a refused rerun."""
    run = RunLayout(out)
    metrics, ckpt = run.metrics, run.checkpoint
    if cfg.overwrite:
        return "overwrite"
    if metrics.exists():
        if cfg.resume:
            return "finished"
        raise FileExistsError(
            f"{metrics} exists: this run is finished; pass overwrite=true to train it again "
            "from scratch (resume=true does nothing on a finished run)"
        )
    if ckpt.exists() and not cfg.resume:
        raise FileExistsError(
            f"{ckpt} exists: pass resume=true to continue this run, or overwrite=true to "
            "start it again"
        )
    return "resume" if ckpt.exists() else "fresh"


def check_run(cfg: TrainConfig, out: Path | None) -> str | None:
    """Everything checked before any compute (the config's values were checked when ``cfg``
    was made): that the run fits the machine's memory
    (:func:`~swimrl.rl.plan.check_train_memory`) and, for a known run directory ``out``, that
    no other process holds it (:func:`~swimrl.runs.jobs.refuse_if_locked`) and the
    run-directory rules (:func:`run_dir_state`)."""
    check_train_memory(cfg)
    if out is None:
        return None
    refuse_if_locked(Path(out))
    return run_dir_state(cfg, Path(out))


def train(cfg: TrainConfig, out: Path) -> dict | None:
    """Train (or resume) in ``out``, holding its lock (:func:`~swimrl.runs.jobs.run_lock`)
    throughout; returns the final metrics, or None if stopped early or already finished.

    A preemption signal (:func:`~swimrl.runs.jobs.preemption_signals`) during the
    updates stops the run after the update in flight (or inside an evaluation, before its next
    decision) with a checkpoint and raises :class:`~swimrl.runs.jobs.Preempted` (exit
    status :data:`~swimrl.runs.jobs.PREEMPTED_EXIT`); ``resume=true`` then continues
    with the evaluation that was stopped (periodic or final).

    Parameters
    ----------
    cfg
        The checked training config (:func:`swimrl.config.train_config`).
    out
        The run directory: ``policy.pt``, ``metrics.json``, ``curves.csv``, ``tb/``,
        ``checkpoints/``, ``policies/`` (:class:`~swimrl.runs.layout.RunLayout`).

    Returns
    -------
    dict or None
        The final evaluation's metrics (``R_hat_mean``, ``R_hat_sem``, ``per_flow``, ...,
        ``training``: counters and speeds), as written to ``metrics.json``; None when the run
        stopped early (``train.stop_after_updates``) or had already finished.

    Raises
    ------
    ConfigError
        A config that differs from the checkpoint's on ``resume=true`` (one line per key).
    Preempted
        A preemption signal (exit status 75), after the checkpoint is written.
    """
    out = Path(out)
    plan = make_plan(cfg)
    cfg.runtime.apply()
    with run_lock(out, "swimrl-train"):
        return _train_locked(cfg, plan, out)


def _train_locked(cfg: TrainConfig, plan: TrainPlan, out: Path) -> dict | None:
    run = RunLayout(out)
    state = run_dir_state(cfg, out)
    if state == "finished":
        print(f"{out}: already finished (metrics.json exists); nothing to do", flush=True)
        return None
    if state == "overwrite":
        clean_run_dir(out)
    resuming = state == "resume"
    if resuming:
        ckpt, state = load_checkpoint(out)
        diffs = config_differences(upgrade_config(state["config"]), cfg.record)
        if diffs:
            raise ConfigError(
                f"resume=true with a config that differs from {ckpt}: " + "; ".join(diffs)
            )
    out.mkdir(parents=True, exist_ok=True)
    trainer = PPOTrainer(cfg, plan, out, state=state if resuming else None)
    if resuming:
        log.info(
            "resumed %s at update %d/%d (%d frames)",
            out,
            trainer.counters["updates"],
            plan.n_updates,
            trainer.counters["frames"],
        )
    t = cfg.train
    log.info(
        "PPO: %d updates x %d frames (%d flows x %d swimmers x %d decisions), %d epochs x %d "
        "minibatches of %d; Adam %.3g / %.3g; reward scale %.4g; %.1f episodes of %d swimmers",
        plan.n_updates,
        t.frames_per_batch,
        t.n_flows,
        t.n_swimmers,
        plan.rollout_steps,
        t.epochs,
        plan.minibatches_per_epoch,
        t.minibatch_size,
        plan.lr_actor,
        plan.lr_critic,
        trainer.reward_scale,
        plan.total_frames / plan.frames_per_episode,
        t.n_swimmers,
    )
    with preemption_signals() as preemption:
        try:
            finished = trainer.train(cfg.train.stop_after_updates, preemption)
        finally:
            trainer.close()  # the TensorBoard logger: training is over
        u, frames = trainer.counters["updates"], trainer.counters["frames"]
        if preemption.requested:
            where = "during the periodic evaluation " if trainer.eval_pending else ""
            preemption.stop(f"{where}after update {u}/{plan.n_updates} ({frames} frames): "
                            f"checkpoint written to {run.checkpoint}; continue with "
                            "resume=true")
        if not finished:
            log.info("stopped after update %d/%d; continue with resume=true", u,
                     plan.n_updates)
            return None
        trainer.save_policy()
        try:
            metrics = trainer.evaluate(cfg.held_out)
        except EvaluationInterruptedError:
            preemption.stop(f"during the final evaluation (training finished, {frames} "
                            f"frames; checkpoint {run.checkpoint}): continue with "
                            "resume=true, which makes the final evaluation")
    metrics["policy"] = str(out)
    metrics["training"] = {
        **trainer.counters,
        "episodes": trainer.episodes,
        "n_updates": plan.n_updates,
        "frames_per_s": trainer.counters["frames"] / max(trainer.counters["wall_s"], 1e-9),
        "reward_scale": trainer.reward_scale,
        "eval_seed": plan.eval_seed,
        "train_seed": plan.train_seed,
    }
    write_json(metrics, run.metrics, overwrite=cfg.overwrite)
    print(summary_line(metrics), flush=True)
    if cfg.train.compare_baselines:
        compare_with_baselines(cfg, out, plan.eval_seed)
    return metrics


def compare_with_baselines(cfg: TrainConfig, out: Path, seed: int) -> dict:
    """STO, naive (``Lambda = 0.98``) and the trained policy on the same held-out flows.

    Exactly ``swimrl-compare 'compare.strategies=[sto,naive,policy]' compare.policies=[out]
    seed=<eval seed>`` with the run's final-evaluation sizes; writes ``comparison.json`` and
    ``comparison.md`` into the run directory and prints the table (ratios to STO, paired).
    Where the action steers (``actuation=steer``, ``shape_steer``) there is no STO: naive
    (the gyrotactic swimmer steering up) and the policy, ratios to naive.
    """
    baselines = ["naive"] if cfg.params.actuation.steers else ["sto", "naive"]
    settings = {"strategies": [*baselines, "policy"], "naive_shape_factors": [0.98],
                "policies": [str(out)], "minimal": {"c1": 1.0, "c2": 0.0, "c3": 0.0, "c4": 0.0}}
    record = {**cfg.record, "seed": int(seed), "compare": settings}
    setup = replace(cfg.held_out, seed=int(seed), record=record)
    variants = strategy_variants(settings["strategies"], settings["naive_shape_factors"],
                                 tuple(settings["minimal"].values()), settings["policies"])
    result = compare(CompareConfig(setup, variants))
    print(write_comparison(result, Path(out)), flush=True)
    return result
