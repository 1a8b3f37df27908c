r"""``swimrl-eval``: a strategy on fresh flow realisations -> ``metrics.json``.

    swimrl-eval strategy=sto flow.kubo=10 eval.n_flows=10 eval.n_swimmers=200
    swimrl-eval strategy=policy policy=pretrained/ku10 flow.kubo=10
"""

from __future__ import annotations

import logging
from pathlib import Path

from omegaconf import DictConfig

from swimrl.cli import command, run_dir
from swimrl.config import eval_config
from swimrl.evaluation.records import refuse_overwrite, summary_line, write_json
from swimrl.evaluation.rollout import Actor, EvalConfig, actor_for, evaluate

log = logging.getLogger(__name__)


def check(cfg: DictConfig, out: Path | None) -> tuple[EvalConfig, Actor]:
    """Parse and check the config, refuse to replace a result, load the actor."""
    c = eval_config(cfg)
    if out is not None:
        refuse_overwrite(out / "metrics.json", c.overwrite)
    return c, actor_for(c.strategy, c.policy, c.setup.params)


@command("evaluate", check=check)
def main(cfg: DictConfig) -> dict:
    target = run_dir() / "metrics.json"
    c, actor = check(cfg, run_dir())
    metrics = evaluate(c.setup, actor, c.strategy.name)
    write_json(metrics, target, c.overwrite)
    print(summary_line(metrics))
    log.info("wrote %s", target)
    return metrics


if __name__ == "__main__":
    main()
