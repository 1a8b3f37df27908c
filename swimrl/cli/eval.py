r"""``swimrl-eval``: a strategy on fresh flow realisations -> ``metrics.json``.

    swimrl-eval strategy=sto flow.kubo=10 eval.n_flows=10 eval.n_swimmers=200
    swimrl-eval strategy=policy policy=pretrained/ku10 flow.kubo=10
    swimrl-eval strategy=sto eval.record=5    # + trajectories.npz: every decision of 5
                                              #   swimmers per flow

On ``SIGTERM`` or ``SIGUSR1`` it stops before the next decision, writes nothing and exits with
status 75 (:data:`swimrl.runs.jobs.PREEMPTED_EXIT`): the same command runs it again.
"""

from __future__ import annotations

import logging
from pathlib import Path

from omegaconf import DictConfig

from swimrl.cli import command, run_dir
from swimrl.config import eval_config
from swimrl.evaluation.rollout import Actor, EvalConfig, actor_for, check_eval_memory, evaluate
from swimrl.evaluation.trajectories import TrajectoryRecorder, save_trajectories
from swimrl.runs.jobs import (
    EvaluationInterruptedError,
    preemption_signals,
    refuse_if_locked,
    run_lock,
)
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import refuse_overwrite, summary_line, write_json

log = logging.getLogger(__name__)

#: The actor the last check loaded, with what it was loaded from. The check runs twice, from
#: the ``CheckFirst`` callback and again in the main (holding the run directory's lock): the
#: main takes the callback's actor instead of reading the policy file again.
_LOADED: dict[str, object] = {}


def load_actor(c: EvalConfig) -> Actor:
    """The actor of ``c`` (:func:`~swimrl.evaluation.rollout.actor_for`); the one the last
    check loaded when it was for the same strategy, policy and env parameters."""
    key = (c.strategy, c.policy, c.setup.params)
    if _LOADED.get("key") != key:
        _LOADED.clear()
        _LOADED.update(key=key, actor=actor_for(c.strategy, c.policy, c.setup.params))
    return _LOADED["actor"]


def check(cfg: DictConfig, out: Path | None) -> tuple[EvalConfig, Actor]:
    """Parse and check the config, refuse to replace a result, load the actor."""
    c = eval_config(cfg)
    if out is not None:
        refuse_if_locked(out)
        refuse_overwrite(RunLayout(out).metrics, c.overwrite)
    check_eval_memory(c.setup)
    return c, load_actor(c)


@command("evaluate", check=check)
def main(cfg: DictConfig) -> dict:
    run = RunLayout(run_dir())
    target = run.metrics
    with run_lock(run_dir(), "swimrl-eval"):  # one process per run directory
        c, actor = check(cfg, run_dir())
        _LOADED.clear()  # a multirun's next job reads its policy file again
        n_record = c.setup.sizes.record
        recorder = TrajectoryRecorder(n_record) if n_record else None
        with preemption_signals() as preemption:
            try:
                metrics = evaluate(c.setup, actor, c.strategy.name, recorder, preemption)
            except EvaluationInterruptedError as exc:
                preemption.stop(f"after decision {exc.decision} of an episode: nothing "
                                "written; run the same command again")
        if recorder is not None:
            path = save_trajectories(recorder.arrays(), run.trajectories,
                                     [c.strategy.name], c.setup.record)
            log.info("wrote %s", path)
        write_json(metrics, target, c.overwrite)
    print(summary_line(metrics))
    log.info("wrote %s", target)
    return metrics


if __name__ == "__main__":
    main()
