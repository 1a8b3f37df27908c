r"""``flow=dns``: the DNS solver stepped alongside the swimmers (one realisation per flow).

A batch of ``F`` independent DNS realisations (:class:`swimrl.flows.dns.DNS`) is spun up
from rest for ``spinup_time``; over its last ``measure_time`` the reference scales
``u_rms = <u.u>^{1/2}`` and ``tau_K = <d_i u_j d_i u_j>^{-1/2}`` are measured (ensemble and
time averages). Afterwards the solver produces snapshots ``Q_j`` every ``s`` solver steps,
``Δ = s dt_DNS ~ snapshot_tau_k tau_K``, on demand, and the swimmers see the same
linear-in-time interpolation as a stored run (:class:`~swimrl.flows.replay.ReplayFlow`):
``q(x, t) = (1 - a) Q_j + a Q_{j+1}``. Nothing is written to disk.

A reset of a flow starts its new episode at the run's current time: the realisation keeps
evolving (it is statistically stationary after the spin-up), so no new spin-up is needed.
Best on a GPU (``device=cuda``); on a CPU a 512² spin-up takes minutes.
"""

from __future__ import annotations

import math

import torch

from swimrl.flows.dns import DNS, DNSParams, flow_channels
from swimrl.flows.dns.diagnostics import gradient_norm2, u_rms
from swimrl.flows.replay import ReplayFlow


class LiveDNSRun:
    """Batched DNS producing channel snapshots ``(F, n, n, 5)`` on demand (a small cache)."""

    def __init__(
        self,
        params: DNSParams,
        seeds: list[int],
        spinup_time: float,
        measure_time: float,
        snapshot_tau_k: float,
        keep: int = 8,
    ):
        if not spinup_time >= measure_time > 0:
            raise ValueError(
                f"flow.measure_time={measure_time} is invalid: allowed (0, flow.spinup_time="
                f"{spinup_time}]"
            )
        self.dns = DNS(params, batch=len(seeds), seeds=seeds)
        grid = self.dns.grid
        n_spin = max(1, round(spinup_time / params.dt))
        n_meas = max(1, round(measure_time / params.dt))
        every = max(1, n_meas // 50)
        u2 = g2 = 0.0
        count = 0
        for i in range(n_spin):
            self.dns.step()
            if i >= n_spin - n_meas and (n_spin - 1 - i) % every == 0:
                w = self.dns.state.omega_hat
                u2 += float((u_rms(grid, w) ** 2).mean())
                g2 += float(gradient_norm2(grid, w).mean())
                count += 1
        self.u_rms = math.sqrt(u2 / count)
        self.tau_k = (g2 / count) ** -0.5
        self.steps_per_snapshot = max(1, round(snapshot_tau_k * self.tau_k / params.dt))
        self.dt_store = self.steps_per_snapshot * params.dt
        self.length = float(params.length)
        self.n = int(params.n)
        self.n_times = 10**15  # unbounded
        self.keep = int(keep)
        self.latest = 0
        self.cache = {0: self._channels()}

    def _channels(self) -> torch.Tensor:
        return flow_channels(self.dns.state.omega_hat, self.dns.grid)

    def channels_of(self, flow: int, i0: int, i1: int) -> torch.Tensor:
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


class LiveDNSFlow(ReplayFlow):
    """A :class:`ReplayFlow` whose snapshots come from a running batched DNS."""

    def __init__(
        self,
        run: LiveDNSRun,
        interval: float,
        episode_time: float,
        device: torch.device | str = "cpu",
        dtype: torch.dtype = torch.float32,
        generator: torch.Generator | None = None,
    ):
        super().__init__(run, run.dns.state.batch, interval, episode_time, device, dtype, generator)

    def _read(self, flow: int, i0: int, i1: int) -> torch.Tensor:
        return self.source.channels_of(flow, i0, i1)

    def start_indices(self, count: int) -> torch.Tensor:
        """New episodes start at the run's current snapshot (no new spin-up)."""
        return torch.full((count,), self.source.latest, dtype=torch.int64)
