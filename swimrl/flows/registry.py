r"""Flows by name: the registry behind ``flow=<name>``.

A flow is one module (``swimrl/flows/<name>.py`` or ``swimrl/flows/<name>/``) holding the
flow, the frozen dataclass of its ``flow.*`` keys, its builder and its
:class:`~swimrl.flows.entry.FlowEntry` (``<NAME>_ENTRY``), and one ``conf/flow/<name>.yaml``
holding every key of that dataclass. :data:`BUILTIN_FLOWS` is the one table of swimrl's flows,
``flow=<name>`` -> its entry, imported from the flow's module; :func:`register_flow` adds a
flow defined outside the package (a recipe's module, imported by a Hydra callback).
:func:`flow_entry` returns the entry; :func:`~swimrl.flows.build.build_flow` and the config
mapping (:func:`swimrl.config.flow_spec`) only look entries up. The entry's ``spec`` checks
its values on construction (one :class:`~swimrl.errors.ConfigError` naming the ``flow.*``
key).
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from swimrl.errors import one_of
from swimrl.flows.analytic import ABC_ENTRY, LINEAR_ENTRY, TAYLOR_GREEN_ENTRY
from swimrl.flows.dns.flow import DNS_ENTRY, DNS_REPLAY_ENTRY
from swimrl.flows.entry import POINT_KERNELS, FlowEntry
from swimrl.flows.stochastic import STOCHASTIC_ENTRY
from swimrl.flows.stochastic3d import STOCHASTIC3D_ENTRY

# POINT_KERNELS is defined in swimrl.flows.entry; swimrl.env reads it from here.
__all__ = ["BUILTIN_FLOWS", "POINT_KERNELS", "flow_dimension", "flow_entry", "flow_names",
           "register_flow"]

BUILTIN_FLOWS: Mapping[str, FlowEntry] = MappingProxyType({
    "stochastic": STOCHASTIC_ENTRY,
    "dns_replay": DNS_REPLAY_ENTRY,
    "dns": DNS_ENTRY,
    "stochastic3d": STOCHASTIC3D_ENTRY,
    "linear": LINEAR_ENTRY,
    "abc": ABC_ENTRY,
    "taylor_green": TAYLOR_GREEN_ENTRY,
})
"""swimrl's flows: ``flow=<name>`` (``conf/flow/<name>.yaml``) -> its entry, defined with the
flow in ``swimrl/flows/<name>.py`` (the DNS flows in ``swimrl/flows/dns/flow.py``, the
analytic flows together in ``swimrl/flows/analytic.py``)."""

_ENTRIES: dict[str, FlowEntry] = {}


def register_flow(entry: FlowEntry) -> FlowEntry:
    """Add ``entry`` (a second entry of the same name replaces the first); returns it.

    swimrl's own flows are those of :data:`BUILTIN_FLOWS`; this is for a flow defined
    outside the package (``examples/recipes/oscillating_cells.py``)."""
    if not callable(entry.dimension) and entry.dimension not in (2, 3):
        raise ValueError(f"flow {entry.name!r}: dimension {entry.dimension} is not 2 or 3")
    _ENTRIES[entry.name] = entry
    return entry


def _register_builtin() -> None:
    for name, entry in BUILTIN_FLOWS.items():
        if entry.name != name:
            raise ValueError(f"flow {name!r}: its entry is named {entry.name!r}")
        register_flow(entry)


_register_builtin()


def flow_names() -> tuple[str, ...]:
    """The registered flows' names, sorted."""
    return tuple(sorted(_ENTRIES))


def flow_entry(name: str) -> FlowEntry:
    """The entry of ``flow=<name>``; an unknown name is a ConfigError naming ``flow.name``."""
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
