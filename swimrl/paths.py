"""Locations: the Hydra config directory and the current run directory."""

from __future__ import annotations

from pathlib import Path

#: Top-level ``conf/`` of the repository (the package is installed in editable mode).
CONF_DIR = Path(__file__).resolve().parents[1] / "conf"


def run_dir() -> Path:
    """The Hydra run (or multirun job) output directory."""
    from hydra.core.hydra_config import HydraConfig

    return Path(HydraConfig.get().runtime.output_dir)
