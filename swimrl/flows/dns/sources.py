r"""Snapshot sources of the replay flow: a stored DNS run and a DNS running alongside.

All implement :class:`swimrl.flows.replay.SnapshotSource`: ``n_runs`` realisations of
snapshots $Q_j$ (five channels on the nodes) $\Delta$ = ``dt_store`` apart,
``channels(i0, i1, run)``, and the reference scales ``u_rms``, ``tau_k`` in which the
swimmers' parameters are expressed.

* :class:`DNSStore` reads a run written by ``swimrl-dns`` (``flow=dns_replay``); channels are
  reconstructed from the stored vorticity coefficients by spectral differentiation, on the
  run's own grid or on a coarser decode grid of $n_d$ nodes per side (``flow.decode_n``):
  the retained modes $|m_x|, |m_y| \le K$ with $K \le n_d/2 - 1$ are kept exactly, so for
  $n_d > 2K$ the decoded nodes sample the same band-limited field, and only the bilinear
  interpolation between nodes (error $\sim h^2$) differs; smaller $n_d$ also truncates
  $K$ (docs/dns.md has the measured errors). Every read passes the chunks' crc32c checksums
  and every snapshot read is finite with an rms velocity within a factor 5 of the run's
  ``u_rms`` (:mod:`swimrl.flows.dns.integrity`), else :class:`~swimrl.errors.IntegrityError`;
  a store written before checksums reads unverified, with one warning line.
* :class:`StoreSet` is several stored runs (independent realisations, e.g. seeds) replayed
  as one source: ``channels(i0, i1, run)`` reads run ``run``.
* :class:`LiveDNS` (``flow=dns``) is a batch of ``F`` independent DNS realisations, one per
  flow, spun up from rest (:mod:`swimrl.flows.dns.spinup`: $u_\mathrm{rms}$ and $\tau_K$ are
  measured over the end of the spin-up). Afterwards the solver produces a snapshot every
  $s$ solver steps, $\Delta = s\,\delta t_\mathrm{DNS} \approx$ ``interval_tau_k`` $\tau_K$,
  on demand, keeping a few in a cache. Its ``n_times`` is ``None`` (unbounded): a new
  episode starts at the run's newest snapshot, the realisation keeping on evolving (it is
  statistically stationary after the spin-up). Nothing is written to disk. Best on a GPU
  (``device=cuda``).

The flows replaying them, their specs and entries: :mod:`swimrl.flows.dns.flow`.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
import torch
import zarr

from swimrl.flows.base import CHANNELS
from swimrl.flows.dns.grid import SpectralGrid, dealias_cutoff
from swimrl.flows.dns.integrity import (
    SnapshotCheck,
    has_checksum,
    read,
    read_snapshots,
    verify_hint,
)
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.spinup import SpinupSchedule, spin_up
from swimrl.flows.dns.state import flow_channels
from swimrl.flows.dns.stepper import DNS
from swimrl.flows.dns.store import unpack

log = logging.getLogger(__name__)
#: stores already reported as unverified in this process (one warning line per store)
_UNVERIFIED_REPORTED: set[Path] = set()


class DNSStore:
    """Reader of a run stored by ``swimrl-dns`` (:mod:`swimrl.flows.dns.store`).

    ``DNSStore(path)`` exposes ``n_times``, ``dt_store``, ``u_rms``, ``tau_k``, ``length``,
    ``n``, ``times``, ``attrs``, ``checksums`` and :meth:`channels`. Reads are checked
    (module docstring): a damaged chunk or an impossible snapshot is an
    :class:`~swimrl.errors.IntegrityError` naming the store and the time index.
    """

    n_runs = 1
    realisation_per_flow = False

    def __init__(
        self, path: str | Path, device: torch.device | str = "cpu", decode_n: int | None = None
    ):
        self.path = Path(path)
        if not self.path.exists():
            raise FileNotFoundError(f"no DNS store at {self.path}")
        self.group = zarr.open_group(str(self.path), mode="r")
        self.attrs: dict[str, Any] = dict(self.group.attrs)
        if "n" not in self.attrs or "n_written" not in self.attrs:
            raise ValueError(f"{self.path} is not a swimrl DNS store (missing attrs n/n_written)")
        self.device = torch.device(device)
        self.store_n = int(self.attrs["n"])
        self.n = self.store_n if decode_n is None else int(decode_n)
        self.length = float(self.attrs["length"])
        self.n_times = int(self.attrs["n_written"])
        self.dt_store = float(self.attrs.get("dt_store", math.nan))
        self.u_rms = float(self.attrs.get("u_rms", math.nan))
        self.tau_k = float(self.attrs.get("tau_k", math.nan))
        self.channel_names = tuple(self.attrs.get("channel_names", CHANNELS))
        self._grid = SpectralGrid(self.n, self.length, self.device, torch.float32)
        self.cutoff = min(dealias_cutoff(self.store_n), self.n // 2 - 1)  # modes decoded
        self.check = SnapshotCheck(self.store_n, self.length, self.u_rms, self.path)
        self.checksums = has_checksum(self.group["omega_hat"])
        if not self.checksums and self.path.resolve() not in _UNVERIFIED_REPORTED:
            _UNVERIFIED_REPORTED.add(self.path.resolve())
            log.warning("%s is unverified (no checksums: written before swimrl stored them); "
                        "check it with %s", self.path, verify_hint(self.path))

    @property
    def complete(self) -> bool:
        """Whether the run finished."""
        return self.attrs.get("status") == "complete"

    @property
    def times(self) -> np.ndarray:
        """Snapshot times ``(n_times,)``."""
        return read(self.group["time"], self.path, "time", slice(0, self.n_times))

    def _check_range(self, i0: int, i1: int) -> None:
        if not 0 <= i0 <= i1 <= self.n_times:
            raise IndexError(f"snapshot range [{i0}, {i1}) outside [0, {self.n_times}]")

    def omega_hat(self, i0: int, i1: int, dtype: torch.dtype = torch.complex64) -> torch.Tensor:
        """Unnormalised ``rfft2(omega)`` of snapshots ``i0..i1-1``, ``(i1-i0, N, N//2+1)``."""
        c = self._stored(i0, i1)
        return unpack(c.to(dtype) * float(self.store_n) ** 2, self.store_n)

    def decoded_hat(self, i0: int, i1: int) -> torch.Tensor:
        r"""Unnormalised ``rfft2(omega)`` on the decode grid, ``(i1-i0, n_d, n_d//2+1)``:
        the stored $c_k$ with $|m_x|, |m_y| \le$ ``cutoff``, times $n_d^2$."""
        c = self._stored(i0, i1)
        big, k = dealias_cutoff(self.store_n), self.cutoff
        c = c[:, big - k: big + k + 1, : k + 1]
        return unpack(c.to(torch.complex64) * float(self.n) ** 2, self.n, cutoff=k)

    def _stored(self, i0: int, i1: int) -> torch.Tensor:
        """The stored (packed, normalised) coefficients of snapshots ``i0..i1-1``, checked:
        their chunks' checksums, finite, rms velocity within a factor ``RMS_FACTOR = 5`` of
        ``u_rms`` (:class:`~swimrl.flows.dns.integrity.SnapshotCheck`)."""
        self._check_range(i0, i1)
        c = read_snapshots(self.group["omega_hat"], self.path, i0, i1)
        c = torch.from_numpy(c).to(self.device)
        self.check.check(c, i0)
        return c

    def diagnostics(self, names: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """The committed diagnostics series (``t``, ``energy``, ...; all if ``names`` is
        None), checksums checked."""
        d = self.group["diagnostics"]
        n = int(self.attrs.get("n_diag", d["t"].shape[0]))
        names = tuple(d.array_keys()) if names is None else names
        return {k: read(d[k], self.path, f"diagnostics/{k}", slice(0, n)) for k in names}

    def channels(self, i0: int, i1: int, run: int = 0) -> torch.Tensor:
        r"""$(u_x, u_y, S_{xx}, S_{xy}, \omega)$ at the decode nodes, ``(i1-i0, n_d, n_d, 5)``
        float32 (a store is one run: ``run`` must be 0)."""
        if run != 0:
            raise IndexError(f"{self.path} holds one run; run {run} requested")
        return flow_channels(self.decoded_hat(i0, i1), self._grid, cutoff=self.cutoff)

    def __len__(self) -> int:
        return self.n_times

    def __repr__(self) -> str:
        return (f"DNSStore({str(self.path)!r}, n={self.store_n}, decode_n={self.n}, "
                f"n_times={self.n_times}, "
                f"dt_store={self.dt_store:.4g}, u_rms={self.u_rms:.4g}, tau_k={self.tau_k:.4g})")


class StoreSet:
    """Several stored runs (independent realisations) as one source of ``n_runs`` runs.

    The runs must share the grid, box and ``dt_store``; ``n_times`` is the shortest run's,
    and ``u_rms``, ``tau_k`` are the means of the runs' measured scales (they differ by
    the sampling error of each run's spin-up measurement, a few per cent).
    """

    realisation_per_flow = False

    def __init__(self, stores: list[DNSStore]):
        if not stores:
            raise ValueError("flow.path: no store given")
        first = stores[0]
        for s in stores[1:]:
            for key in ("store_n", "n", "length", "dt_store"):
                a, b = getattr(first, key), getattr(s, key)
                if not math.isclose(a, b, rel_tol=1e-9):
                    raise ValueError(f"flow.path: {s.path} has {key}={b}, {first.path} has "
                                     f"{a}; replayed runs must share the grid and dt_store")
        self.stores = list(stores)
        self.n_runs = len(stores)
        self.n, self.length, self.dt_store = first.n, first.length, first.dt_store
        self.n_times = min(s.n_times for s in stores)
        self.u_rms = float(np.mean([s.u_rms for s in stores]))
        self.tau_k = float(np.mean([s.tau_k for s in stores]))

    def channels(self, i0: int, i1: int, run: int = 0) -> torch.Tensor:
        """Snapshots ``i0 <= j < i1`` of run ``run``, ``(i1-i0, n_d, n_d, 5)``."""
        return self.stores[run].channels(i0, i1)

    def __repr__(self) -> str:
        return f"StoreSet({[str(s.path) for s in self.stores]}, n_times={self.n_times})"


class LiveDNS:
    r"""Batched DNS producing channel snapshots ``(F, n, n, 5)`` on demand (a small cache).

    ``spinup`` steps the run from rest to a steady state and measures its scales; snapshots
    are then ``interval_tau_k`` $\tau_K$ apart (whole solver steps).
    """

    def __init__(
        self,
        params: DNSParams,
        seeds: list[int],
        spinup: SpinupSchedule,
        interval_tau_k: float,
        keep: int = 8,
    ):
        self.dns = DNS(params, batch=len(seeds), seeds=seeds)
        self.n_runs = len(seeds)
        self.realisation_per_flow = True  # flow f of the replay is realisation f
        scales = spin_up(self.dns, spinup)
        self.u_rms, self.tau_k = scales["u_rms"], scales["tau_k"]
        self.steps_per_snapshot = max(1, round(interval_tau_k * self.tau_k / params.dt))
        self.dt_store = self.steps_per_snapshot * params.dt
        self.length = float(params.length)
        self.n = int(params.n)
        self.n_times: int | None = None  # unbounded: snapshots are produced on demand
        self.keep = int(keep)
        self.latest = 0
        self.cache = {0: self._channels()}

    def _channels(self) -> torch.Tensor:
        return flow_channels(self.dns.state.omega_hat, self.dns.grid)

    def channels(self, i0: int, i1: int, run: int = 0) -> torch.Tensor:
        """Snapshots ``i0 <= j < i1`` of realisation ``run``, stepping the solver as needed."""
        while self.latest < i1 - 1:
            self.dns.step(self.steps_per_snapshot)
            self.latest += 1
            self.cache[self.latest] = self._channels()
            self.cache.pop(self.latest - self.keep, None)
        missing = [j for j in range(i0, i1) if j not in self.cache]
        if missing:
            raise RuntimeError(f"live DNS snapshot {missing[0]} is no longer cached")
        return torch.stack([self.cache[j][run] for j in range(i0, i1)])
