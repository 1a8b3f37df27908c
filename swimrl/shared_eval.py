r"""Several strategies in the same flows at once: swimmers split into one block per strategy.

Swimmers do not act on the flow, so ``K`` strategies with ``S`` swimmers each can share one
environment of ``F`` flows x ``K S`` swimmers: block ``k`` (swimmers ``k S .. (k+1) S - 1``
of every flow) follows strategy ``k``. Every strategy then sees exactly the same flow
realisations (for a replayed DNS run: the same start times and snapshots), and the flow is
computed or decoded once for all of them — for ``flow=dns_replay``, whose cost is decoding
512² snapshots, the whole comparison costs about as much as one strategy. Initial positions
and orientations are drawn independently per swimmer, so the pairing between strategies is
per flow, exactly what the ratio's delta-method SEM uses.

``compare.shared_flows=true`` in ``swimrl-compare`` uses it.
"""

from __future__ import annotations

import time

import torch
from omegaconf import DictConfig
from tensordict import TensorDictBase
from torch import nn

from swimrl.builders import build_env, setup_runtime
from swimrl.evaluate import (
    chunk_seed,
    flow_statistics,
    mean_flow_stats,
    run_episodes,
    validate_eval_cfg,
)


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


@torch.no_grad()
def evaluate_shared(cfg: DictConfig, actors: list, seed: int | None = None) -> list[dict]:
    """Per-strategy metrics (``R_hat_mean/std/sem``, ``per_flow``, ...) on shared flows."""
    params = validate_eval_cfg(cfg)
    device, dtype = setup_runtime(cfg)
    seed = int(cfg.seed if seed is None else seed)
    n_flows, per_batch = int(cfg.eval.n_flows), int(cfg.eval.flows_per_batch)
    s, k = int(cfg.eval.n_swimmers), len(actors)
    router = SplitActor([a.to(device) for a in actors], s)
    per_flow: list[list[float]] = [[] for _ in range(k)]
    stats = []
    t0 = time.perf_counter()
    for c, i in enumerate(range(0, n_flows, per_batch)):
        env = build_env(cfg, min(per_batch, n_flows - i), k * s, chunk_seed(seed, c), device,
                        dtype)
        r_hat = run_episodes(env, router).double()
        stats.append(env.flow.measured_stats())
        for j in range(k):
            per_flow[j].extend(r_hat[:, j * s:(j + 1) * s].mean(dim=1).cpu().tolist())
    wall = time.perf_counter() - t0
    substeps_per_s = n_flows * k * s * params.n_decisions * params.n_substeps / wall
    flow_stats = mean_flow_stats(stats, "shared flows")
    return [{**flow_statistics(per_flow[j]), "n_flows": n_flows, "n_swimmers": s, "seed": seed,
             "wall_s": wall, "flow_stats": flow_stats, "swimmer_substeps_per_s": substeps_per_s}
            for j in range(k)]
