r"""A DNS run stored for replay: spin-up to a steady state, then snapshots (``swimrl-dns``).

Phases (all resumable from the zarr store, see :mod:`swimrl.flows.dns.store`):

1. spin-up for ``spinup_time`` from ``init`` (rest or a random field); over its last
   ``measure_time`` the time averages
   $u_\mathrm{rms} = \langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$ and
   $\tau_K = \langle\partial_i u_j\,\partial_i u_j\rangle^{-1/2}$ are measured from samples
   every ``diag_every`` steps
   (:mod:`swimrl.flows.dns.spinup`);
2. storing: ``store_every = max(1, round(interval_tau_k * tau_K / dt))`` solver steps between
   snapshots (``dt_store = store_every * dt``), ``n_times`` snapshots of ``omega_hat``;
   ``u_rms`` and ``tau_K`` attributes are then the averages over the stored snapshots.

Checkpoints (solver state + forcing RNG state + progress) are written every
``checkpoint_seconds`` and at the end of each phase; a rerun with the same parameters
continues from the last one. A finished store is never overwritten unless ``overwrite``.
``max_steps`` stops an invocation early (resumable).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zarr
from tqdm import tqdm

from swimrl.conf_values import yaml_value
from swimrl.errors import as_bool, as_float, as_int, keep_number_types, one_of
from swimrl.flows.base import CHANNELS
from swimrl.flows.dns import diagnostics as diag
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.spinup import ScaleMeter, SpinupSchedule
from swimrl.flows.dns.state import random_state, zero_state
from swimrl.flows.dns.stepper import DNS
from swimrl.flows.dns.store import CHANNEL_UNITS, check_run_store, open_run_store

INIT_KINDS = ("rest", "random")


@dataclass(frozen=True)
class DNSRun:
    """Everything ``swimrl-dns`` needs (``conf/dns.yaml``; keys in the error messages). The
    defaults (for library calls) are read from ``conf/dns.yaml`` (:mod:`swimrl.conf_values`)."""

    params: DNSParams
    seed: int
    init_kind: str
    init_energy: float
    init_k_peak: float
    spinup_time: float
    measure_time: float
    path: Path
    n_times: int
    interval_tau_k: float
    chunk_times: int = yaml_value("dns", "store.chunk_times")
    overwrite: bool = yaml_value("dns", "store.overwrite")
    extend: bool = yaml_value("dns", "store.extend")
    checkpoint_seconds: float = yaml_value("dns", "store.checkpoint_seconds")
    diag_every: int = yaml_value("dns", "store.diag_every")
    max_steps: int | None = yaml_value("dns", "max_steps")
    progress: bool = yaml_value("dns", "progress")

    def __post_init__(self) -> None:
        as_int("seed", self.seed, low=0)
        object.__setattr__(self, "init_kind", str(self.init_kind))
        one_of("init.kind", self.init_kind, INIT_KINDS)
        as_float("init.energy", self.init_energy, lambda v: v > 0, "> 0")
        as_float("init.k_peak", self.init_k_peak, lambda v: v > 0, "> 0")
        as_float("spinup.time", self.spinup_time, lambda v: v > 0, "> 0 (code time units)")
        as_float("spinup.measure_time", self.measure_time, lambda v: 0 < v <= self.spinup_time,
                 f"in (0, spinup.time={self.spinup_time}]")
        as_int("store.n_times", self.n_times)
        as_float("store.interval_tau_k", self.interval_tau_k, lambda v: v > 0, "> 0")
        as_int("store.chunk_times", self.chunk_times)
        as_bool("store.overwrite", self.overwrite)
        as_bool("store.extend", self.extend)
        as_float("store.checkpoint_seconds", self.checkpoint_seconds, lambda v: v > 0, "> 0")
        as_int("store.diag_every", self.diag_every)
        if self.max_steps is not None:
            as_int("max_steps", self.max_steps)
        as_bool("progress", self.progress)
        keep_number_types(self)

    @property
    def spinup(self) -> SpinupSchedule:
        """Spin-up steps, measured steps, and diagnostics every ``diag_every`` steps."""
        return SpinupSchedule.from_times(self.spinup_time, self.measure_time, self.params.dt,
                                         self.diag_every)


#: attributes that must match for a run to be resumed
RESUME_KEYS = ("n", "length", "nu", "alpha", "hypo_power", "epsilon", "k_f", "forcing_width",
               "dt", "dtype", "seed", "spinup_steps", "measure_steps", "interval_tau_k",
               "init_kind", "init_energy", "init_k_peak", "diag_every")


def sample(dns: DNS) -> dict[str, float]:
    r"""Diagnostics of realisation 0: $t, E, Z$, the rates,
    $\langle\boldsymbol u\cdot\boldsymbol u\rangle = 2E$,
    $\langle\mathbb A:\mathbb A\rangle = 2Z$."""
    s = {k: float(v[0]) for k, v in diag.scalar_summary(dns.grid, dns.params,
                                                        dns.state.omega_hat[:1]).items()}
    return {**s, "t": dns.state.step * dns.params.dt, "u2": 2 * s["energy"],
            "grad2": 2 * s["enstrophy"]}


def run_attrs(run: DNSRun) -> dict[str, Any]:
    """Root attributes of the store of ``run`` (parameters, schedule, conventions, units)."""
    sched = run.spinup
    p = run.params.to_dict()
    p.pop("device")
    return {
        **p,
        "seed": int(run.seed),
        "spinup_steps": sched.steps,
        "measure_steps": sched.measure_steps,
        "interval_tau_k": float(run.interval_tau_k),
        "n_times_target": int(run.n_times),
        "diag_every": int(run.diag_every),
        "init_kind": str(run.init_kind),
        "init_energy": float(run.init_energy),
        "init_k_peak": float(run.init_k_peak),
        "equation": "d_t omega + u.grad omega = nu lap omega - alpha (-lap)^(-h) omega + f",
        "sign_convention": "u = (d_y psi, -d_x psi), omega = d_x u_y - d_y u_x = -lap psi",
        "grid": "nodes x_j = j L/N, fields indexed [iy, ix]",
        "dealias": "2/3 rule: |m_x|, |m_y| <= (N-1)//3 retained",
        "channel_names": list(CHANNELS),
        "channel_units": list(CHANNEL_UNITS),
        "units": {"L": "code length (box side = length)", "T": "code time"},
        "forcing": "Gaussian white in time, spectrum exp(-(|k|-k_f)^2/(2 forcing_width^2)), "
                   "mean energy injection epsilon",
        "software": "swimrl.flows.dns",
    }


def _initial_state(run: DNSRun, dns: DNS):
    if run.init_kind == "rest":
        return zero_state(dns.grid, 1)
    return random_state(dns.grid, [int(run.seed) + 1_000_003], float(run.init_energy),
                        float(run.init_k_peak))


def _meter(prog: dict[str, Any], prefix: str) -> ScaleMeter:
    """A scale meter restored from the progress attributes ``{prefix}u2`` etc."""
    return ScaleMeter(*(float(prog.get(prefix + k, 0.0)) for k in ("u2", "grad2", "count")))


def _meter_attrs(meter: ScaleMeter, prefix: str) -> dict[str, float]:
    return {prefix + "u2": meter.u2, prefix + "grad2": meter.grad2, prefix + "count": meter.count}


def check_run(run: DNSRun) -> str:
    """What :func:`run_dns` will do with the store (``"create"``, ``"replace"``,
    ``"resume"``), checked without touching it; raises for a store it refuses."""
    return check_run_store(run.path, run_attrs(run), RESUME_KEYS, bool(run.overwrite),
                           int(run.n_times) if run.extend else None)


def run_dns(run: DNSRun) -> Path:
    """Run (or resume) the DNS described by ``run``; returns the store path."""
    params = run.params
    path = Path(run.path)
    path.parent.mkdir(parents=True, exist_ok=True)
    attrs = run_attrs(run)
    extend_to = int(run.n_times) if run.extend else None
    writer, resumed = open_run_store(path, attrs, RESUME_KEYS, bool(run.overwrite),
                                     int(run.chunk_times), extend_to=extend_to)
    dns = DNS(params, batch=1, seeds=[int(run.seed)])
    dns.state = _initial_state(run, dns)
    prog: dict[str, Any] = dict(writer.attrs)
    if resumed and int(prog.get("step", 0)) > 0:
        w, rng = writer.load_checkpoint()
        if not bool(w.any()):
            raise FileExistsError(f"{path}: the checkpoint of step {prog['step']} is all zeros "
                                  "(damaged); pass store.overwrite=true to start again")
        dns.state.omega_hat = w[None].to(dns.grid.device, dns.grid.complex_dtype)
        dns.state.step = int(prog["step"])
        dns.state.t = dns.state.step * params.dt
        if rng is not None and dns.forcing is not None:
            dns.forcing.set_rng_state(rng)
    n_target = int(run.n_times)
    sched = run.spinup
    spin = sched.steps
    spin_meter, store_meter = _meter(prog, "m_"), _meter(prog, "s_")
    last_ck = time.monotonic()
    max_steps = run.max_steps
    steps_here = 0

    def checkpoint(**extra: Any) -> None:
        nonlocal last_ck
        rng = dns.forcing.get_rng_state() if dns.forcing is not None else None
        writer.save_checkpoint(dns.state.omega_hat[0], rng, step=dns.state.step,
                               t=dns.state.t, **_meter_attrs(spin_meter, "m_"),
                               **_meter_attrs(store_meter, "s_"), **extra)
        last_ck = time.monotonic()

    def one_step() -> None:
        nonlocal steps_here
        dns.step()
        steps_here += 1
        if dns.state.step % sched.sample_every == 0:
            row = sample(dns)
            writer.append_diagnostics(row)
            if sched.measures(dns.state.step):
                spin_meter.add(row["u2"], row["grad2"])

    def out_of_budget() -> bool:
        return max_steps is not None and steps_here >= int(max_steps)

    if not resumed:
        writer.commit(status="spinup", step=0, t=0.0)
    store_every = prog.get("store_every")
    total = spin + (n_target - 1) * int(store_every or 1)
    bar = tqdm(total=total, initial=min(dns.state.step, total), disable=not run.progress,
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
        if time.monotonic() - last_ck > run.checkpoint_seconds:
            checkpoint(status="spinup")
    if store_every is None:
        if spin_meter.count == 0:  # measurement window shorter than diag_every: one sample
            row = sample(dns)
            spin_meter.add(row["u2"], row["grad2"])
        scales = spin_meter.scales()
        store_every = max(1, round(attrs["interval_tau_k"] * scales["tau_k"] / params.dt))
        checkpoint(status="storing", store_every=store_every, dt_store=store_every * params.dt,
                   tau_k_spinup=scales["tau_k"], u_rms_spinup=scales["u_rms"],
                   step_first=dns.state.step, t_first=dns.state.step * params.dt)
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
        store_meter.add(row["u2"], row["grad2"])
        n += 1
        if n % 10 == 0:
            bar.set_postfix(phase="store", n=n, t=f"{dns.state.t:.2f}",
                            cfl=f"{dns.last_cfl or 0.0:.2f}")
        if n == n_target:
            break
        if out_of_budget():
            checkpoint(status="storing", **store_meter.scales())
            bar.close()
            return path
        if time.monotonic() - last_ck > run.checkpoint_seconds:
            checkpoint(status="storing", **store_meter.scales())
    checkpoint(status="complete", n_times=n, **store_meter.scales())
    bar.close()
    return path


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
