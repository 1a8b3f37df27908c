"""Throughput of the swimmer environment: swimmer-substeps per second and ms per env step.

A substep is one Heun step ``dt`` of one swimmer (two flow evaluations); a decision interval
is ``K = T_u/dt`` substeps of every swimmer. Prints, for each batch ``n_flows x n_swimmers``
and kernel (``kernel=eager|fused|compiled``: the eager torch reference, the fused C++ CPU
kernel, ``torch.compile(fullgraph=True)`` of the interval), the best of ``--repeats`` timings
of ``--intervals`` consecutive

* decision intervals (:meth:`SwimmerEnv.integrate`): swimmer-substeps/s and ms per interval;
* env steps (``env.step``: the interval + signals, reward, done flags, TorchRL's
  bookkeeping: what the collector calls once per decision): ms per env step;

and the seconds of the first (warm-up) interval, where ``compiled`` compiles, and the share of
the timed intervals' CPU time spent in the kernel (``sys %``: page faults, mostly).
``--malloc retain`` (default, as every ``swimrl-*`` command on the CPU) keeps freed buffers in
the heap (:func:`swimrl.runtime.retain_freed_memory`); ``--malloc default`` leaves glibc's
defaults, which map and unmap the 3D flow's large temporaries every call:

    python benchmarks/bench_env.py --flow stochastic3d --threads 1 --batches 10x1000 \
        --kernels compiled --malloc default

    python benchmarks/bench_env.py --device cpu --threads 2
    python benchmarks/bench_env.py --threads 1 --batches 64x64 --kernels fused compiled
    python benchmarks/bench_env.py --device cuda --batches 256x64 --kernels eager compiled
    python benchmarks/bench_env.py --smoke          # a tiny grid and batch, seconds
    python benchmarks/bench_env.py --flow stochastic3d --threads 1 --batches 512x8 64x8

``--flow stochastic3d``: the 3D stochastic flow (random Fourier modes evaluated at the
swimmers, ``--n-waves`` per component; kernels ``eager``, ``compiled``, the compiled mode
sum of :func:`swimrl.flows.stochastic3d.compiled_mode_sum`, and ``fused``, the fused C++
kernel of the 3D interval, :func:`swimrl.physics.integrator.integrate_interval_3d_fused`):

    python benchmarks/bench_env.py --flow stochastic3d --threads 1 --batches 512x8 \
        --kernels compiled fused
"""

from __future__ import annotations

import argparse
import resource
import time

import torch

from swimrl.env import EnvParams, SwimmerEnv, env_from_flow
from swimrl.flows.stochastic import StochasticFlow
from swimrl.flows.stochastic3d import StochasticFlow3D
from swimrl.physics.body3d import SIGNAL_NAMES_3D
from swimrl.runtime import retain_freed_memory

DEFAULT_BATCHES = ["1x1000", "10x100", "10x1000", "100x100", "1x10000", "10x10000", "1x100000"]
#: The GPU floor's batch (docs/training.md, issue 46): train_preset=parallel_gpu, 16 384 swimmers.
GPU_FLOOR_BATCH = "256x64"
KERNELS = ("eager", "fused", "compiled")
#: --smoke: a 64^2 grid of spacing 0.1, 2 flows x 8 swimmers, one interval, one repeat.
SMOKE = {"n_grid": 64, "spacing": 0.1, "batches": ["2x8"], "intervals": 1, "repeats": 1}


def _sync(device: str) -> None:
    if device.startswith("cuda"):
        torch.cuda.synchronize()


