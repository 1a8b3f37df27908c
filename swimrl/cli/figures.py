r"""``swimrl-figures``: the paper's figures into ``docs/figures/`` (:mod:`swimrl.paper`).

    swimrl-figures                         # all, from the records in docs/results/figures/
    swimrl-figures only=kuInf              # one figure
    swimrl-figures only=robustness figures.refresh=[robustness]   # remake its record

Every number a figure draws comes from its record ``<records>/<figure>.json`` (made, where it
is missing, from the evaluations cached under ``outputs/figures_cache``); a record made for
other sizes, seeds or policy files is refused in one line (exit status 2) that says how to
remake it.
"""

from __future__ import annotations

from pathlib import Path

from omegaconf import DictConfig

from swimrl.cli import command
from swimrl.paper.build import build_figures
from swimrl.paper.config import figures_config
from swimrl.paper.settings import FiguresConfig


def check(cfg: DictConfig, out: Path | None) -> FiguresConfig:
    """Parse and check the config."""
    return figures_config(cfg)


@command("figures", check=check)
def main(cfg: DictConfig) -> dict:
    c = check(cfg, None)
    c.runtime.apply()
    return build_figures(c)


if __name__ == "__main__":
    main()
