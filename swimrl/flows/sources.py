r"""Snapshot sources of the replay flow: a stored DNS run and a DNS running alongside.

Both implement :class:`swimrl.flows.replay.SnapshotSource`: snapshots ``Q_j`` (five channels
on the nodes) ``Δ = dt_store`` apart, ``channels(i0, i1, flow)``, and the reference scales
``u_rms``, ``tau_k`` in which the swimmers' parameters are expressed.

* :class:`DNSStore` reads a run written by ``swimrl-dns`` (``flow=dns_replay``); channels are
  reconstructed from the stored vorticity coefficients by spectral differentiation.
* :class:`LiveDNS` (``flow=dns``) is a batch of ``F`` independent DNS realisations, one per
  flow, spun up from rest (:mod:`swimrl.flows.dns.spinup`: ``u_rms`` and ``tau_K`` are
  measured over the end of the spin-up). Afterwards the solver produces a snapshot every
  ``s`` solver steps, ``Δ = s dt_DNS ~ interval_tau_k tau_K``, on demand, keeping a few in a
  cache. Its ``n_times`` is ``None`` (unbounded): a new episode starts at the run's newest
  snapshot, the realisation keeping on evolving (it is statistically stationary after the
  spin-up). Nothing is written to disk. Best on a GPU (``device=cuda``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import torch
import zarr

from swimrl.flows.base import CHANNELS
from swimrl.flows.dns import DNS, DNSParams, flow_channels
from swimrl.flows.dns.grid import SpectralGrid
from swimrl.flows.dns.spinup import SpinupSchedule, spin_up
from swimrl.flows.dns.store import unpack


class DNSStore:
    """Reader of a run stored by ``swimrl-dns`` (:mod:`swimrl.flows.dns.store`).

    ``DNSStore(path)`` exposes ``n_times``, ``dt_store``, ``u_rms``, ``tau_k``, ``length``,
    ``n``, ``times``, ``attrs`` and :meth:`channels`.
    """

    def __init__(self, path: str | Path, device: torch.device | str = "cpu"):
        self.path = Path(path)
        if not self.path.exists():
            raise FileNotFoundError(f"no DNS store at {self.path}")
        self.group = zarr.open_group(str(self.path), mode="r")
        self.attrs: dict[str, Any] = dict(self.group.attrs)
        if "n" not in self.attrs or "n_written" not in self.attrs:
            raise ValueError(f"{self.path} is not a swimrl DNS store (missing attrs n/n_written)")
        self.device = torch.device(device)
        self.n = int(self.attrs["n"])
        self.length = float(self.attrs["length"])
        self.n_times = int(self.attrs["n_written"])
        self.dt_store = float(self.attrs.get("dt_store", math.nan))
        self.u_rms = float(self.attrs.get("u_rms", math.nan))
        self.tau_k = float(self.attrs.get("tau_k", math.nan))
        self.channel_names = tuple(self.attrs.get("channel_names", CHANNELS))
        self._grid = SpectralGrid(self.n, self.length, self.device, torch.float32)

    @property
    def complete(self) -> bool:
        """Whether the run finished."""
        return self.attrs.get("status") == "complete"

    @property
    def times(self) -> np.ndarray:
        """Snapshot times ``(n_times,)``."""
        return np.asarray(self.group["time"][: self.n_times])

    def _check_range(self, i0: int, i1: int) -> None:
        if not 0 <= i0 <= i1 <= self.n_times:
            raise IndexError(f"snapshot range [{i0}, {i1}) outside [0, {self.n_times}]")

    def omega_hat(self, i0: int, i1: int, dtype: torch.dtype = torch.complex64) -> torch.Tensor:
        """Unnormalised ``rfft2(omega)`` of snapshots ``i0..i1-1``, ``(i1-i0, N, N//2+1)``."""
        self._check_range(i0, i1)
        c = torch.from_numpy(np.asarray(self.group["omega_hat"][i0:i1])).to(self.device)
        return unpack(c.to(dtype) * float(self.n) ** 2, self.n)

    def channels(self, i0: int, i1: int, flow: int = 0) -> torch.Tensor:
        """``(u_x, u_y, S_xx, S_xy, omega)`` at the nodes, ``(i1-i0, N, N, 5)`` float32 (the
        same stored run for every ``flow``)."""
        return flow_channels(self.omega_hat(i0, i1), self._grid)

    def __len__(self) -> int:
        return self.n_times

    def __repr__(self) -> str:
        return (f"DNSStore({str(self.path)!r}, n={self.n}, n_times={self.n_times}, "
                f"dt_store={self.dt_store:.4g}, u_rms={self.u_rms:.4g}, tau_k={self.tau_k:.4g})")


class LiveDNS:
    """Batched DNS producing channel snapshots ``(F, n, n, 5)`` on demand (a small cache).

    ``spinup`` steps the run from rest to a steady state and measures its scales; snapshots
    are then ``interval_tau_k tau_K`` apart (whole solver steps).
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

    def channels(self, i0: int, i1: int, flow: int = 0) -> torch.Tensor:
        """Snapshots ``i0 <= j < i1`` of realisation ``flow``, stepping the solver as needed."""
        while self.latest < i1 - 1:
            self.dns.step(self.steps_per_snapshot)
            self.latest += 1
            self.cache[self.latest] = self._channels()
            self.cache.pop(self.latest - self.keep, None)
        missing = [j for j in range(i0, i1) if j not in self.cache]
        if missing:
            raise RuntimeError(f"live DNS snapshot {missing[0]} is no longer cached")
        return torch.stack([self.cache[j][flow] for j in range(i0, i1)])