def measure(flows: int, swimmers: int, kernel: str, args) -> dict:
    """Best swimmer-substeps/s, ms per interval and ms per env step over the repeats (after one
    warm-up interval and one warm-up env step)."""
    gen = torch.Generator(device=args.device).manual_seed(0)
    if args.flow == "stochastic3d":
        flow = StochasticFlow3D(flows, args.kubo, n_waves=args.n_waves, device=args.device,
                                generator=gen)
        env = env_from_flow(flow, swimmers, EnvParams(signals=SIGNAL_NAMES_3D),
                            kernel=kernel)
    else:
        flow = StochasticFlow(flows, args.kubo, n_grid=args.n_grid, spacing=args.spacing,
                              device=args.device, generator=gen)
        env = SwimmerEnv(flow, swimmers, EnvParams(), kernel=kernel)
    td = env.reset()
    td.set("action", torch.full(env.action_spec.shape, 0.98, device=args.device))
    lam = torch.full((flows * swimmers,), 0.98, device=args.device)
    _sync(args.device)
    t0 = time.perf_counter()
    env.integrate(lam)  # compiles (kernel=compiled), builds or loads (fused)
    _sync(args.device)
    first = time.perf_counter() - t0
    env.step(td)
    k = env.params.n_substeps
    interval, step = float("inf"), float("inf")
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    for _ in range(args.repeats):
        _sync(args.device)
        t0 = time.perf_counter()
        for _ in range(args.intervals):
            env.integrate(lam)
        _sync(args.device)
        interval = min(interval, (time.perf_counter() - t0) / args.intervals)
        t0 = time.perf_counter()
        for _ in range(args.intervals):
            env.step(td)
        _sync(args.device)
        step = min(step, (time.perf_counter() - t0) / args.intervals)
    cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    user, system = cpu1.ru_utime - cpu0.ru_utime, cpu1.ru_stime - cpu0.ru_stime
    return {"substeps_per_s": flows * swimmers * k / interval, "ms_interval": 1e3 * interval,
            "ms_step": 1e3 * step, "first_s": first, "n_substeps": k,
            "sys_percent": 100 * system / max(user + system, 1e-9)}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--kubo", type=float, default=10.0)
    p.add_argument("--flow", default="stochastic", choices=("stochastic", "stochastic3d"))
    p.add_argument("--n-waves", type=int, default=64, help="stochastic3d: modes per component")
    p.add_argument("--batches", nargs="*", default=None,
                   help=f"FLOWSxSWIMMERS (default: {' '.join(DEFAULT_BATCHES)}; the GPU floor's "
                        f"batch of 16384 swimmers is {GPU_FLOOR_BATCH})")
    p.add_argument("--intervals", type=int, default=None, help="timed per repeat (default 5)")
    p.add_argument("--repeats", type=int, default=None, help="best of (default 3)")
    p.add_argument("--kernels", nargs="*", default=["eager", "fused"], choices=KERNELS,
                   help="fused runs on the CPU only (skipped elsewhere)")
    p.add_argument("--n-grid", type=int, default=None, help="flow grid points (default 400)")
    p.add_argument("--spacing", type=float, default=None, help="grid spacing (default 0.025)")
    p.add_argument("--malloc", choices=("retain", "default"), default="retain",
                   help="retain: freed buffers stay in the heap (as the swimrl commands); "
                        "default: glibc's defaults")
    p.add_argument("--smoke", action="store_true",
                   help="tiny grid and batch, one interval (a test that the script runs)")
    args = p.parse_args(argv)
    defaults = SMOKE if args.smoke else {"n_grid": 400, "spacing": 0.025,
                                         "batches": DEFAULT_BATCHES, "intervals": 5, "repeats": 3}
    for key, value in defaults.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    return args


def main(argv: list[str] | None = None) -> list[dict]:
    args = parse_args(argv)
    torch.set_num_threads(args.threads)
    retained = args.malloc == "retain" and retain_freed_memory()
    dev = torch.cuda.get_device_name() if args.device.startswith("cuda") else "cpu"
    k = EnvParams().n_substeps
    print(f"# device={args.device} ({dev}) threads={args.threads} torch={torch.__version__} "
          f"flow={args.flow} Ku={args.kubo:g} K={k} substeps per interval, "
          + (f"{args.n_waves} modes per component; " if args.flow == "stochastic3d" else
             f"grid {args.n_grid} x {args.spacing:g}; ") +
          f"best of {args.repeats} x {args.intervals} intervals; malloc="
          + ("retain" if retained else "default"))
    print(f"{'batch':>10} {'swimmers':>9} {'kernel':>8} {'substeps/s':>11} {'ms/interval':>12} "
          f"{'ms/env step':>12} {'warm-up s':>10} {'sys %':>6}")
    rows = []
    for b in args.batches:
        flows, swimmers = (int(v) for v in b.split("x"))
        for kernel in args.kernels:
            if kernel == "fused" and not args.device.startswith("cpu"):
                continue
            r = measure(flows, swimmers, kernel, args)
            rows.append({"batch": b, "kernel": kernel, **r})
            print(f"{b:>10} {flows * swimmers:>9} {kernel:>8} {r['substeps_per_s']:>11.3e} "
                  f"{r['ms_interval']:>12.3f} {r['ms_step']:>12.3f} {r['first_s']:>10.2f} "
                  f"{r['sys_percent']:>6.1f}",
                  flush=True)
    return rows


if __name__ == "__main__":
    main()
