r"""Replay of stored flow snapshots (e.g. DNS runs) as a flow for the swimmer environment.

Snapshots $Q_j(\boldsymbol x)$ (five channels on a periodic grid) of a run are stored at
times $j\Delta$. Between them the flow is linear in time:

$$
q(\boldsymbol x, t) = (1 - a)\,Q_j(\boldsymbol x) + a\,Q_{j+1}(\boldsymbol x),\qquad
t = (j + a)\,\Delta,\qquad 0 \le a < 1,
$$

which is the :class:`GriddedFlow` form $\sum_m c_m(t)\,Q_m$ over a window of $M$
consecutive snapshots with hat-function weights $c_m(t) = \max(0, 1 - |s - j_m|)$,
$s = j_0 + t/\Delta$ ($j_0$ the episode's start index, $j_m$ the snapshot held in slot
$m$). The window covers a whole decision interval ($M = T_u/\Delta + 1$ snapshots when
$T_u$ is a multiple of $\Delta$, else $\lceil T_u/\Delta\rceil + 2$) and is a ring: snapshot
$j$ sits in slot $j \bmod M$, so sliding the window writes only the snapshots new to it.

Decoding a snapshot (reading it and transforming it to node values) costs far more than
moving swimmers through it, so it is done once for all the swimmers that need it:

* flows that replay the same run from the same start time share one basis row
  (:meth:`GriddedFlow.rows`); ``flows_per_start`` consecutive flows of a reset draw one
  (run, start) together, so $F$ flows need $F$ / ``flows_per_start`` decodes per new
  snapshot instead of $F$;
* decoded snapshots are kept in a small least-recently-used cache keyed by (run, index), so
  rows that need the same snapshot at the same time decode it once.

A reset draws, per group of flows, a run $r\sim U\{0, \dots, n_\mathrm{runs} - 1\}$ (only
when the source holds several) and a start index
$j_0\sim U\{0, \dots, n_\mathrm{times} - n_\mathrm{needed}\}$; the swimmers' random start
positions supply the random place. A source that produces snapshots on demand
(``n_times = None``, a DNS stepped alongside) has one realisation per flow and starts each
episode at its newest snapshot.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import Protocol

import torch

from swimrl.flows.base import GriddedFlow, field_stats, max_speed
from swimrl.flows.grid import PeriodicGrid


class SnapshotSource(Protocol):
    """What a replay needs from a set of runs (:mod:`swimrl.flows.dns.sources`).

    ``n_times`` is the number of stored snapshots per run, or None for runs that produce
    them on demand; such a source's newest snapshot is ``latest``. ``realisation_per_flow``:
    run ``f`` belongs to flow ``f`` (``n_runs`` equals the number of flows).
    """

    n_runs: int
    realisation_per_flow: bool
    n_times: int | None
    dt_store: float
    u_rms: float
    tau_k: float
    length: float
    n: int

    def channels(self, i0: int, i1: int, run: int = 0) -> torch.Tensor:
        """Snapshots ``i0 <= j < i1`` of run ``run``, ``(i1 - i0, n, n, 5)``."""
        ...


def window_size(interval: float, delta: float) -> int:
    r"""Snapshots $M$ a window needs to cover one decision interval $T_u$ ($\Delta$ apart)."""
    ratio = interval / delta
    if abs(ratio - round(ratio)) < 1e-6 and round(ratio) >= 1:
        return round(ratio) + 1  # intervals start on stored times: no extra snapshot
    return math.ceil(ratio) + 2


class ReplayFlow(GriddedFlow):
    """``n_flows`` replays of stored runs; ``flows_per_start`` flows share each start."""

    def __init__(
        self,
        source: SnapshotSource,
        n_flows: int,
        interval: float,
        episode_time: float,
        device: torch.device | str = "cpu",
        dtype: torch.dtype = torch.float32,
        generator: torch.Generator | None = None,
        flows_per_start: int = 1,
        cache_size: int | None = None,
    ):
        """``interval``: decision interval $T_u$ and ``episode_time``: $T$, in flow units."""
        self.source = source
        self.delta = float(source.dt_store)
        window = window_size(interval, self.delta)
        needed = math.ceil(episode_time / self.delta - 1e-9) + 1
        if source.n_times is not None and needed > source.n_times:
            raise ValueError(
                f"flow.path: the stored run has {source.n_times} snapshots "
                f"({(source.n_times - 1) * self.delta / source.tau_k:.1f} tau_K) but an episode "
                f"needs {needed} ({episode_time / source.tau_k:.1f} tau_K): store a longer run "
                "or shorten episode.duration"
            )
        self.max_start = None if source.n_times is None else source.n_times - needed
        self.per_flow = bool(getattr(source, "realisation_per_flow", False))
        if self.per_flow and source.n_runs != n_flows:
            raise ValueError(f"the source has {source.n_runs} realisations for {n_flows} flows")
        self.flows_per_start = 1 if self.per_flow else max(1, int(flows_per_start))
        rows = math.ceil(n_flows / self.flows_per_start)
        grid = PeriodicGrid(int(source.n), float(source.length))
        super().__init__(grid, n_flows, window, device, dtype, n_rows=rows)
        self.u_rms = float(source.u_rms)
        self.tau_k = float(source.tau_k)
        self.generator = generator
        self.cache: OrderedDict[tuple[int, int], torch.Tensor] = OrderedDict()
        self.cache_size = window + 1 if cache_size is None else int(cache_size)
        self.decodes = 0  # snapshots decoded so far (benchmarks and tests)
        # per flow: its basis row (its run and start are the row's)
        self.row = torch.full((n_flows,), -1, dtype=torch.int64)
        self._row_dev = self.row.to(self.device)
        # per row: run, start, time, stored index held in each ring slot (-1: none), in use
        self.row_run = torch.zeros(rows, dtype=torch.int64)
        self.row_start = torch.zeros(rows, dtype=torch.int64)
        self.row_time = torch.zeros(rows, dtype=torch.float64)
        self.held = torch.full((rows, window), -1, dtype=torch.int64)
        self.reset()

    # -- episodes -----------------------------------------------------------------------------
    def start_indices(self, count: int) -> torch.Tensor:
        r"""Stored index of $t = 0$ for ``count`` new episodes:
        $j\sim U\{0, \dots, m\}$, $m$ = ``max_start`` (a run producing snapshots on demand: its
        newest one)."""
        if self.max_start is None:
            return torch.full((count,), self.source.latest, dtype=torch.int64)
        return torch.randint(
            0, self.max_start + 1, (count,), generator=self.generator, device=self.device
        ).cpu()

    @property
    def run(self) -> torch.Tensor:
        """Run replayed by each flow, ``(F,)``."""
        return self.row_run[self.row]

    @property
    def start(self) -> torch.Tensor:
        """Stored index of each flow's $t = 0$, ``(F,)``."""
        return self.row_start[self.row]

    def start_runs(self, count: int) -> torch.Tensor:
        r"""Run replayed by ``count`` new episodes: $r\sim U\{0, \dots, n_\mathrm{runs} - 1\}$ (no
        draw for one run)."""
        if self.source.n_runs == 1:
            return torch.zeros(count, dtype=torch.int64)
        return torch.randint(0, self.source.n_runs, (count,), generator=self.generator,
                             device=self.device).cpu()

    def reset(self, flows: torch.Tensor | None = None) -> None:
        """New episodes for the selected flows (bool ``(F,)``; all if None): consecutive
        groups of ``flows_per_start`` of them draw one (run, start) and share a basis row."""
        sel = torch.ones(self.n_flows, dtype=torch.bool) if flows is None else flows.cpu()
        idx = sel.nonzero().flatten()
        if idx.numel() == 0:
            return
        self.row[idx] = -1
        groups = list(idx.split(self.flows_per_start))
        starts = self.start_indices(len(groups))
        runs = idx.clone() if self.per_flow else self.start_runs(len(groups))
        new_rows = []
        for group, run, start in zip(groups, runs.tolist(), starts.tolist(), strict=True):
            r = self._free_row()
            if int(self.row_run[r]) != run:
                self.held[r] = -1  # its ring holds another run's snapshots
            self.row[group] = r
            self.row_run[r], self.row_start[r], self.row_time[r] = run, start, 0.0
            new_rows.append(r)
        self._row_dev = self.row.to(self.device)
        self.time[idx.to(self.time.device)] = 0.0
        rows = torch.tensor(new_rows, dtype=torch.int64)
        self._load(rows, self.row_start[rows])
        self.coeffs[rows.to(self.device)] = self._weights(self.row_time[rows][None], rows)[0]

    def _free_row(self) -> int:
        """A basis row no flow uses (the basis grows by one row if there is none)."""
        used = torch.zeros(self.basis.shape[0], dtype=torch.bool)
        live = self.row[self.row >= 0]
        used[live] = True
        free = (~used).nonzero().flatten()
        if free.numel():
            return int(free[0])
        self.basis = torch.cat([self.basis, torch.zeros_like(self.basis[:1])])
        self.coeffs = torch.cat([self.coeffs, torch.zeros_like(self.coeffs[:1])])
        self.mode_speed = torch.cat([self.mode_speed, torch.zeros_like(self.mode_speed[:1])])
        self.row_run = torch.cat([self.row_run, self.row_run[:1]])
        self.row_start = torch.cat([self.row_start, self.row_start[:1]])
        self.row_time = torch.cat([self.row_time, self.row_time[:1]])
        self.held = torch.cat([self.held, torch.full_like(self.held[:1], -1)])
        return self.basis.shape[0] - 1

    def rows(self, flow_index: torch.Tensor) -> torch.Tensor:
        """Basis row of each flow (flows replaying one run from one start share a row)."""
        return self._row_dev[flow_index]

    # -- snapshots ----------------------------------------------------------------------------
    def snapshot(self, run: int, j: int) -> torch.Tensor:
        """Decoded snapshot ``j`` of run ``run``, ``(n, n, 5)`` (from the cache if held)."""
        key = (run, j)
        if key in self.cache:
            self.cache.move_to_end(key)
            return self.cache[key]
        q = self.source.channels(j, j + 1, run)[0].to(device=self.device, dtype=self.dtype)
        self.decodes += 1
        self.cache[key] = q
        while len(self.cache) > self.cache_size:
            self.cache.popitem(last=False)
        return q

    def _load(self, rows: torch.Tensor, first: torch.Tensor) -> None:
        """Make snapshots ``first .. first + M - 1`` the window of each row in ``rows``
        (snapshot ``j`` in ring slot ``j mod M``; only those not already held are written)."""
        m, end = self.n_basis, self.source.n_times
        for r, j0 in zip(rows.tolist(), first.tolist(), strict=True):
            run = int(self.row_run[r])
            # at the end of a run the window may reach past its last snapshot; the slot
            # left stale holds an index <= j0 - 1, whose weight is 0 from s >= j0 on
            for j in range(j0, j0 + m if end is None else min(j0 + m, end)):
                slot = j % m
                if int(self.held[r, slot]) != j:
                    self.basis[r, :, :, slot] = q = self.snapshot(run, j)
                    self.mode_speed[r, slot] = max_speed(q.unsqueeze(-2))[0]
                    self.held[r, slot] = j

    def _weights(self, times: torch.Tensor, rows: torch.Tensor) -> torch.Tensor:
        """Hat weights ``c_m = max(0, 1 - |s - j_m|)``, ``s = start + t/Δ``, of the ring slots
        at row times ``times`` ``(K, len(rows))``; ``(K, len(rows), M)``."""
        s = self.row_start[rows].double() + times / self.delta
        held = self.held[rows].double()
        w = (1 - (s[..., None] - held).abs()).clamp_min(0) * (held >= 0)
        return w.to(device=self.device, dtype=self.dtype)

    # -- time ---------------------------------------------------------------------------------
    def coefficient_path(self, n_steps: int, dt: float) -> torch.Tensor:
        r"""Weights of every basis row at $t + k\,\delta t$ ($k = 0, \dots,$ ``n_steps``),
        ``(K+1, R, M)``, over windows covering the interval."""
        rows = torch.unique(self.row[self.row >= 0])
        t0 = self.row_time[rows]
        s0 = self.row_start[rows].double() + t0 / self.delta
        first = (s0 + 1e-6).floor().to(torch.int64)
        last = self.row_start[rows].double() + (t0 + n_steps * dt) / self.delta
        end = math.inf if self.source.n_times is None else self.source.n_times - 1
        if torch.any(last > first + self.n_basis - 1 + 1e-6) or torch.any(last > end + 1e-6):
            raise RuntimeError("replay window too short for the interval (or past the run)")
        self._load(rows, first)
        times = t0[None, :] + dt * torch.arange(n_steps + 1, dtype=torch.float64)[:, None]
        path = torch.zeros(n_steps + 1, *self.coeffs.shape, device=self.device, dtype=self.dtype)
        path[:, rows.to(self.device)] = self._weights(times, rows)
        self.row_time[rows] += n_steps * dt
        self.time += n_steps * dt
        self.coeffs.copy_(path[-1])
        return path

    def measured_stats(self) -> dict[str, float]:
        r"""Grid averages over all flows (each row weighted by the flows that share it):
        $u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$,
        $\tau_K = \langle A_{ij}A_{ij}\rangle^{-1/2}$."""
        rows, count = torch.unique(self.row[self.row >= 0], return_counts=True)
        rows = rows.to(self.device)
        q = torch.einsum("fm,fyxmc->fyxc", self.coeffs[rows], self.basis[rows])
        return field_stats(q.double(), count.to(q.device, torch.float64))

    def advance(self, dt: float) -> None:
        """Advance all flows by ``dt`` (one-step coefficient path)."""
        self.coefficient_path(1, dt)
