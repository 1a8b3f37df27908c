r"""``swimrl-eval``: performance index of a strategy on fresh flow realisations.

For each of ``eval.n_flows`` realisations, ``eval.n_swimmers`` swimmers start at uniformly
random positions and orientations and follow the strategy for ``T``; the performance index
(paper ``eq:reward2``) of a swimmer is ``R_hat = |x(T) - x_0| / (v_s T)``. The run writes
``metrics.json`` with the mean over flows of the per-flow mean (``R_hat_mean``), its standard
deviation over flows (``R_hat_std``) and standard error (``R_hat_sem = std / sqrt(n_flows)``).

Strategies that use no randomness see identical flows and initial conditions for the same
``seed`` (common random numbers), so differences between strategies are paired.

    swimrl-eval strategy=sto flow.kubo=10 eval.n_flows=10 eval.n_swimmers=200
"""

from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path

import hydra
import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf
from tqdm.auto import tqdm

from swimrl.builders import build_env, setup_runtime
from swimrl.config import STRATEGIES, EnvParams, validate_flow_cfg
from swimrl.paths import CONF_DIR, run_dir
from swimrl.strategies import build_strategy

log = logging.getLogger(__name__)


def chunk_seed(seed: int, chunk: int) -> int:
    """Independent seed for flow chunk ``chunk`` of an evaluation seeded with ``seed``."""
    return int(np.random.SeedSequence([int(seed), int(chunk)]).generate_state(1)[0])


def validate_eval_cfg(cfg: DictConfig) -> EnvParams:
    """All checks of an evaluation config, before any compute; returns the env parameters."""
    params = EnvParams.from_cfg(cfg)
    validate_flow_cfg(cfg.flow)
    if cfg.strategy.name not in STRATEGIES:
        raise ValueError(f"strategy={cfg.strategy.name!r} is invalid: allowed {list(STRATEGIES)}")
    for key in ("n_flows", "n_swimmers", "flows_per_batch"):
        if int(cfg.eval[key]) < 1:
            raise ValueError(f"eval.{key}={cfg.eval[key]} is invalid: allowed integer >= 1")
    return params


def load_actor(cfg: DictConfig, params: EnvParams):
    """The actor named by ``strategy`` (baselines) or ``policy`` (a trained policy)."""
    if cfg.strategy.name == "policy":
        if cfg.get("policy") is None:
            raise ValueError(
                "strategy=policy needs policy=<run dir | checkpoint | pretrained/NAME>"
            )
        from swimrl.policy_io import load_policy  # training stack, imported only when needed

        return load_policy(str(cfg.policy), params)
    return build_strategy(cfg.strategy, params.shape_factor_max)


@torch.no_grad()
def run_episodes(env, actor, progress: tqdm | None = None) -> torch.Tensor:
    """Run one full episode of every swimmer of ``env``; returns ``R_hat`` ``(F, S)``."""
    td = env.reset()
    for _ in range(env.params.n_decisions):
        td = env.step(actor(td)).get("next")
        if progress is not None:
            progress.update(1)
    return td.get("distance").squeeze(-1) / env.reference_distance


def evaluate(cfg: DictConfig, actor=None, seed: int | None = None) -> dict:
    """Evaluate ``actor`` (default: from the config) and return the metrics dictionary."""
    params = validate_eval_cfg(cfg)
    device, dtype = setup_runtime(cfg)
    actor = actor if actor is not None else load_actor(cfg, params)
    seed = int(cfg.seed if seed is None else seed)
    n_flows, per_batch = int(cfg.eval.n_flows), int(cfg.eval.flows_per_batch)
    n_swimmers = int(cfg.eval.n_swimmers)
    chunks = [min(per_batch, n_flows - i) for i in range(0, n_flows, per_batch)]
    bar = tqdm(
        total=len(chunks) * params.n_decisions,
        desc=f"eval {cfg.strategy.name}",
        unit="step",
        disable=not cfg.eval.progress,
        mininterval=2.0,
    )
    per_flow, stats, sim_s = [], [], 0.0
    t_start = time.perf_counter()
    for c, n_c in enumerate(chunks):
        env = build_env(cfg, n_c, n_swimmers, chunk_seed(seed, c), device, dtype)
        actor = actor.to(device)
        t0 = time.perf_counter()
        r_hat = run_episodes(env, actor, bar)
        sim_s += time.perf_counter() - t0
        stats.append(env.flow.measured_stats())
        per_flow.extend(r_hat.double().mean(dim=1).cpu().tolist())
    bar.close()
    wall = time.perf_counter() - t_start
    substeps = n_flows * n_swimmers * params.n_decisions * params.n_substeps
    return {
        "strategy": cfg.strategy.name,
        **flow_statistics(per_flow),
        "n_flows": n_flows,
        "n_swimmers": n_swimmers,
        "seed": seed,
        "flow_stats": mean_flow_stats(stats, "averaged over flow chunks"),
        "wall_s": wall,
        "swimmer_substeps_per_s": substeps / sim_s,
        "config": OmegaConf.to_container(cfg, resolve=True),
    }


def flow_statistics(per_flow: list[float]) -> dict:
    """``R_hat_mean``, ``R_hat_std`` (over flows, ``ddof = 1``), ``R_hat_sem = std / sqrt(n)``
    and ``per_flow`` from the per-flow means of ``R_hat``."""
    arr = np.asarray(per_flow)
    std = float(arr.std(ddof=1)) if arr.size > 1 else 0.0
    return {"R_hat_mean": float(arr.mean()), "R_hat_std": std,
            "R_hat_sem": std / math.sqrt(arr.size), "per_flow": list(per_flow)}


def mean_flow_stats(stats: list[dict], how: str) -> dict:
    """Mean of the flows' ``measured_stats()`` (``u_rms``, ``tau_K``) over environments."""
    return {
        "u_rms": float(np.mean([s["u_rms"] for s in stats])),
        "tau_K": float(np.mean([s["tau_K"] for s in stats])),
        "note": f"grid averages at the end of each episode, {how}",
    }


def summary_line(m: dict) -> str:
    """One line: strategy, flow, R_hat +- SEM, size, time and speed."""
    flow = m["config"]["flow"]
    knob = f"Ku={flow['kubo']:g}" if flow["name"] == "stochastic" else flow["name"]
    return (
        f"{m['strategy']} {knob}: R_hat = {m['R_hat_mean']:.4f} +- {m['R_hat_sem']:.4f} (SEM; "
        f"std over flows {m['R_hat_std']:.4f}) over {m['n_flows']} flows x {m['n_swimmers']} "
        f"swimmers; {m['wall_s']:.1f} s, {m['swimmer_substeps_per_s']:.3g} swimmer-substeps/s"
    )


def write_metrics(metrics: dict, out: Path, overwrite: bool) -> Path:
    """Write ``metrics.json`` atomically; refuse to replace an existing one unless asked."""
    path = out / "metrics.json"
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=true to replace it")
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(metrics, indent=2))
    tmp.replace(path)
    return path


@hydra.main(config_path=str(CONF_DIR), config_name="evaluate", version_base="1.3")
def main(cfg: DictConfig) -> dict:
    out = run_dir()
    if (out / "metrics.json").exists() and not cfg.overwrite:
        raise FileExistsError(f"{out / 'metrics.json'} exists; pass overwrite=true to replace it")
    metrics = evaluate(cfg)
    path = write_metrics(metrics, out, bool(cfg.overwrite))
    print(summary_line(metrics))
    log.info("wrote %s", path)
    return metrics


if __name__ == "__main__":
    main()
