r"""The evaluation loop: full episodes of every swimmer, on fresh flow realisations.

For each of ``n_flows`` realisations, ``n_swimmers`` swimmers start at uniformly random
positions and orientations and follow a strategy for ``T``; the performance index (paper
``eq:reward2``) of a swimmer is ``R_hat = |x(T) - x_0| / (v_s T)``; the statistics over
flows are those of :mod:`swimrl.evaluation.statistics`. Flows are simulated in chunks of
``flows_per_batch``; chunk ``c`` is seeded with ``SeedSequence([seed, c])``, so strategies
that use no randomness see identical flows and initial conditions for the same ``seed``
(common random numbers) and their differences are paired.

Several strategies can share the flows: swimmers do not act on the flow, so ``K`` strategies
with ``S`` swimmers each run in one environment of ``F`` flows x ``K S`` swimmers, block
``k`` (swimmers ``k S .. (k+1) S - 1`` of every flow) following strategy ``k``
(:class:`SplitActor`). The flow is then computed (or a stored run decoded) once for all.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModule
from torch import nn
from tqdm.auto import tqdm

from swimrl.env import EnvParams, SwimmerEnv, build_env
from swimrl.errors import ConfigError, as_bool
from swimrl.flows.build import FLOW_WORK_BYTES, flow_table_bytes
from swimrl.flows.dns.flow import StoredRunSpec
from swimrl.flows.dns.store import store_record
from swimrl.policies.baselines import StrategySpec, build_strategy
from swimrl.policies.networks import check_action
from swimrl.runs.jobs import EvaluationInterruptedError, Preemption
from swimrl.runs.policy_files import load_policy
from swimrl.runs.spec import EvalSizes, RunSpec
from swimrl.runtime import check_memory

from .statistics import chunk_outcomes, flow_statistics, mean_flow_stats, outcome_statistics
from .trajectories import TrajectoryRecorder

#: A strategy to evaluate: a baseline (built against the environment's action spec) or an
#: actor module (e.g. a loaded or a training policy).
Actor = StrategySpec | TensorDictModule


@dataclass(frozen=True)
class EvalConfig:
    """``swimrl-eval``: one strategy (a baseline, or ``policy`` with a policy spec) on ``setup``."""

    setup: RunSpec
    strategy: StrategySpec
    policy: str | None
    overwrite: bool

    def __post_init__(self) -> None:
        if self.policy is not None:
            object.__setattr__(self, "policy", str(self.policy))
        as_bool("overwrite", self.overwrite)
        if self.strategy.name == "policy" and self.policy is None:
            raise ConfigError(
                "policy=None is invalid: strategy=policy needs policy=<run dir | checkpoint | "
                "pretrained/NAME>"
            )
        self.strategy.check_bound(self.setup.params.shape_factor_max)
        self.strategy.check_dimension(self.setup.dimension)
        self.strategy.check_actuation(self.setup.params.actuation)


#: Bytes per swimmer of state, observations and integration temporaries (an upper estimate).
SWIMMER_BYTES = 512


def check_eval_memory(setup: RunSpec, n_strategies: int = 1) -> None:
    """Refuse (one line naming ``eval.flows_per_batch``) a chunk of ``flows_per_batch`` flows,
    ``n_strategies x n_swimmers`` swimmers each, whose flow tables, swimmers and work memory
    (:func:`~swimrl.flows.build.flow_table_bytes`, :data:`SWIMMER_BYTES`,
    :data:`~swimrl.flows.build.FLOW_WORK_BYTES`) exceed the device's available memory."""
    sizes, dtype = setup.sizes, setup.runtime.dtype
    flows = min(sizes.flows_per_batch, sizes.n_flows)
    table = flow_table_bytes(setup.flow, flows, dtype, setup.params.update_interval)
    swimmers = flows * n_strategies * sizes.n_swimmers * SWIMMER_BYTES
    check_memory(table + swimmers + FLOW_WORK_BYTES, setup.runtime.device,
                 "eval.flows_per_batch", sizes.flows_per_batch,
                 f"the flow tables of {flows} flows ({table / 2**30:.1f} GiB), "
                 f"{flows * n_strategies * sizes.n_swimmers} swimmers and work memory")


def chunk_seed(seed: int, chunk: int) -> int:
    """Independent seed for flow chunk ``chunk`` of an evaluation seeded with ``seed``."""
    return int(np.random.SeedSequence([int(seed), int(chunk)]).generate_state(1)[0])


def actor_for(strategy: StrategySpec, policy: str | None, params: EnvParams) -> Actor:
    """The baseline ``strategy``, or for ``strategy=policy`` the policy file ``policy``."""
    if strategy.name != "policy":
        return strategy
    return load_policy(str(policy), params)


