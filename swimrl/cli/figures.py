r"""``swimrl-figures``: the paper's figures into ``docs/figures/`` (:mod:`swimrl.analysis.figures`).

    swimrl-figures                         # all, evaluations cached under outputs/figures_cache
    swimrl-figures only=kuInf              # one figure
    swimrl-figures figures.n_swimmers=200  # smaller records (sizes go into the titles)
"""

from __future__ import annotations

from pathlib import Path

from omegaconf import DictConfig

from swimrl.analysis.figures.build import build_figures
from swimrl.analysis.figures.records import FiguresConfig
from swimrl.cli import command
from swimrl.config import figures_config


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
