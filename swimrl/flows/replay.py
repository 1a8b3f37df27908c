r"""Replay of stored flow snapshots (e.g. a DNS run) as a flow for the swimmer environment.

Snapshots ``Q_j(x)`` (five channels on a periodic grid) are stored at times ``j Δ``. Between
them the flow is linear in time:

``q(x, t) = (1 - a) Q_j(x) + a Q_{j+1}(x)``,  ``t = (j + a) Δ``,  ``0 <= a < 1``,

which is the :class:`GriddedFlow` form ``sum_m c_m(t) Q_m`` over a sliding window of
``M`` consecutive snapshots with hat-function weights
``c_m(t) = max(0, 1 - |t/Δ - (j_0 + m)|)``. The window is chosen per flow and per
decision interval so that it covers the whole interval (``M = T_u/Δ + 1`` snapshots when
``T_u`` is a multiple of ``Δ``, else ``ceil(T_u/Δ) + 2``); only snapshots new to the window
are read. Spatially the fields are periodically extended and
interpolated bilinearly, as for the stochastic flow. Each realisation (row of the batch)
starts its episode at a uniformly random stored time index (the swimmers' random start
positions supply the random place), or, for a source that produces its snapshots on demand
(``n_times = None``, a DNS stepped alongside), at the source's newest snapshot.
"""

from __future__ import annotations

import math
from typing import Protocol

import torch

from swimrl.flows.base import GriddedFlow
from swimrl.flows.grid import PeriodicGrid


class SnapshotSource(Protocol):
    """What a replay needs from a run (:mod:`swimrl.flows.sources`).

    ``n_times`` is the number of stored snapshots, or None for a run that produces them on
    demand; such a run's newest snapshot is ``latest``.
    """

    n_times: int | None
    dt_store: float
    u_rms: float
    tau_k: float
    length: float
    n: int

    def channels(self, i0: int, i1: int, flow: int = 0) -> torch.Tensor:
        """Snapshots ``i0 <= j < i1`` seen by realisation ``flow``, ``(i1 - i0, n, n, 5)``."""
        ...


class ReplayFlow(GriddedFlow):
    """``n_flows`` replays of one stored run, each from its own random start time."""

    def __init__(
        self,
        source: SnapshotSource,
        n_flows: int,
        interval: float,
        episode_time: float,
        device: torch.device | str = "cpu",
        dtype: torch.dtype = torch.float32,
        generator: torch.Generator | None = None,
    ):
        """``interval``: decision interval ``T_u`` and ``episode_time``: ``T``, in flow units."""
        self.source = source
        self.delta = float(source.dt_store)
        ratio = interval / self.delta
        if abs(ratio - round(ratio)) < 1e-6 and round(ratio) >= 1:
            window = round(ratio) + 1  # intervals start on stored times: no extra snapshot
        else:
            window = math.ceil(ratio) + 2
        needed = math.ceil(episode_time / self.delta - 1e-9) + 1
        if source.n_times is not None and needed > source.n_times:
            raise ValueError(
                f"flow.path: the stored run has {source.n_times} snapshots "
                f"({(source.n_times - 1) * self.delta / source.tau_k:.1f} tau_K) but an episode "
                f"needs {needed} ({episode_time / source.tau_k:.1f} tau_K): store a longer run "
                "or shorten episode.duration"
            )
        self.max_start = None if source.n_times is None else source.n_times - needed
        grid = PeriodicGrid(int(source.n), float(source.length))
        super().__init__(grid, n_flows, window, device, dtype)
        self.u_rms = float(source.u_rms)
        self.tau_k = float(source.tau_k)
        self.generator = generator
        self.start = torch.zeros(n_flows, dtype=torch.int64)  # stored index of t = 0
        self.window_start = torch.full((n_flows,), -(10**9), dtype=torch.int64)
        self.reset()

    def start_indices(self, count: int) -> torch.Tensor:
        """Stored index of ``t = 0`` for ``count`` new episodes: ``j ~ U{0..max_start}`` (a run
        producing snapshots on demand: its newest one)."""
        if self.max_start is None:
            return torch.full((count,), self.source.latest, dtype=torch.int64)
        return torch.randint(
            0, self.max_start + 1, (count,), generator=self.generator, device=self.device
        ).cpu()

    def reset(self, flows: torch.Tensor | None = None) -> None:
        """New episodes (from :meth:`start_indices`) for the selected flows."""
        sel = torch.ones(self.n_flows, dtype=torch.bool) if flows is None else flows.cpu()
        idx = sel.nonzero().flatten()
        if idx.numel() == 0:
            return
        self.start[idx] = self.start_indices(idx.numel())
        self.time[idx.to(self.time.device)] = 0.0
        self.window_start[idx] = -(10**9)
        self._load_window(idx, self.start[idx])
        self.coeffs[idx.to(self.device)] = self._weights(self.time[idx.to(self.time.device)], idx)


    def _load_window(self, flows: torch.Tensor, first: torch.Tensor) -> None:
        """Make snapshots ``first .. first + M - 1`` the basis of each flow in ``flows``."""
        m = self.n_basis
        for f, j0 in zip(flows.tolist(), first.tolist(), strict=True):
            old = int(self.window_start[f])
            shift = j0 - old
            if 0 < shift < m:  # keep the overlap, read only the new snapshots
                self.basis[f, :, :, : m - shift] = self.basis[f, :, :, shift:].clone()
                new = self.source.channels(old + m, j0 + m, f)
                self.basis[f, :, :, m - shift :] = new.permute(1, 2, 0, 3).to(self.basis)
            elif shift != 0:
                snaps = self.source.channels(j0, j0 + m, f)
                self.basis[f] = snaps.permute(1, 2, 0, 3).to(self.basis)
            self.window_start[f] = j0

    def _weights(self, time: torch.Tensor, flows: torch.Tensor) -> torch.Tensor:
        """Hat weights ``c_m = max(0, 1 - |s - (j_0 + m)|)``, ``s = start + t/Δ``; ``(len, M)``."""
        s = self.start[flows].double() + time.cpu().double() / self.delta
        rel = s[:, None] - self.window_start[flows].double()[:, None]
        m = torch.arange(self.n_basis, dtype=torch.float64)
        w = (1 - (rel - m).abs()).clamp_min(0)
        return w.to(device=self.device, dtype=self.dtype)

    def coefficient_path(self, n_steps: int, dt: float) -> torch.Tensor:
        """Weights at ``t + k dt`` (``k = 0..n_steps``) over a window covering the interval."""
        flows = torch.arange(self.n_flows)
        t0 = self.time.cpu().double()
        first = (self.start.double() + t0 / self.delta + 1e-6).floor().to(torch.int64)
        last = self.start.double() + (t0 + n_steps * dt) / self.delta
        end = math.inf if self.source.n_times is None else self.source.n_times - 1
        if torch.any(last > first + self.n_basis - 1 + 1e-6) or torch.any(last > end + 1e-6):
            raise RuntimeError("replay window too short for the interval (or past the run)")
        self._load_window(flows, first)
        times = t0[None, :] + dt * torch.arange(n_steps + 1, dtype=torch.float64)[:, None]
        path = torch.stack([self._weights(t, flows) for t in times])
        self.time += n_steps * dt
        self.coeffs.copy_(path[-1])
        return path

    def advance(self, dt: float) -> None:
        """Advance all flows by ``dt`` (one-step coefficient path)."""
        self.coefficient_path(1, dt)
