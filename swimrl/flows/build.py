r"""The factory that builds ``n_flows`` realisations of any registered flow
(:mod:`swimrl.flows.registry`), the specs of the paper's three flows as one type, and the
memory the realisations hold.

Each flow's spec and builder live with the flow: ``flow=stochastic`` in
:mod:`swimrl.flows.stochastic`, ``flow=dns_replay`` and ``flow=dns`` in
:mod:`swimrl.flows.dns.flow`, ``flow=stochastic3d`` in :mod:`swimrl.flows.stochastic3d`, the
analytic flows in :mod:`swimrl.flows.analytic`.
"""

from __future__ import annotations

import torch

from swimrl.flows.dns.flow import LiveDNSSpec, StoredRunSpec
from swimrl.flows.registry import flow_entry, flow_names
from swimrl.flows.stochastic import StochasticSpec

#: The paper's flow specs; any registered flow's spec is accepted where a spec is
#: (:mod:`swimrl.flows.registry`).
FlowSpec = StochasticSpec | StoredRunSpec | LiveDNSSpec

#: Work memory a flow may use beyond its basis table while drawing or decoding (the stochastic
#: synthesis works on at most 2^22 float64 nodes at a time; a snapshot decode on a few grids).
FLOW_WORK_BYTES = 2**29


def flow_table_bytes(spec, n_flows: int, dtype: torch.dtype, interval: float) -> int:
    r"""Bytes ``n_flows`` realisations of ``spec`` hold (the flow entry's ``table_bytes``;
    0 for a flow that declares none); ``interval`` is $T_u$ in units of $\tau_K$."""
    entry = flow_entry(spec.name)
    return 0 if entry.table_bytes is None else entry.table_bytes(spec, n_flows, dtype, interval)


def build_flow(
    spec,
    n_flows: int,
    device: torch.device,
    dtype: torch.dtype,
    generator: torch.Generator,
    interval: float,
    duration: float,
):
    r"""``n_flows`` realisations of ``spec``, by its registered builder
    (:mod:`swimrl.flows.registry`).

    Parameters
    ----------
    spec
        The flow: :class:`~swimrl.flows.stochastic.StochasticSpec`,
        :class:`~swimrl.flows.dns.flow.StoredRunSpec`,
        :class:`~swimrl.flows.dns.flow.LiveDNSSpec` or any registered flow's spec.
    n_flows
        Independent realisations (the environment's first batch dimension).
    device, dtype
        Where and in which precision the fields are kept.
    generator
        The random generator of the realisations.
    interval, duration
        $T_u$ and $T$ in units of $\tau_K$ (used by the replayed flows).

    Returns
    -------
    GriddedFlow or PointFlow
        The flow (:class:`~swimrl.flows.stochastic.StochasticFlow`,
        :class:`~swimrl.flows.replay.ReplayFlow`, a
        :class:`~swimrl.flows.pointwise.PointFlow`, ...), its realisations drawn.
    """
    return flow_entry(spec.name).build(spec, n_flows, device, dtype, generator, interval,
                                       duration)


def __getattr__(name: str):
    """``FLOWS``: the registered flows' names (:func:`~swimrl.flows.registry.flow_names`)."""
    if name == "FLOWS":
        return flow_names()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
