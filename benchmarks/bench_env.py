"""Throughput of the swimmer environment: swimmer-substeps per second.

A substep is one Heun step ``dt`` of one swimmer (two flow evaluations). Prints, for each
batch ``n_flows x n_swimmers``, the best of ``--repeats`` timings of ``--intervals`` decision
intervals (``T_u/dt`` substeps each) of :meth:`SwimmerEnv.integrate`, for the eager torch
reference and the fused CPU kernel (``kernel=eager|fused``).

    python benchmarks/bench_env.py --device cpu --threads 2
"""

from __future__ import annotations

import argparse
import time

import torch

from swimrl.env import EnvParams, SwimmerEnv
from swimrl.flows.stochastic import StochasticFlow

DEFAULT_BATCHES = ["1x1000", "10x100", "10x1000", "100x100", "1x10000", "10x10000", "1x100000"]


def measure(flows: int, swimmers: int, kernel: str, args) -> float:
    """Best swimmer-substeps/s over repeats (after one warm-up interval)."""
    gen = torch.Generator(device=args.device).manual_seed(0)
    flow = StochasticFlow(flows, args.kubo, device=args.device, generator=gen)
    env = SwimmerEnv(flow, swimmers, EnvParams(), kernel=kernel)
    env.reset()
    lam = torch.full((flows * swimmers,), 0.98, device=args.device)
    env.integrate(lam)
    best = 0.0
    for _ in range(args.repeats):
        if args.device.startswith("cuda"):
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        for _ in range(args.intervals):
            env.integrate(lam)
        if args.device.startswith("cuda"):
            torch.cuda.synchronize()
        rate = flows * swimmers * env.params.n_substeps * args.intervals
        best = max(best, rate / (time.perf_counter() - t0))
    return best


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--kubo", type=float, default=10.0)
    p.add_argument("--batches", nargs="*", default=DEFAULT_BATCHES, help="FLOWSxSWIMMERS")
    p.add_argument("--intervals", type=int, default=5)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--kernels", nargs="*", default=["eager", "fused"])
    args = p.parse_args()
    torch.set_num_threads(args.threads)
    dev = torch.cuda.get_device_name() if args.device.startswith("cuda") else "cpu"
    print(f"# device={args.device} ({dev}) threads={args.threads} torch={torch.__version__}")
    print(f"{'batch':>10} {'swimmers':>9} {'kernel':>7} {'substeps/s':>11}")
    for b in args.batches:
        flows, swimmers = (int(v) for v in b.split("x"))
        for kernel in args.kernels:
            if kernel == "fused" and not args.device.startswith("cpu"):
                continue
            r = measure(flows, swimmers, kernel, args)
            print(f"{b:>10} {flows * swimmers:>9} {kernel:>7} {r:>11.3e}", flush=True)


if __name__ == "__main__":
    main()
