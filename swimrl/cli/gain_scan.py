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
from swimrl.config import eval_config, gain_scan_config
from swimrl.evaluation.records import refuse_overwrite, write_json

log = logging.getLogger(__name__)
RECORD = "gain_scan.json"


def check(cfg: DictConfig, out: Path | None) -> tuple[GainScanConfig, bool]:
    """Parse and check the config; refuse to replace a finished scan (``overwrite``)."""
    c, overwrite = gain_scan_config(cfg), eval_config(cfg).overwrite
    if out is not None:
        refuse_overwrite(out / RECORD, overwrite)
    return c, overwrite


@command("gain_scan", check=check)
def main(cfg: DictConfig) -> list[dict]:
    c, overwrite = check(cfg, run_dir())
    rows = gain_scan(c)
    table = markdown(rows)
    target = write_json({"policy": c.policy, "gains": list(c.gains), "rows": rows},
                        run_dir() / RECORD, overwrite=overwrite)
    (run_dir() / "gain_scan.md").write_text(table + "\n")
    print(table)
    log.info("wrote %s", target)
    return rows


if __name__ == "__main__":
    main()
