"""Command-line mains: one thin Hydra (or argparse) main per ``swimrl-*`` command.

Each main parses its config once into typed objects (:mod:`swimrl.config`) and calls library
functions. Bad input (:class:`~swimrl.errors.ConfigError`, a missing file, a result that
would be overwritten) is printed as one line and exits with status 2;
``HYDRA_FULL_ERROR=1`` shows the traceback instead.
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from swimrl.errors import ConfigError

#: The configs shipped with the package (the repository's top-level ``conf/``).
CONFIG_PATH = "pkg://swimrl.conf"
USAGE_ERRORS = (ConfigError, FileExistsError, FileNotFoundError)


def run_dir() -> Path:
    """The Hydra run (or multirun job) output directory."""
    return Path(HydraConfig.get().runtime.output_dir)


def one_line_errors(task: Callable) -> Callable:
    """Print a usage error as ``error: MESSAGE`` and exit with status 2."""

    @functools.wraps(task)
    def wrapped(*args, **kwargs):
        try:
            return task(*args, **kwargs)
        except USAGE_ERRORS as err:
            if os.environ.get("HYDRA_FULL_ERROR") == "1":
                raise
            print(f"error: {err}", file=sys.stderr)
            sys.exit(2)

    return wrapped


def command(config_name: str) -> Callable[[Callable[[DictConfig], object]], Callable]:
    """``@hydra.main`` on the shipped configs, with :func:`one_line_errors`."""

    def decorate(task: Callable[[DictConfig], object]) -> Callable:
        return hydra.main(config_path=CONFIG_PATH, config_name=config_name,
                          version_base="1.3")(one_line_errors(task))

    return decorate
