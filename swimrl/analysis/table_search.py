r"""The best 12-state table of Colabrese et al.'s problem found by a stated search: coordinate
ascent over the $4^{12}$ tables (state :func:`~swimrl.physics.body2d.twelve_states` $\to$ one
of the four directions right, up, left, down), from several starts.

Every candidate of one coordinate step (the table with one state's action changed to each of
the four) is one block of swimmers of a single batched environment, all blocks with the same
starts (common random numbers: the Taylor-Green flow is deterministic), so a step is one
rollout;
the objective is $\langle v_z\rangle/v_s$ over the measuring window (``task=vertical``). A
sweep visits the twelve states in order and keeps a change only where it raises the mean by
more than ``tol``; a start ends after a sweep without a change or after ``max_sweeps``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import torch

from swimrl.env import EnvParams, build_env
from swimrl.flows.analytic import TaylorGreenSpec
from swimrl.physics.body2d import twelve_states
from swimrl.physics.gyrotaxis import axis_directions
from swimrl.runtime import Runtime

#: The four actions' names, in :func:`~swimrl.physics.gyrotaxis.axis_directions` order (2D).
ACTIONS = ("right", "up", "left", "down")
#: The table of the naive swimmer: up in every state.
NAIVE_TABLE = (1,) * 12


def table_actions(tables: torch.Tensor, signals: torch.Tensor, discrete: bool) -> torch.Tensor:
    r"""The action of every swimmer of flow row $f$ under ``tables[f]`` ``(F, 12)``, from its
    signals ``(F, S, 5)``: the index (``discrete``) or the direction vector ``(F, S, 2)``."""
    state = twelve_states(signals).argmax(-1)                     # (F, S)
    index = torch.gather(tables, 1, state)                        # (F, S)
    if discrete:
        return index
    return axis_directions(2, signals.device, signals.dtype)[index]


def evaluate_tables(tables: Sequence[Sequence[int]], params: EnvParams, n_swimmers: int,
                    seed: int, runtime: Runtime) -> torch.Tensor:
    r"""$\langle v_z\rangle/v_s$ of each table, mean over ``n_swimmers`` starts shared by all
    tables (one flow, a block of swimmers per table with the same starts: ``ic_blocks``;
    ``params``: ``actuation=steer``, ``task=vertical``), ``(len(tables),)``."""
    t = torch.as_tensor(tables, dtype=torch.long)
    c = len(t)
    env = build_env(TaylorGreenSpec(), params, runtime, 1, c * n_swimmers, seed, ic_blocks=c)
    td = env.reset()
    discrete = params.actuation.directions == "discrete"
    for _ in range(params.n_decisions):
        action = table_actions(t, td["signals"].view(c, n_swimmers, -1), discrete)
        td.set("action", action.reshape(1, c * n_swimmers, *action.shape[2:]))
        td = env.step(td)["next"]
    return env.score(td).view(c, n_swimmers).mean(1)


@dataclass(frozen=True)
class SearchResult:
    """The best table found, its objective, and the path of each start."""

    table: tuple[int, ...]
    value: float
    starts: list[dict]
    evaluations: int


def coordinate_ascent(params: EnvParams, n_swimmers: int, seed: int, runtime: Runtime,
                      n_random_starts: int = 3, max_sweeps: int = 4, tol: float = 1e-3,
                      search_seed: int = 0, starts: Sequence[Sequence[int]] = (NAIVE_TABLE,),
                      progress: Callable[[str], None] | None = None) -> SearchResult:
    """Coordinate ascent (module docstring) from the tables ``starts`` (the naive one by
    default) and ``n_random_starts`` random tables (drawn from ``search_seed``)."""
    gen = torch.Generator().manual_seed(search_seed)
    starts = [tuple(t) for t in starts] + [
        tuple(torch.randint(0, 4, (12,), generator=gen).tolist())
        for _ in range(n_random_starts)]
    runs, evaluations = [], 0
    for k, table in enumerate(starts):
        table = list(table)
        value = float(evaluate_tables([table], params, n_swimmers, seed, runtime)[0])
        evaluations += 1
        path = [value]
        for sweep in range(max_sweeps):
            changed = False
            for state in range(12):
                cands = []
                for a in range(4):
                    c = list(table)
                    c[state] = a
                    cands.append(c)
                values = evaluate_tables(cands, params, n_swimmers, seed, runtime)
                evaluations += 4
                best = int(values.argmax())
                value = float(values[table[state]])  # the current table, re-measured
                if best != table[state] and float(values[best]) > value + tol:
                    table[state], value, changed = best, float(values[best]), True
            path.append(value)
            if progress is not None:
                progress(f"start {k}, sweep {sweep}: {value:.3f} "
                         f"{''.join(ACTIONS[a][0] for a in table)}")
            if not changed:
                break
        runs.append({"start": list(starts[k]), "table": list(table), "value": value,
                     "path": path})
    best = max(runs, key=lambda r: r["value"])
    return SearchResult(tuple(best["table"]), best["value"], runs, evaluations)
