r"""``swimrl-train``: PPO training of the shape-control policy (paper Sec. II C, App. RL).

    swimrl-train flow.kubo=10                                 # default preset (this CPU)
    swimrl-train train_preset=paper flow.kubo=10 seed=1       # paper: 5000 episodes
    swimrl-train hydra.run.dir=outputs/train/ku10 resume=true # continue a killed run
                                                              # (a finished one: no-op)
    swimrl-train -m flow.kubo=0.1,1,10,1e7 seed=0,1,2 hydra/launcher=joblib

Writes into the run directory ``checkpoints/last.pt``, ``policy.pt``, ``tb/`` (TensorBoard)
and, at the end, ``metrics.json`` (held-out deterministic evaluation, as ``swimrl-eval``).
On ``SIGTERM`` or ``SIGUSR1`` (a scheduler's preemption or time-limit warning) it finishes
the update in flight, writes a checkpoint and exits with status 75
(:data:`swimrl.runs.jobs.PREEMPTED_EXIT`): continue with ``resume=true``. One process
at a time trains in a run directory (its ``.lock``); a second one is refused. See
``docs/training.md``.
"""

from __future__ import annotations

from omegaconf import DictConfig

from swimrl.cli import command, run_dir
from swimrl.config import train_config
from swimrl.rl.run import check_run, train


@command("train", check=lambda cfg, out: check_run(train_config(cfg), out))
def main(cfg: DictConfig) -> dict | None:
    return train(train_config(cfg), run_dir())


if __name__ == "__main__":
    main()
