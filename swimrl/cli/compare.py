r"""``swimrl-compare`` and ``swimrl-naive-scan``: several strategies on identical flows.

Outputs in the run directory: ``comparison.json``, ``comparison.md`` and, for a scan of
constant shape factors, ``naive_scan.png`` (``R_hat`` against ``Lambda``).

    swimrl-compare flow.kubo=10                      # naive vs STO
    swimrl-compare flow.kubo=10 'compare.strategies=[naive,sto,policy]' \
        'compare.policies=[pretrained/ku10,outputs/train/my_run]'   # + trained policies
    swimrl-naive-scan flow.kubo=10                   # constant Lambda over [-0.98, 0.98]

An interrupted comparison continues with the same command (the same run directory:
``hydra.run.dir=...``, or the sweep's) plus ``compare.resume=true``:
``comparison.partial.json`` in the run directory holds the flow chunks already done, and a
finished comparison is left as it is (so a relaunched multirun only completes what is
missing). On ``SIGTERM`` or ``SIGUSR1`` (a scheduler's preemption or time-limit warning) the
comparison stops after the chunk in flight, with the partial record written, and exits with
status 75 (:data:`swimrl.runs.jobs.PREEMPTED_EXIT`); one process at a time works in a
run directory (its ``.lock``).
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

from omegaconf import DictConfig

from swimrl.analysis.plots import plot_naive_scan
from swimrl.cli import command, run_dir
from swimrl.config import compare_config
from swimrl.errors import ConfigError
from swimrl.evaluation.compare import CompareConfig, compare
from swimrl.evaluation.rollout import check_eval_memory
from swimrl.runs.jobs import preemption_signals, refuse_if_locked, run_lock
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import refuse_overwrite, write_comparison

log = logging.getLogger(__name__)


def check(cfg: DictConfig, out: Path | None) -> CompareConfig:
    """Parse and check the config; refuse a run directory held by another process, and to
    replace a result or to drop an unfinished one."""
    c = compare_config(cfg)
    if out is not None:
        run = RunLayout(out)
        refuse_if_locked(out)
        refuse_overwrite(run.comparison, c.overwrite or c.resume)
        if run.comparison_partial.exists() and not (c.resume or c.overwrite):
            raise ConfigError(f"compare.resume=false but {run.comparison_partial} holds an "
                              "unfinished comparison: allowed compare.resume=true (continue "
                              "it) or overwrite=true (start again)")
    check_eval_memory(c.setup, len(c.variants) if c.shared_flows else 1)
    return c


def _main(cfg: DictConfig) -> dict:
    out = run_dir()
    run = RunLayout(out)
    with run_lock(out, "swimrl-compare"):
        c = check(cfg, out)  # again, holding the lock
        if c.resume and not c.overwrite and run.comparison.exists():
            log.info("compare.resume=true: %s is complete, nothing to do", run.comparison)
            return json.loads(run.comparison.read_text())
        with preemption_signals() as preemption:
            record = compare(c, run.comparison_partial, preemption)
        print(write_comparison(record, out), flush=True)
        run.comparison_partial.unlink(missing_ok=True)
        plot_naive_scan(record, run.naive_scan_plot)
        log.info("wrote %s", run.comparison)
        return record


@command("compare", check=check)
def main(cfg: DictConfig) -> dict:
    return _main(cfg)


@command("naive_scan", check=check)
def main_naive_scan(cfg: DictConfig) -> dict:
    return _main(cfg)


if __name__ == "__main__":
    main()
