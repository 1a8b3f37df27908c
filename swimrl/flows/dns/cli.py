"""``swimrl-dns``: spin a DNS up to a statistically steady state and store it (Hydra CLI).

Phases (all resumable from the zarr store, see :mod:`swimrl.flows.dns.store`):

1. spin-up for ``spinup.time`` from ``init`` (rest or a random field); over its last
   ``spinup.measure_time`` the time averages ``u_rms = <u.u>^{1/2}`` and
   ``tau_K = <d_i u_j d_i u_j>^{-1/2}`` are measured from samples every ``store.diag_every``
   steps;
2. storing: ``store_every = max(1, round(interval_tau_k * tau_K / dt))`` solver steps between
   snapshots (``dt_store = store_every * dt``), ``store.n_times`` snapshots of ``omega_hat``;
   ``u_rms`` and ``tau_K`` attributes are then the averages over the stored snapshots.

Checkpoints (solver state + forcing RNG state + progress) are written every
``store.checkpoint_seconds`` and at the end of each phase; a rerun with the same config
continues from the last one. A finished store is never overwritten unless
``store.overwrite=true``. ``max_steps`` stops an invocation early (resumable).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import hydra
import torch
import zarr
from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

from swimrl.flows.dns import diagnostics as diag
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.state import random_state, zero_state
from swimrl.flows.dns.stepper import DNS
from swimrl.flows.dns.store import CHANNEL_NAMES, CHANNEL_UNITS, open_run_store

CONF_DIR = str(Path(__file__).resolve().parents[3] / "conf")

#: attributes that must match for a run to be resumed
RESUME_KEYS = ("n", "length", "nu", "alpha", "hypo_power", "epsilon", "k_f", "forcing_width",
               "dt", "dtype", "seed", "spinup_steps", "measure_steps", "interval_tau_k",
               "init_kind", "init_energy", "init_k_peak", "diag_every")


def sample(dns: DNS) -> dict[str, float]:
    """Diagnostics of realisation 0: ``t, E, Z``, the rates, ``<u.u> = 2E``, ``<A:A> = 2Z``."""
    s = {k: float(v[0]) for k, v in diag.scalar_summary(dns.grid, dns.params,
                                                        dns.state.omega_hat[:1]).items()}
    return {**s, "t": dns.state.step * dns.params.dt, "u2": 2 * s["energy"],
            "grad2": 2 * s["enstrophy"]}


def run_attrs(cfg: DictConfig, params: DNSParams) -> dict[str, Any]:
    """Root attributes of the store for ``cfg`` (parameters, schedule, conventions, units)."""
    dt = params.dt
    spin = max(1, round(cfg.spinup.time / dt))
    meas = min(spin, max(1, round(cfg.spinup.measure_time / dt)))
    p = params.to_dict()
    p.pop("device")
    return {
        **p,
        "seed": int(cfg.seed),
        "spinup_steps": spin,
        "measure_steps": meas,
        "interval_tau_k": float(cfg.store.interval_tau_k),
        "n_times_target": int(cfg.store.n_times),
        "diag_every": int(cfg.store.diag_every),
        "init_kind": str(cfg.init.kind),
        "init_energy": float(cfg.init.energy),
        "init_k_peak": float(cfg.init.k_peak),
        "equation": "d_t omega + u.grad omega = nu lap omega - alpha (-lap)^(-h) omega + f",
        "sign_convention": "u = (d_y psi, -d_x psi), omega = d_x u_y - d_y u_x = -lap psi",
        "grid": "nodes x_j = j L/N, fields indexed [iy, ix]",
        "dealias": "2/3 rule: |m_x|, |m_y| <= (N-1)//3 retained",
        "channel_names": list(CHANNEL_NAMES),
        "channel_units": list(CHANNEL_UNITS),
        "units": {"L": "code length (box side = length)", "T": "code time"},
        "forcing": "Gaussian white in time, spectrum exp(-(|k|-k_f)^2/(2 forcing_width^2)), "
                   "mean energy injection epsilon",
        "software": "swimrl.flows.dns",
    }


def _initial_state(cfg: DictConfig, dns: DNS):
    if cfg.init.kind == "rest":
        return zero_state(dns.grid, 1)
    if cfg.init.kind == "random":
        return random_state(dns.grid, [int(cfg.seed) + 1_000_003], float(cfg.init.energy),
                            float(cfg.init.k_peak))
    raise ValueError(f"init.kind={cfg.init.kind!r} out of range: must be 'rest' or 'random'")


def run_dns(cfg: DictConfig) -> Path:
    """Run (or resume) the DNS described by ``cfg``; returns the store path."""
    params = DNSParams.from_mapping(cfg.dns)
    if cfg.get("threads"):
        torch.set_num_threads(int(cfg.threads))
    path = Path(hydra.utils.to_absolute_path(str(cfg.store.path)))
    path.parent.mkdir(parents=True, exist_ok=True)
    attrs = run_attrs(cfg, params)
    extend_to = int(cfg.store.n_times) if cfg.store.get("extend", False) else None
    writer, resumed = open_run_store(path, attrs, RESUME_KEYS, bool(cfg.store.overwrite),
                                     int(cfg.store.chunk_times), extend_to=extend_to)
    dns = DNS(params, batch=1, seeds=[int(cfg.seed)])
    dns.state = _initial_state(cfg, dns)
    prog: dict[str, Any] = dict(writer.attrs)
    if resumed and writer.has_checkpoint():
        w, rng = writer.load_checkpoint()
        dns.state.omega_hat = w[None].to(dns.grid.device, dns.grid.complex_dtype)
        dns.state.step = int(prog["step"])
        dns.state.t = dns.state.step * params.dt
        if rng is not None and dns.forcing is not None:
            dns.forcing.set_rng_state(rng)
    n_target = int(cfg.store.n_times)
    spin, meas = attrs["spinup_steps"], attrs["measure_steps"]
    diag_every = attrs["diag_every"]
    acc = {k: float(prog.get(k, 0.0)) for k in ("m_u2", "m_grad2", "m_count",
                                                 "s_u2", "s_grad2", "s_count")}
    last_ck = time.monotonic()
    max_steps = cfg.get("max_steps")
    steps_here = 0

    def checkpoint(**extra: Any) -> None:
        nonlocal last_ck
        rng = dns.forcing.get_rng_state() if dns.forcing is not None else None
        writer.save_checkpoint(dns.state.omega_hat[0], rng, step=dns.state.step,
                               t=dns.state.t, **acc, **extra)
        last_ck = time.monotonic()

    def one_step() -> None:
        nonlocal steps_here
        dns.step()
        steps_here += 1
        if dns.state.step % diag_every == 0:
            row = sample(dns)
            writer.append_diagnostics(row)
            if spin - meas < dns.state.step <= spin:
                acc["m_u2"] += row["u2"]
                acc["m_grad2"] += row["grad2"]
                acc["m_count"] += 1

    def out_of_budget() -> bool:
        return max_steps is not None and steps_here >= int(max_steps)

    if not resumed:
        writer.commit(status="spinup", step=0, t=0.0)
    store_every = prog.get("store_every")
    total = spin + (n_target - 1) * int(store_every or 1)
    bar = tqdm(total=total, initial=min(dns.state.step, total), disable=not cfg.progress,
               desc=f"DNS {params.n}^2", unit="step", dynamic_ncols=True)
    # -- phase 1: spin-up --------------------------------------------------------------
    while dns.state.step < spin:
        one_step()
        bar.update(1)
        if dns.state.step % 200 == 0:
            bar.set_postfix(phase="spinup", t=f"{dns.state.t:.2f}", cfl=f"{dns.last_cfl:.2f}")
        if out_of_budget():
            checkpoint(status="spinup")
            bar.close()
            return path
        if time.monotonic() - last_ck > cfg.store.checkpoint_seconds:
            checkpoint(status="spinup")
    if store_every is None:
        count = max(acc["m_count"], 1.0)
        if acc["m_count"] == 0:  # measurement window shorter than diag_every: one sample
            row = sample(dns)
            acc["m_u2"], acc["m_grad2"] = row["u2"], row["grad2"]
        tau_k0 = (acc["m_grad2"] / count) ** -0.5
        u_rms0 = (acc["m_u2"] / count) ** 0.5
        store_every = max(1, round(attrs["interval_tau_k"] * tau_k0 / params.dt))
        checkpoint(status="storing", store_every=store_every, dt_store=store_every * params.dt,
                   tau_k_spinup=tau_k0, u_rms_spinup=u_rms0, step_first=dns.state.step,
                   t_first=dns.state.step * params.dt)
        bar.total = spin + (n_target - 1) * store_every
        prog = dict(writer.attrs)
    store_every = int(store_every)
    # -- phase 2: storing --------------------------------------------------------------
    n = writer.n_written
    expected = int(prog["step_first"]) + max(n - 1, 0) * store_every
    if n > 0 and dns.state.step != expected:
        raise RuntimeError(f"inconsistent checkpoint in {path}: step {dns.state.step} != "
                           f"{expected} expected after {n} snapshots")
    while n < n_target:
        if n > 0:
            for _ in range(store_every):
                one_step()
            bar.update(store_every)
        writer.append_snapshot(dns.state.omega_hat[0], dns.state.step * params.dt)
        row = sample(dns)
        acc["s_u2"] += row["u2"]
        acc["s_grad2"] += row["grad2"]
        acc["s_count"] += 1
        n += 1
        if n % 10 == 0:
            bar.set_postfix(phase="store", n=n, t=f"{dns.state.t:.2f}",
                            cfl=f"{dns.last_cfl or 0.0:.2f}")
        if n == n_target:
            break
        if out_of_budget():
            checkpoint(status="storing", **_stored_stats(acc))
            bar.close()
            return path
        if time.monotonic() - last_ck > cfg.store.checkpoint_seconds:
            checkpoint(status="storing", **_stored_stats(acc))
    checkpoint(status="complete", n_times=n, **_stored_stats(acc))
    bar.close()
    return path


def _stored_stats(acc: dict[str, float]) -> dict[str, float]:
    """``u_rms = <u.u>^{1/2}``, ``tau_k = <A:A>^{-1/2}`` averaged over the stored snapshots."""
    c = max(acc["s_count"], 1.0)
    return {"u_rms": (acc["s_u2"] / c) ** 0.5, "tau_k": (acc["s_grad2"] / c) ** -0.5}


def summary(path: str | Path) -> dict[str, Any]:
    """Main attributes of the store at ``path`` (printed at the end of a run)."""
    attrs = dict(zarr.open_group(str(path), mode="r").attrs)
    keys = ("status", "n", "n_written", "dt", "store_every", "dt_store", "u_rms", "tau_k",
            "u_rms_spinup", "tau_k_spinup")
    out = {k: attrs[k] for k in keys if k in attrs}
    out["path"] = str(path)
    if "tau_k" in out and "dt_store" in out:
        out["dt_store_over_tau_k"] = float(out["dt_store"]) / float(out["tau_k"])
    return out


@hydra.main(config_path=CONF_DIR, config_name="dns", version_base="1.3")
def main(cfg: DictConfig) -> None:
    """Entry point of ``swimrl-dns`` (see ``conf/dns.yaml`` and ``docs/dns.md``)."""
    path = run_dns(cfg)
    print(OmegaConf.to_yaml(OmegaConf.create(summary(path))))


if __name__ == "__main__":  # pragma: no cover
    main()
