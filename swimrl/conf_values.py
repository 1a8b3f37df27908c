"""The library's defaults, read from the yaml shipped with it: one source per value.

A default of a typed config or of a library call's keyword that a config key sets is that
key's value in the yaml (``conf/``, shipped as the package ``swimrl.conf``), read here::

    n_modes: int = yaml_value("flow/stochastic", "n_modes")   # conf/flow/stochastic.yaml

:func:`yaml_value` reads the one file with ``OmegaConf.load``, so a number parses as Hydra
parses it (``1.0e-4`` a float, ``15_360_000`` an int); lists come back as tuples, mappings
as read-only mappings, interpolations unresolved. The file is read alone (its ``defaults``
list is not composed): a key is read from the file that writes it.
``tests/test_config_sources.py`` checks that every default so read is the value the
commands' composed configs give its key. No torch here (``import swimrl`` stays light).
"""

from __future__ import annotations

import functools
from importlib.resources import files
from types import MappingProxyType
from typing import Any

from omegaconf import OmegaConf

#: The package that holds the yaml (the top-level ``conf/`` in the source tree).
CONF_PACKAGE = "swimrl.conf"


@functools.cache
def _read(group_file: str) -> dict:
    """``conf/<group_file>.yaml`` as plain containers, interpolations unresolved."""
    resource = files(CONF_PACKAGE)
    for part in f"{group_file}.yaml".split("/"):
        resource = resource / part
    with resource.open("r", encoding="utf-8") as stream:
        return OmegaConf.to_container(OmegaConf.load(stream), resolve=False)


def _frozen(value: Any) -> Any:
    if isinstance(value, list | tuple):
        return tuple(_frozen(v) for v in value)
    if isinstance(value, dict):
        return MappingProxyType({k: _frozen(v) for k, v in value.items()})
    return value


@functools.cache
def yaml_value(group_file: str, key: str) -> Any:
    """The value of the dotted ``key`` in ``conf/<group_file>.yaml`` (``group_file``
    without ``.yaml``: ``"evaluate"``, ``"flow/stochastic"``); lists as tuples. A key the
    file lacks raises ``KeyError`` naming both."""
    node: Any = _read(group_file)
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            raise KeyError(f"conf/{group_file}.yaml has no key {key!r}")
        node = node[part]
    return _frozen(node)
