"""``swimrl-figures``: every figure's builder (:data:`BUILDERS`) and :func:`build_figures`."""

from __future__ import annotations

import time
from collections.abc import Callable

from .ablation import build_ablation
from .beyond_energy import build_beyond_energy
from .beyond_paths import build_beyond_target_paths
from .beyond_target import build_beyond_target
from .dns import build_dns_flow
from .mechanism import build_ku01, build_ku_inf, build_ku_pattern
from .robustness import build_robustness, build_robustness_noise
from .seeds import build_seed_spread_figure
from .settings import FiguresConfig
from .stochastic import build_smart_performance, build_swimmer
from .three_d import (
    build_three_d_curves_figure,
    build_three_d_ku_figure,
    build_three_d_maps_figure,
    build_three_d_paths_figure,
)
from .training import build_training_curves
from .videos import build_videos

#: Figure name -> builder, in build order (the names: :data:`.settings.FIGURES`).
BUILDERS: dict[str, Callable[[FiguresConfig], dict]] = {
    "swimmer": build_swimmer,
    "smartPerformance": build_smart_performance,
    "ku0.1": build_ku01,
    "kuInf": build_ku_inf,
    "ku_pattern": build_ku_pattern,
    "trainingCurves": build_training_curves,
    "ablation": build_ablation,
    "robustness-noise": build_robustness_noise,
    "robustness": build_robustness,
    "dnsFlow": build_dns_flow,
    "videos": build_videos,
    "beyondTarget": build_beyond_target,
    "beyondTargetPaths": build_beyond_target_paths,
    "beyondEnergy": build_beyond_energy,
    "threeDKu": build_three_d_ku_figure,
    "threeDPaths": build_three_d_paths_figure,
    "threeDMaps": build_three_d_maps_figure,
    "threeDCurves": build_three_d_curves_figure,
    "seedSpread": build_seed_spread_figure,
}


def build_figures(cfg: FiguresConfig, log: Callable[[str], None] = print) -> dict[str, dict]:
    """Every figure (or ``cfg.only``); returns each builder's data and wall time."""
    names = [cfg.only] if cfg.only else list(BUILDERS)
    out = {}
    for name in names:
        t0 = time.perf_counter()
        out[name] = BUILDERS[name](cfg)
        wall = time.perf_counter() - t0
        out[name]["wall_s"] = wall
        log(f"{name}: {wall:.0f} s" + (f" ({out[name]['pending']})" if "pending" in out[name]
                                       else ""))
    return out
