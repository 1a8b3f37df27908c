r"""``flow=dns_replay`` (runs stored by ``swimrl-dns``) and ``flow=dns`` (a DNS stepped
alongside the swimmers): their specs, builders and the registry's entries
(:mod:`swimrl.flows.registry`).

Both replay snapshots through :class:`~swimrl.flows.replay.ReplayFlow` from a source of
:mod:`swimrl.flows.dns.sources`, interpolated in time over decision intervals $T_u$ and
episodes $T$ given in units of the run's own $\tau_K$. Each spec checks its values on
construction (one :class:`~swimrl.errors.ConfigError` naming the ``flow.*`` key).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import torch

from swimrl.conf_values import yaml_value
from swimrl.errors import as_bool, as_float, as_int, keep_number_types, key_prefix, require
from swimrl.flows.base import GriddedFlow
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.sources import DNSStore, LiveDNS, StoreSet
from swimrl.flows.dns.spinup import SpinupSchedule
from swimrl.flows.dns.store import store_status
from swimrl.flows.entry import FlowEntry
from swimrl.flows.replay import ReplayFlow, window_size


@dataclass(frozen=True)
class StoredRunSpec:
    """``flow=dns_replay``: runs stored by ``swimrl-dns`` at ``paths`` (one or several
    independent realisations), decoded on ``decode_n`` nodes per side (None: the run's
    grid), ``flows_per_start`` flows sharing each drawn (run, start time). The defaults are
    read from ``conf/flow/dns_replay.yaml`` (:mod:`swimrl.conf_values`).

    Parameters
    ----------
    paths
        The zarr stores (``flow.path``), each a finished run of ``swimrl-dns``.
    allow_incomplete
        Replay what an unfinished store holds.
    decode_n
        Nodes per side the stored modes are decoded on (None: the run's grid).
    flows_per_start
        Flows that share each drawn (run, start time).
    name
        The config group's name.
    """

    paths: tuple[Path, ...]
    allow_incomplete: bool = yaml_value("flow/dns_replay", "allow_incomplete")
    decode_n: int | None = yaml_value("flow/dns_replay", "decode_n")
    flows_per_start: int = yaml_value("flow/dns_replay", "flows_per_start")
    name: str = yaml_value("flow/dns_replay", "name")

    def __post_init__(self) -> None:
        as_bool("flow.allow_incomplete", self.allow_incomplete)
        require(len(self.paths) > 0, "flow.path", "[]", "a store path or a list of them")
        require(len(set(self.paths)) == len(self.paths), "flow.path",
                [str(p) for p in self.paths], "distinct stores")
        for path in self.paths:
            status = store_status(path)
            require(status not in (None, "unknown"), "flow.path", str(path),
                    "a DNS store made by swimrl-dns (see docs/dns.md)")
            require(status == "complete" or self.allow_incomplete, "flow.path", str(path),
                    f"a finished DNS store (this one's status is {status!r}: finish it with "
                    "swimrl-dns, or pass flow.allow_incomplete=true to replay what it holds)")
        if self.decode_n is not None:
            n = as_int("flow.decode_n", self.decode_n, low=8)
            require(n % 2 == 0, "flow.decode_n", n, "null or an even integer >= 8")
        as_int("flow.flows_per_start", self.flows_per_start, low=1)
        keep_number_types(self)

    @property
    def path(self) -> Path:
        """The first store."""
        return self.paths[0]


@dataclass(frozen=True)
class LiveDNSSpec:
    r"""``flow=dns``: one DNS realisation per flow, spun up, then stepped with the swimmers.

    Parameters
    ----------
    dns
        The solver's parameters (``conf/solver/dns.yaml``).
    spinup_time, measure_time
        The spin-up from rest and its final part over which $u_\mathrm{rms}$ and $\tau_K$ are
        measured (code time units).
    interval_tau_k
        The interval between the snapshots the swimmers see, in units of $\tau_K$.
    name
        The config group's name.
    """

    dns: DNSParams
    spinup_time: float
    measure_time: float
    interval_tau_k: float
    name: str = yaml_value("flow/dns", "name")

    def __post_init__(self) -> None:
        for key in ("spinup_time", "interval_tau_k"):
            as_float(f"flow.{key_name(key)}", getattr(self, key), lambda v: v > 0, "> 0")
        as_float("flow.spinup.measure_time", self.measure_time,
                 lambda v: 0 < v <= self.spinup_time,
                 f"in (0, flow.spinup.time={self.spinup_time}]")
        keep_number_types(self)

    @property
    def spinup(self) -> SpinupSchedule:
        """Step counts of the spin-up."""
        return SpinupSchedule.from_times(self.spinup_time, self.measure_time, self.dns.dt)


def key_name(field: str) -> str:
    """Config key of a :class:`LiveDNSSpec` field."""
    return {"spinup_time": "spinup.time", "measure_time": "spinup.measure_time"}.get(field, field)


def live_dns_params(solver: dict, device: torch.device, dtype: torch.dtype) -> DNSParams:
    """Solver parameters of ``flow.dns`` on the run's ``device`` and ``dtype``."""
    with key_prefix("flow."):
        return DNSParams.from_mapping(
            {**solver, "device": str(device), "dtype": str(dtype).replace("torch.", "")}
        )


def _live_dns_bytes(spec: LiveDNSSpec, n_flows: int, dtype: torch.dtype,
                    interval: float) -> int:
    """A decoded-snapshot cache of ``M + 1`` snapshots and the solver state (``~12 n^2``
    complex128) per live DNS."""
    size = torch.empty((), dtype=dtype).element_size()
    n = spec.dns.n
    window = window_size(interval, spec.interval_tau_k)
    return n_flows * n * n * (window * 5 * size + 12 * 16)


def _stored_bytes(spec: StoredRunSpec, n_flows: int, dtype: torch.dtype,
                  interval: float) -> int:
    """A decoded-snapshot cache of ``M + 1`` snapshots per basis row of a replay."""
    size = torch.empty((), dtype=dtype).element_size()
    store = DNSStore(Path(spec.path), decode_n=spec.decode_n)
    window = window_size(interval * store.tau_k, store.dt_store)
    rows = -(-n_flows // spec.flows_per_start)
    return (rows + 1) * store.n**2 * window * 5 * size + store.n**2 * 5 * size


def _build_replay(spec: StoredRunSpec | LiveDNSSpec, n_flows, device, dtype, generator,
                  interval, duration) -> GriddedFlow:
    common = {"device": device, "dtype": dtype, "generator": generator}
    if isinstance(spec, LiveDNSSpec):
        seeds = torch.randint(0, 2**31 - 1, (n_flows,), generator=generator, device=device)
        source = LiveDNS(
            spec.dns, [int(x) for x in seeds.tolist()], spec.spinup, spec.interval_tau_k
        )
        per_start = 1
    else:
        stores = [DNSStore(Path(p), decode_n=spec.decode_n) for p in spec.paths]
        source = stores[0] if len(stores) == 1 else StoreSet(stores)
        per_start = spec.flows_per_start
    tau_k = source.tau_k
    return ReplayFlow(source, n_flows, interval * tau_k, duration * tau_k, **common,
                      flows_per_start=per_start)


def _stored_given(node: Mapping, device, dtype) -> dict:
    """``flow.path``: one store or a list of them."""
    paths = node["path"] if isinstance(node["path"], list | tuple) else [node["path"]]
    return {"paths": tuple(Path(str(p)) for p in paths)}


def _live_given(node: Mapping, device, dtype) -> dict:
    """``flow.dns.*`` on the run's device and dtype, and ``flow.spinup.*``."""
    spinup = node["spinup"]
    return {"dns": live_dns_params(dict(node["dns"]), device, dtype),
            "spinup_time": spinup["time"], "measure_time": spinup["measure_time"]}


#: ``flow=dns_replay`` in the registry (:data:`swimrl.flows.registry.BUILTIN_FLOWS`).
DNS_REPLAY_ENTRY = FlowEntry("dns_replay", StoredRunSpec, _build_replay, 2, given=_stored_given,
                             table_bytes=_stored_bytes)
#: ``flow=dns`` in the registry (:data:`swimrl.flows.registry.BUILTIN_FLOWS`).
DNS_ENTRY = FlowEntry("dns", LiveDNSSpec, _build_replay, 2, given=_live_given,
                      table_bytes=_live_dns_bytes)
