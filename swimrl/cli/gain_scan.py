r"""``swimrl-gain-scan``: R_hat of ``Lambda_max tanh(g mu(s))`` against the gain ``g``.

    swimrl-gain-scan policy=pretrained/ku10 flow.kubo=10 'gains=[1,2,3,5,10]'

A diagnostic of how soft a trained policy's mean is (:mod:`swimrl.analysis.gain_scan`).
Prints the table and writes it to the run directory: ``gain_scan.json`` (the policy, the
gains and, per gain, ``R_hat`` mean, SEM and per-flow values) and ``gain_scan.md``.
"""

from __future__ import annotations

import logging
from pathlib import Path

from omegaconf import DictConfig

from swimrl.analysis.gain_scan import GainScanConfig, gain_scan, markdown
from swimrl.cli import command, run_dir
from swimrl.config import gain_scan_config
from swimrl.runs.atomic import atomic_write_text
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import refuse_overwrite, write_json

log = logging.getLogger(__name__)


def check(cfg: DictConfig, out: Path | None) -> GainScanConfig:
    """Parse and check the config; refuse to replace a scan's record or table unless
    ``overwrite``."""
    c = gain_scan_config(cfg)
    if out is not None:
        run = RunLayout(out)
        for path in (run.gain_scan, run.gain_scan_table):
            refuse_overwrite(path, c.overwrite)
    return c


@command("gain_scan", check=check)
def main(cfg: DictConfig) -> list[dict]:
    out = run_dir()
    run = RunLayout(out)
    c = check(cfg, out)
    rows = gain_scan(c)
    table = markdown(rows)
    print(table)
    atomic_write_text(run.gain_scan_table, table)
    record = {"policy": c.policy, "gains": list(c.gains), "rows": rows, "config": c.setup.record}
    target = write_json(record, run.gain_scan, overwrite=c.overwrite)  # last: marks it finished
    log.info("wrote %s", target)
    return rows


if __name__ == "__main__":
    main()