@torch.no_grad()
def run_episodes(
    env: SwimmerEnv,
    actor,
    progress: tqdm | None = None,
    on_decision: Callable[[int, TensorDictBase], None] | None = None,
    preemption: Preemption | None = None,
) -> torch.Tensor:
    """One full episode of every swimmer of ``env``; returns ``R_hat`` ``(F, S)``
    (:meth:`~swimrl.env.SwimmerEnv.score`; the other outcomes: ``env.outcomes()``).

    ``on_decision(i, td)`` sees decision ``i`` (signals and action) before the step. Once
    ``preemption`` is requested (a signal) the episode stops before the next decision with
    :class:`~.jobs.EvaluationInterruptedError` (a decision takes milliseconds: the signal is
    answered within one). The loop reads no tensor value, so it never waits on the device.
    """
    td = env.reset()
    for i in range(env.params.n_decisions):
        if preemption is not None and preemption.requested:
            raise EvaluationInterruptedError(i)
        td = actor(td)
        if on_decision is not None:
            on_decision(i, td)
        td = env.step(td).get("next")
        if progress is not None:
            progress.update(1)
    return env.score(td)


class SplitActor(nn.Module):
    """Route swimmer block ``k`` (``td[:, k S:(k+1) S]``) to ``actors[k]``; writes ``action``."""

    def __init__(self, actors: list, block: int):
        super().__init__()
        self.actors = nn.ModuleList(actors)
        self.block = int(block)

    def forward(self, td: TensorDictBase) -> TensorDictBase:
        s = self.block
        actions = [a(td[:, k * s:(k + 1) * s].clone(False)).get("action")
                   for k, a in enumerate(self.actors)]
        td.set("action", torch.cat(actions, dim=1))
        return td


def flow_chunks(sizes: EvalSizes) -> list[int]:
    """Flows per chunk: ``n_flows`` in chunks of ``flows_per_batch`` (the last one smaller)."""
    n, per = sizes.n_flows, sizes.flows_per_batch
    return [min(per, n - i) for i in range(0, n, per)]


def check_chunks(done: Sequence[dict], chunks: Sequence[int], k: int) -> None:
    """ValueError unless ``done`` are the results of chunks ``0, 1, ..`` of ``chunks`` (flows
    per chunk) for ``k`` strategies, each with its times and flow statistics."""
    if len(done) > len(chunks):
        raise ValueError(f"{len(done)} chunks done of {len(chunks)}")
    for c, chunk in enumerate(done):
        ok = (isinstance(chunk, dict) and chunk.get("chunk") == c
              and {"flow_stats", "sim_s", "wall_s"} <= set(chunk)
              and len(chunk.get("per_flow", ())) == k
              and all(len(f) == chunks[c] for f in chunk["per_flow"]))
        if not ok:
            raise ValueError(f"chunk {c} is not {chunks[c]} flows for each of {k} strategies "
                             "with flow_stats, sim_s and wall_s")


