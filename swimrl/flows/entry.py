r"""What a flow declares to the registry (:mod:`swimrl.flows.registry`): its :class:`FlowEntry`.

Each flow module defines its entry next to the flow, its spec and its builder
(``STOCHASTIC_ENTRY`` in :mod:`swimrl.flows.stochastic`, ``<NAME>_ENTRY`` for ``flow=<name>``);
the registry's table maps each name to it. This module imports no flow, so that the flow
modules and the registry both import it without a cycle.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

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
