"""Command-line mains: one thin Hydra (or argparse) main per ``swimrl-*`` command.

Each main parses its config once into typed objects (:mod:`swimrl.config`) and calls library
functions. Bad input (:class:`~swimrl.errors.ConfigError`, a missing or unreadable file, a
result that would be overwritten) is printed as one line and exits with status 2;
``HYDRA_FULL_ERROR=1`` shows the traceback instead.

A Hydra command is declared with :func:`command`, which also registers the command's
*check*: the part of the main that parses the config and refuses bad input. Hydra creates
the run directory (and writes ``.hydra/``) before it calls the main, so the check runs first,
from the :class:`CheckFirst` callback (``hydra.callbacks`` in ``conf/evaluate.yaml`` and
``conf/dns.yaml``) on the composed config: invalid input leaves no run directory behind.
In a multirun the callback checks the values common to all jobs; a job's own bad value is
still reported in one line, from its job directory.

``hydra.output_subdir`` is ``.hydra`` except in a run directory that already holds a result
and is not being overwritten (:func:`provenance_subdir`): a refused or a no-op rerun leaves a
finished run's recorded config untouched.
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.experimental.callback import Callback
from omegaconf import DictConfig, OmegaConf

from swimrl.errors import BadFileError, ConfigError, IntegrityError, NonFiniteError
from swimrl.runs.layout import RunLayout

#: The configs shipped with the package (the repository's top-level ``conf/``).
CONFIG_PATH = "pkg://swimrl.conf"
USAGE_ERRORS = (ConfigError, BadFileError, FileExistsError, FileNotFoundError)
#: ``check(cfg, out)`` of each Hydra config name; ``out`` is the run directory, or None in a
#: multirun (the job directories are not known yet).
CHECKS: dict[str, Callable[[DictConfig, Path | None], object]] = {}


def writable_dir(path: Path) -> Path:
    """Create the directory ``path`` (with its parents) and check that a file can be written
    in it; :class:`~swimrl.errors.BadFileError` with the system's reason otherwise."""
    path = Path(path)
    probe = path / f".swimrl-write-probe-{os.getpid()}"
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as err:
        raise BadFileError(f"{err.strerror or type(err).__name__}: "
                           f"{err.filename or path}") from err
    return path


def run_dir() -> Path:
    """The Hydra run (or multirun job) output directory."""
    return Path(HydraConfig.get().runtime.output_dir)


def usage_error(err: BaseException, status: int = 2) -> None:
    """Print ``error: MESSAGE`` and exit with ``status`` (re-raise if ``HYDRA_FULL_ERROR=1``)."""
    if os.environ.get("HYDRA_FULL_ERROR") == "1":
        raise err
    print(f"error: {err}", file=sys.stderr)
    sys.exit(status)


def one_line_errors(task: Callable) -> Callable:
    """Print a usage error as ``error: MESSAGE`` and exit with status 2; a non-finite or
    impossible result or corrupt stored data (:class:`~swimrl.errors.NonFiniteError`,
    :class:`~swimrl.errors.IntegrityError`; nothing written) the same way with status 1."""

    @functools.wraps(task)
    def wrapped(*args, **kwargs):
        try:
            return task(*args, **kwargs)
        except USAGE_ERRORS as err:
            usage_error(err)
        except (NonFiniteError, IntegrityError) as err:
            usage_error(err, status=1)

    return wrapped


def provenance_subdir(output_dir: str, overwrite) -> str | None:
    """``hydra.output_subdir``: ``.hydra``, or None (Hydra then writes no config files) when
    ``output_dir`` holds a result (:attr:`~swimrl.runs.layout.RunLayout.results`) and
    ``overwrite`` is not true."""
    finished = any(path.exists() for path in RunLayout(output_dir).results)
    return None if finished and overwrite is not True else ".hydra"


OmegaConf.register_new_resolver("provenance_subdir", provenance_subdir, replace=True)


class CheckFirst(Callback):
    """Hydra callback: the command's check (:data:`CHECKS`) before any directory is made."""

    def on_run_start(self, config: DictConfig, config_name: str | None = None, **kwargs) -> None:
        out = Path(str(config.hydra.run.dir))
        self._check(config, config_name, out)
        self._writable("hydra.run.dir", out)

    def on_multirun_start(self, config: DictConfig, config_name: str | None = None,
                          **kwargs) -> None:
        self._check(config, config_name, None)
        self._writable("hydra.sweep.dir", Path(str(config.hydra.sweep.dir)))

    @staticmethod
    def _writable(key: str, out: Path) -> None:
        """One line, exit 2, unless the run directory ``out`` can be created and written
        (Hydra creates it next; a probe file is written and removed)."""
        try:
            writable_dir(out)
        except BadFileError as err:
            usage_error(ConfigError(f"{key}={str(out)!r} is invalid: allowed a directory "
                                    f"that can be created and written ({err})"))

    @staticmethod
    def _check(config: DictConfig, config_name: str | None, out: Path | None) -> None:
        check = CHECKS.get(str(config_name))
        if check is None:
            return
        HydraConfig.instance().set_config(config)  # for hydra.utils.to_absolute_path
        try:
            check(config, out)
        except USAGE_ERRORS as err:
            usage_error(err)
        except Exception:  # noqa: BLE001 - not bad input: the main reports it, with its traceback
            return


def command(
    config_name: str, check: Callable[[DictConfig, Path | None], object] | None = None
) -> Callable[[Callable[[DictConfig], object]], Callable]:
    """``@hydra.main`` on the shipped configs, with :func:`one_line_errors`; ``check`` (the
    config parsing and refusals of the main) also runs before Hydra makes the run directory."""

    def decorate(task: Callable[[DictConfig], object]) -> Callable:
        if check is not None:
            CHECKS[config_name] = check
        return hydra.main(config_path=CONFIG_PATH, config_name=config_name,
                          version_base="1.3")(one_line_errors(task))

    return decorate
