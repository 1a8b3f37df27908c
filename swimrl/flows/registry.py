r"""Flows by name: the registry behind ``flow=<name>``.

A flow is one module of :mod:`swimrl.flows` that calls :func:`register_flow` with a
:class:`FlowEntry` (its config name, the frozen dataclass of its ``flow.*`` keys, the
function that builds ``n_flows`` realisations, its dimension) and one
``conf/flow/<name>.yaml`` holding every key of that dataclass. :func:`flow_entry` imports
every module of the package once (so a new module is found without an edit elsewhere) and
returns the entry; :func:`~swimrl.flows.build.build_flow` and the config mapping
(:func:`swimrl.config.flow_spec`) only look entries up. The entry's ``spec`` checks its
values on construction (one :class:`~swimrl.errors.ConfigError` naming the ``flow.*`` key).
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from swimrl.errors import one_of

#: ``build(spec, n_flows, device, dtype, generator, interval, duration) -> flow``, with
#: ``interval`` and ``duration`` ``T_u`` and ``T`` in units of ``tau_K``.
Builder = Callable[..., Any]
#: ``given(node, device, dtype) -> {field: value}``: the spec fields made from several keys
#: (or renamed), from the ``flow`` node as plain containers.
Given = Callable[[Mapping, Any, Any], dict]
#: The kernels of a flow evaluated at points (:class:`~swimrl.env.PointSwimmerEnv`).
POINT_KERNELS = ("auto", "eager", "compiled")
#: ``table_bytes(spec, n_flows, dtype, interval) -> bytes`` the realisations hold.
TableBytes = Callable[..., int]


@dataclass(frozen=True)
class FlowEntry:
    """One flow of the registry.

    Parameters
    ----------
    name
        ``flow=<name>``, also the spec's ``name`` field and the yaml's ``name`` key.
    spec
        The frozen dataclass of the ``flow.*`` keys (checked on construction).
    build
        Builds ``n_flows`` realisations of a spec (:data:`Builder`).
    dimension
        2 (the plane, gridded or point flows) or 3; or a function of the spec (or of the
        ``flow`` node as a mapping) for a flow of either (``flow=linear``).
    given
        Spec fields not read by name from ``flow.*`` (:data:`Given`; None: all are).
    table_bytes
        Memory the realisations hold (:data:`TableBytes`; None: negligible, 0).
    kernels
        The ``kernel`` values the flow runs with (None: all; a point flow: ``auto``,
        ``eager``, ``compiled``).
    """

    name: str
    spec: type
    build: Builder
    dimension: int | Callable[[Any], int]
    given: Given | None = None
    table_bytes: TableBytes | None = None
    kernels: tuple[str, ...] | None = None


_ENTRIES: dict[str, FlowEntry] = {}
_DISCOVERED = False


def register_flow(entry: FlowEntry) -> FlowEntry:
    """Add ``entry`` (a second entry of the same name replaces the first); returns it."""
    if not callable(entry.dimension) and entry.dimension not in (2, 3):
        raise ValueError(f"flow {entry.name!r}: dimension {entry.dimension} is not 2 or 3")
    _ENTRIES[entry.name] = entry
    return entry


def _discover() -> None:
    """Import every module of :mod:`swimrl.flows` once (each registers its flows)."""
    global _DISCOVERED
    if _DISCOVERED:
        return
    _DISCOVERED = True
    package = importlib.import_module("swimrl.flows")
    for info in pkgutil.iter_modules(package.__path__):
        if not info.name.startswith("_"):
            importlib.import_module(f"swimrl.flows.{info.name}")


def flow_names() -> tuple[str, ...]:
    """The registered flows' names, sorted."""
    _discover()
    return tuple(sorted(_ENTRIES))


def flow_entry(name: str) -> FlowEntry:
    """The entry of ``flow=<name>``; an unknown name is a ConfigError naming ``flow.name``."""
    _discover()
    one_of("flow.name", name, flow_names())
    return _ENTRIES[name]


def flow_dimension(flow) -> int:
    """2 or 3: the dimension of a flow spec, of a ``flow`` node (a mapping with ``name``) or
    of the flow named ``flow`` (whose dimension must not depend on its keys)."""
    if isinstance(flow, str):
        name = flow
    elif isinstance(flow, Mapping):
        name = str(flow["name"])
    else:
        name = flow.name
    dim = flow_entry(name).dimension
    if callable(dim):
        if isinstance(flow, str):
            raise ValueError(f"flow {name!r}: the dimension depends on its keys")
        return int(dim(flow))
    return dim
