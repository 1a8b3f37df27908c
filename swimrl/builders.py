"""Build flows, environments and runtime settings from a validated Hydra config."""

from __future__ import annotations

import os
from pathlib import Path

import torch
from omegaconf import DictConfig

from swimrl.config import EnvParams, resolve_device, resolve_dtype, validate_flow_cfg
from swimrl.env import SwimmerEnv
from swimrl.flows.fields import GriddedFlow
from swimrl.flows.stochastic import StochasticFlow
from swimrl.integrator import KERNELS


def setup_runtime(cfg: DictConfig) -> tuple[torch.device, torch.dtype]:
    """Validate device/dtype/threads/kernel and apply the thread count."""
    device = resolve_device(str(cfg.device))
    dtype = resolve_dtype(str(cfg.dtype))
    if str(cfg.kernel) not in KERNELS:
        raise ValueError(f"kernel={cfg.kernel!r} is invalid: allowed {list(KERNELS)}")
    threads = cfg.get("threads")
    if threads is not None and int(threads) < 1:
        raise ValueError(f"threads={threads} is invalid: allowed null or an integer >= 1")
    torch.set_num_threads(int(threads) if threads else (os.cpu_count() or 1))
    return device, dtype


def _replay_times(params: EnvParams, tau_k: float) -> dict[str, float]:
    """Decision interval and episode duration in the units of a DNS with Kolmogorov time tau_k."""
    return {
        "interval": params.update_interval * tau_k,
        "episode_time": params.duration * tau_k,
    }


def build_flow(
    cfg_flow: DictConfig,
    n_flows: int,
    device,
    dtype,
    generator: torch.Generator,
    params: EnvParams | None = None,
) -> GriddedFlow:
    """The flow backend named by ``flow.name``, with ``n_flows`` realisations.

    Replayed flows need the episode ``params`` (interval and duration in units of tau_K).
    """
    validate_flow_cfg(cfg_flow)
    common = {"device": device, "dtype": dtype, "generator": generator}
    if cfg_flow.name == "dns":
        from swimrl.flows.dns import DNSParams
        from swimrl.flows.live_dns import LiveDNSFlow, LiveDNSRun

        params = params or EnvParams()
        dns_params = DNSParams.from_mapping(
            {**cfg_flow.dns, "device": str(device), "dtype": str(dtype).replace("torch.", "")}
        )
        seeds = torch.randint(0, 2**31 - 1, (n_flows,), generator=generator, device=device)
        run = LiveDNSRun(
            dns_params,
            [int(x) for x in seeds.tolist()],
            spinup_time=float(cfg_flow.spinup_time),
            measure_time=float(cfg_flow.measure_time),
            snapshot_tau_k=float(cfg_flow.snapshot_tau_k),
        )
        return LiveDNSFlow(run, **_replay_times(params, run.tau_k), **common)
    if cfg_flow.name == "dns_replay":
        from swimrl.flows.dns.store import DNSStore
        from swimrl.flows.replay import ReplayFlow

        params = params or EnvParams()
        store = DNSStore(Path(str(cfg_flow.path)))
        return ReplayFlow(store, n_flows, **_replay_times(params, store.tau_k), **common)
    if cfg_flow.name == "stochastic":
        return StochasticFlow(
            n_flows,
            kubo=float(cfg_flow.kubo),
            n_modes=int(cfg_flow.n_modes),
            n_grid=int(cfg_flow.n_grid),
            spacing=float(cfg_flow.spacing),
            device=device,
            dtype=dtype,
            generator=generator,
        )
    raise ValueError(f"flow.name={cfg_flow.name!r} is not available in this build")


def build_env(
    cfg: DictConfig, n_flows: int, n_swimmers: int, seed: int, device, dtype
) -> SwimmerEnv:
    """Environment of ``n_flows x n_swimmers`` swimmers; all randomness from ``seed``."""
    params = EnvParams.from_cfg(cfg)
    gen = torch.Generator(device=device).manual_seed(int(seed))
    flow = build_flow(cfg.flow, n_flows, device, dtype, gen, params)
    return SwimmerEnv(flow, n_swimmers, params, generator=gen, kernel=str(cfg.kernel))
