r"""``swimrl-eval``: a strategy on fresh flow realisations -> ``metrics.json``.

    swimrl-eval strategy=sto flow.kubo=10 eval.n_flows=10 eval.n_swimmers=200
    swimrl-eval strategy=policy policy=pretrained/ku10 flow.kubo=10
"""

from __future__ import annotations

import logging

from omegaconf import DictConfig

from swimrl.cli import command, run_dir
from swimrl.config import eval_config
from swimrl.evaluation.records import refuse_overwrite, summary_line, write_json
from swimrl.evaluation.rollout import actor_for, evaluate

log = logging.getLogger(__name__)


@command("evaluate")
def main(cfg: DictConfig) -> dict:
    # Parse and check the config
    c = eval_config(cfg)
    target = run_dir() / "metrics.json"
    refuse_overwrite(target, c.overwrite)
    # Create the actor and evaluate it
    actor = actor_for(c.strategy, c.policy, c.setup.params)
    metrics = evaluate(c.setup, actor, c.strategy.name)
    write_json(metrics, target, c.overwrite)
    print(summary_line(metrics))
    log.info("wrote %s", target)
    return metrics


if __name__ == "__main__":
    main()
