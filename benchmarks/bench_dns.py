"""Throughput of the 2D Navier-Stokes DNS (ETDRK4, 2/3 de-aliased, stochastic forcing).

Prints, for each grid size N and batch B, the wall time per ETDRK4 step of the whole batch,
steps/s, and ms per realisation-step (= ms/step / B), float32 by default. One step = 4
evaluations of the advection term (4 FFTs each in the default Basdevant form, 5 in the
divergence form) + the forcing draw + the CFL check. "FFT floor" = 8 x the time of one
rfft2 + irfft2 pair of the same batch: the cost of the step's FFTs alone on this hardware.

Anchors (one CPU thread, 512^2, float64 ``rfft``): GeophysicalFlows.jl ~7.6 ms/step,
pyqg ~12.5 ms/step.

    python benchmarks/bench_dns.py                       # CPU, threads 1, 256^2 and 512^2
    python benchmarks/bench_dns.py --threads 1 2 --batches 1 4 16 --forms basdevant divergence
    python benchmarks/bench_dns.py --device cuda --sizes 512 1024 --batches 1 16 64
    python benchmarks/bench_dns.py --smoke               # 32^2, one realisation, seconds
"""

from __future__ import annotations

import argparse
import json
import time

import torch

from swimrl.flows.dns import DNS, DNSParams, SpectralGrid, random_state


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def bench_one(n: int, batch: int, device: str, dtype: str, min_time: float,
              min_steps: int, form: str = "basdevant") -> dict:
    """Time ETDRK4 steps of ``batch`` realisations on an ``n^2`` grid (after 3 warm-up steps)."""
    # a developed-looking state: the default physics, dt small enough for any state here
    p = DNSParams(n=n, nu=1e-4 * (512 / n) ** 2, alpha=0.5, epsilon=1.0, dt=2e-4,
                  dtype=dtype, device=device)
    g = SpectralGrid(n, p.length, p.device, p.torch_dtype)
    seeds = list(range(batch))
    dns = DNS(p, seeds=seeds, state=random_state(g, seeds, 2.0, 6.0), advection_form=form)
    dev = torch.device(device)
    dns.step(3)
    _sync(dev)
    steps, t0 = 0, time.perf_counter()
    while steps < min_steps or time.perf_counter() - t0 < min_time:
        dns.step()
        steps += 1
        if dev.type == "cuda" and steps % 10:
            continue
        _sync(dev)
    _sync(dev)
    dt = (time.perf_counter() - t0) / steps
    return {"n": n, "batch": batch, "device": device, "dtype": dtype, "form": form,
            "threads": torch.get_num_threads(), "steps": steps, "ms_per_step": dt * 1e3,
            "steps_per_s": 1 / dt, "ms_per_realisation_step": dt * 1e3 / batch}


def bench_fft(n: int, batch: int, device: str, dtype: str, min_time: float) -> dict:
    """Time one ``rfft2`` + one ``irfft2`` of a ``(batch, n, n)`` field: the hardware's FFT floor.

    An ETDRK4 step needs 4 x (2 inverse + 2 forward) = 8 such pairs in the Basdevant form and
    10 in the divergence form, so ``8 x pair`` is a lower bound on ms/step here.
    """
    dev = torch.device(device)
    x = torch.randn(batch, n, n, dtype=getattr(torch, dtype), device=dev)
    for _ in range(3):
        torch.fft.irfft2(torch.fft.rfft2(x), s=(n, n))
    _sync(dev)
    reps, t0 = 0, time.perf_counter()
    while reps < 5 or time.perf_counter() - t0 < min_time:
        torch.fft.irfft2(torch.fft.rfft2(x), s=(n, n))
        reps += 1
    _sync(dev)
    pair = (time.perf_counter() - t0) / reps * 1e3
    return {"n": n, "batch": batch, "ms_fft_pair": pair, "ms_floor_step": 8 * pair}


def main(argv: list[str] | None = None) -> list[dict]:
    """Run the benchmark grid given on the command line and print a table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--device", default="cpu", help="cpu | cuda | auto (cuda if available)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1],
                    help="CPU thread counts to try (torch.set_num_threads)")
    ap.add_argument("--sizes", type=int, nargs="+", default=None, help="N (default 256 512)")
    ap.add_argument("--batches", type=int, nargs="+", default=None, help="B (default 1 4 16)")
    ap.add_argument("--dtype", default="float32", choices=["float32", "float64"])
    ap.add_argument("--forms", nargs="+", default=["basdevant"],
                    choices=["basdevant", "divergence"], help="advection forms to time")
    ap.add_argument("--min-time", type=float, default=None,
                    help="seconds timed per case (default 1)")
    ap.add_argument("--min-steps", type=int, default=None, help="default 5")
    ap.add_argument("--json", default=None, help="also write the results to this file")
    ap.add_argument("--smoke", action="store_true",
                    help="32^2, B = 1, 2 steps (a test that the script runs)")
    args = ap.parse_args(argv)
    defaults = ({"sizes": [32], "batches": [1], "min_time": 0.0, "min_steps": 2} if args.smoke
                else {"sizes": [256, 512], "batches": [1, 4, 16], "min_time": 1.0,
                      "min_steps": 5})
    for key, value in defaults.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    device = args.device
    if device == "auto":
        device = "cuda" if torch.cuda.is_available() else "cpu"
    threads = args.threads if device == "cpu" else [torch.get_num_threads()]
    rows = []
    print(f"{'device':>6} {'thr':>3} {'N':>5} {'B':>4} {'form':>10} {'ms/step':>9} "
          f"{'steps/s':>8} {'ms/(real.step)':>14} {'FFT floor':>9}")
    for th in threads:
        torch.set_num_threads(th)
        for n in args.sizes:
            for b in args.batches:
                floor = bench_fft(n, b, device, args.dtype, args.min_time)
                for form in args.forms:
                    r = bench_one(n, b, device, args.dtype, args.min_time, args.min_steps, form)
                    r.update(floor)
                    rows.append(r)
                    print(f"{device:>6} {r['threads']:>3} {n:>5} {b:>4} {form:>10} "
                          f"{r['ms_per_step']:>9.2f} {r['steps_per_s']:>8.2f} "
                          f"{r['ms_per_realisation_step']:>14.2f} {floor['ms_floor_step']:>9.2f}",
                          flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return rows


if __name__ == "__main__":
    main()
