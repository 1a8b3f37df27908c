"""``conf/figures.yaml`` -> :class:`~swimrl.paper.settings.FiguresConfig` (``swimrl-figures``).

The figures' part of the config mapping, kept out of :mod:`swimrl.config` (which the library
commands use) and made with its helpers: :func:`~swimrl.config.from_node`,
:func:`~swimrl.config.runtime`, :func:`~swimrl.config.flow_spec`,
:func:`~swimrl.config.env_params`.
"""

from __future__ import annotations

from pathlib import Path

from omegaconf import DictConfig

from swimrl.config import env_params, flow_spec, from_node, runtime

from .settings import DNSFiguresConfig, FiguresConfig


def figures_config(cfg: DictConfig) -> FiguresConfig:
    """``swimrl-figures`` (``conf/figures.yaml``); paths are taken from the launch directory."""
    from hydra.utils import to_absolute_path

    def path(value) -> Path:
        return Path(to_absolute_path(str(value)))

    rt = runtime(cfg)
    return from_node(
        FiguresConfig, {"figures.": cfg.figures, "": cfg},
        out=path(cfg.out), cache=path(cfg.cache), runtime=rt, flow=flow_spec(cfg.flow, rt),
        params=env_params(cfg), results=path(cfg.results), curves=path(cfg.curves),
        fits=path(cfg.fits), ablation=path(cfg.ablation), records=path(cfg.records),
        beyond=path(cfg.beyond), three_d=path(cfg.three_d),
        three_seeds=path(cfg.three_seeds),
        dns=None if cfg.dns is None else dns_figures_config(cfg.dns, path),
    )


def dns_figures_config(node: DictConfig, path) -> DNSFiguresConfig:
    """``dns.*`` of ``conf/figures.yaml`` (``path``: a path from the launch directory); the
    glyph times go to their check as written (it names them so)."""
    return from_node(
        DNSFiguresConfig, {"dns.": node},
        store=path(node.store), record=path(node.record), transfer=path(node.transfer),
        checks=path(node.checks), curves=tuple(path(c) for c in node.curves or ()),
        glyph_window=node.glyph_window, glyph_every=node.glyph_every,
    )