def evaluate_shared(setup: RunSpec, actors: Sequence[Actor], desc: str = "eval",
                    recorder: TrajectoryRecorder | None = None,
                    done: Sequence[dict] = (),
                    on_chunk: Callable[[dict], None] | None = None,
                    preemption: Preemption | None = None) -> list[dict]:
    """Per-strategy metrics (``R_hat_mean/std/sem``, ``per_flow``, ...) of ``actors`` on the
    same flows, ``n_swimmers`` swimmers each from the same initial conditions (block ``j``
    of the environment is actor ``j``'s; each block's result is the plain evaluation of its
    actor, as long as the dynamics has no noise); ``recorder``
    records every decision of its first swimmers of each flow and strategy.

    Resumable by flow chunk: chunk ``c`` depends only on ``(seed, c)``, so the chunk results
    ``done`` (``{"chunk": c, "per_flow": [[..] per actor], "flow_stats": .., "sim_s": ..,
    "wall_s": .., "outcomes": [.. per actor]}``, :func:`~.statistics.chunk_outcomes`, as
    handed to ``on_chunk`` after each chunk) stand for chunks
    ``0 .. len(done) - 1``, which are not simulated again; the per-flow results are the
    uninterrupted evaluation's, and the times add up over the legs. ``preemption``: see
    :func:`run_episodes` (:class:`~.jobs.EvaluationInterruptedError` inside a chunk; the chunks
    handed to ``on_chunk`` before it stand).

    Parameters
    ----------
    setup
        Flow, physics, runtime, sizes and seed (:class:`RunSpec`).
    actors
        Baselines (:class:`~swimrl.policies.baselines.StrategySpec`) or actor modules (e.g.
        :func:`~swimrl.runs.policy_files.load_policy`), one block of swimmers each.
    desc, recorder, done, on_chunk, preemption
        Progress label; trajectory recorder; chunk results to reuse; callback after each
        chunk; the signal flag read between decisions.

    Returns
    -------
    list of dict
        Per actor: ``R_hat_mean``, ``R_hat_std``, ``R_hat_sem`` (over flows), ``per_flow``,
        ``energy_mean`` and the task's outcomes, ``flow_stats`` (measured ``u_rms``,
        ``tau_K``), sizes, seed, timings and the config record.
    """
    sizes, params = setup.sizes, setup.params
    setup.runtime.apply()
    n_flows, s, k = sizes.n_flows, sizes.n_swimmers, len(actors)
    chunks = flow_chunks(sizes)
    check_chunks(done, chunks, k)
    bar = tqdm(total=(len(chunks) - len(done)) * params.n_decisions, desc=desc, unit="step",
               disable=not sizes.progress, mininterval=2.0)
    results, router = list(done), None
    t_start = time.perf_counter() - sum(chunk["wall_s"] for chunk in done)
    for c, n_c in enumerate(chunks[len(done):], start=len(done)):
        t_chunk = time.perf_counter()
        env = build_env(setup.flow, params, setup.runtime, n_c, k * s,
                        chunk_seed(setup.seed, c), ic_blocks=k)
        if router is None:
            spec = env.action_spec_unbatched
            modules = [build_strategy(a, spec) if isinstance(a, StrategySpec) else a
                       for a in actors]
            for m in modules:  # an actor that knows its action (a policy's) must fit the env's
                if getattr(m, "action_spec", None) is not None:
                    check_action(m.action_spec, spec, getattr(m, "source", "the policy"))
            modules = [m.to(setup.runtime.device) for m in modules]
            router = modules[0] if k == 1 else SplitActor(modules, s)
        t0 = time.perf_counter()
        if recorder is not None:
            recorder.start(env, s, k)
        r_hat = run_episodes(env, router, bar, on_decision=recorder,
                             preemption=preemption).double()
        env.check_displacement()
        outcomes = env.outcomes()
        if recorder is not None:
            recorder.finish(r_hat)
        chunk_s = time.perf_counter() - t0
        result = [r_hat[:, j * s:(j + 1) * s].mean(dim=1).cpu().tolist() for j in range(k)]
        per_actor = [chunk_outcomes(outcomes, slice(j * s, (j + 1) * s), params.update_interval)
                     for j in range(k)]
        results.append({"chunk": c, "per_flow": result, "flow_stats": env.flow.measured_stats(),
                        "sim_s": chunk_s, "wall_s": time.perf_counter() - t_chunk,
                        "outcomes": per_actor})
        if on_chunk is not None:
            on_chunk(results[-1])
    bar.close()
    per_flow = [[x for chunk in results for x in chunk["per_flow"][j]] for j in range(k)]
    stats = [chunk["flow_stats"] for chunk in results]
    sim_s = sum(chunk["sim_s"] for chunk in results)
    wall = time.perf_counter() - t_start
    substeps = n_flows * k * s * params.n_decisions * params.n_substeps
    how = "averaged over flow chunks" + (f", shared by {k} strategies" if k > 1 else "")
    flow_stats = mean_flow_stats(stats, how)
    store = {}
    if isinstance(setup.flow, StoredRunSpec):
        records = [store_record(p) for p in setup.flow.paths]
        store = {"flow_store": records[0]} if len(records) == 1 else {"flow_stores": records}
    outcomes = [outcome_statistics([chunk.get("outcomes", [{}] * k)[j] for chunk in results],
                                   params.update_interval, params.n_decisions)
                for j in range(k)]
    task = {"task": params.task.name}
    if params.task.target:
        task.update(target_distance=params.task.distance,
                    arrival_radius=params.task.arrival_radius)
    return [{**flow_statistics(per_flow[j]), **outcomes[j], **task,
             "n_flows": n_flows, "n_swimmers": s,
             "seed": setup.seed, "flow_stats": flow_stats, **store, "wall_s": wall,
             "swimmer_substeps_per_s": substeps / sim_s, "config": setup.record}
            for j in range(k)]


def evaluate(setup: RunSpec, actor: Actor, strategy: str,
             recorder: TrajectoryRecorder | None = None,
             preemption: Preemption | None = None) -> dict:
    """Metrics of one strategy (named ``strategy`` in the record) on ``setup``; stopped
    between two decisions by ``preemption`` (:class:`~.jobs.EvaluationInterruptedError`).

    Parameters
    ----------
    setup
        Flow, physics, runtime, sizes and seed (:class:`RunSpec`).
    actor
        A baseline spec or an actor module (:func:`~swimrl.runs.policy_files.load_policy`).
    strategy
        Its name in the record.
    recorder, preemption
        Optional trajectory recorder; the signal flag read between decisions.

    Returns
    -------
    dict
        ``strategy`` and the metrics of :func:`evaluate_shared` (``R_hat_mean``,
        ``R_hat_sem``, ``per_flow``, ...).
    """
    (m,) = evaluate_shared(setup, [actor], desc=f"eval {strategy}", recorder=recorder,
                           preemption=preemption)
    return {"strategy": strategy, **m}
