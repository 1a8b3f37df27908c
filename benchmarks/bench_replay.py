"""DNS replay: decode error by decode grid, evaluation swimmer-substeps/s, training frames/s.

Runs on a stored run (``--store``) or, without one, on a surrogate store written to
``--workdir``: random-phase vorticity fields on a 512^2 grid with the stored run's spectrum
(``E(k) ~ k^-3.38`` for ``3 <= k <= 40``, ``k^-3.8`` above, up to ``K = 170``; docs/dns.md),
phases rotating from snapshot to snapshot. Decoding and sampling costs depend only on the
grid, the retained modes and the swimmer count, so the surrogate measures the same speed as
a real run; its interpolation errors follow from the spectrum it shares with the DNS.

Prints, one thread:

1. per decode grid ``n_d``: the rms error of the bilinearly sampled channels at random
   points against the exact Fourier series (and against sampling the full grid), relative to
   each channel's rms;
2. ``swimrl-eval flow=dns_replay`` (STO): swimmer-substeps/s, as its ``metrics.json`` reports
   it (the whole episode loop: decoding, integration, signals, policy);
3. ``swimrl-train flow=dns_replay``: overall frames/s (collection + PPO update, median over the
   updates after the first, which compiles the loss).

    python benchmarks/bench_replay.py                      # surrogate store, all parts
    python benchmarks/bench_replay.py --store data/dns/dns_n512_seed0.zarr --parts error
    python benchmarks/bench_replay.py --smoke      # a 64^2 surrogate, tiny runs: seconds

``--smoke`` (a test that the script runs): a 64^2 surrogate store of 60 snapshots, decode
grids 64 and 48, one ``swimrl-eval`` of 2 x 8 swimmers over 1 tau_K and one ``swimrl-train``
of 2 updates of 2 x 4 swimmers (eager), all parts unless ``--parts`` says otherwise.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from swimrl.flows.dns.grid import dealias_cutoff
from swimrl.flows.dns.sources import DNSStore
from swimrl.flows.dns.store import DNSStoreWriter
from swimrl.flows.replay import ReplayFlow


def surrogate_store(path: Path, n: int = 512, n_times: int = 260, seed: int = 0) -> Path:
    """Write a finished store of random-phase fields with the DNS run's spectrum."""
    if (path / "zarr.json").exists():
        return path
    rng = np.random.default_rng(seed)
    K = dealias_cutoff(n)
    my = np.fft.fftfreq(n, 1.0 / n)[:, None]
    mx = np.arange(n // 2 + 1)[None, :]
    k = np.sqrt(mx**2 + my**2)
    keep = (np.abs(my) <= K) & (mx <= K) & (mx**2 + my**2 > 0)
    k = np.where(k > 0, k, 1.0)  # the k = 0 mode is dropped by keep
    energy = np.where(k < 3, (k / 3) ** 2, np.where(k <= 40, (k / 3) ** -3.38,
                                                     (40 / 3) ** -3.38 * (k / 40) ** -3.8))
    amp = np.where(keep, np.sqrt(k * energy), 0.0)  # shell sum of |w_k|^2 ~ k^2 E(k)
    phase = rng.uniform(0, 2 * np.pi, amp.shape)
    freq = rng.normal(0, 1, amp.shape) * 0.3 * (1 + k / 10) ** (2 / 3)
    w0 = amp * np.exp(1j * phase)
    field = np.fft.irfft2(w0, s=(n, n))  # scale the field to u_rms = 1
    psi = np.where(k > 0, w0 / np.maximum(k, 1) ** 2, 0)
    ux = np.fft.irfft2(1j * my * psi, s=(n, n))
    uy = np.fft.irfft2(-1j * mx * psi, s=(n, n))
    u_rms = math.sqrt(float((ux**2 + uy**2).mean()))
    scale = 1.0 / u_rms
    omega_rms = float(np.sqrt((field**2).mean())) * scale
    tau_k = 1 / omega_rms  # 2D periodic: <A_ij A_ij> = <omega^2>
    dt_store = 0.1003 * tau_k
    w = DNSStoreWriter.create(path, {"n": n, "length": 2 * math.pi, "dt_store": dt_store,
                                     "u_rms": 1.0, "tau_k": tau_k, "surrogate": True})
    for j in range(n_times):
        # w0 is unnormalised (rfft2 layout, irfft2 above): what append_snapshot takes
        w_hat = torch.from_numpy(w0 * scale * np.exp(1j * freq * j * 0.1))
        w.append_snapshot(w_hat.to(torch.complex128), j * dt_store)
        if j % 50 == 49:
            w.commit()
    w.commit(status="complete")
    return path


def exact_series(store: DNSStore, j: int, pts: np.ndarray) -> np.ndarray:
    """The five channels at ``pts`` by direct summation of every stored mode (float64)."""
    K = dealias_cutoff(store.store_n)
    c = np.asarray(store.group["omega_hat"][j]).astype(np.complex128)
    my = np.arange(-K, K + 1)[:, None].astype(float)
    mx = np.arange(K + 1)[None, :].astype(float)
    k2 = mx**2 + my**2
    psi = np.where(k2 > 0, c / np.where(k2 > 0, k2, 1), 0)
    hats = np.stack([1j * my * psi, -1j * mx * psi, -(mx * my) * psi,
                     0.5 * (mx**2 - my**2) * psi, c])
    hats = hats * np.where(mx == 0, 1.0, 2.0)
    out = np.zeros((len(pts), 5))
    for i0 in range(0, len(pts), 50):
        p = pts[i0:i0 + 50]
        ex = np.exp(1j * p[:, 0, None] * mx[0])  # (P, Kx)
        ey = np.exp(1j * p[:, 1, None] * my[:, 0])  # (P, Ky)
        out[i0:i0 + 50] = np.einsum("cyx,py,px->pc", hats, ey, ex).real
    return out


def decode_errors(path: Path, grids: list[int], points: int = 2000) -> None:
    """Relative rms error of bilinear sampling on each decode grid."""
    pts = np.random.default_rng(1).uniform(0, 2 * math.pi, (points, 2))
    store = DNSStore(path)
    want = exact_series(store, 0, pts)
    rms = np.sqrt((want**2).mean(0))
    full = None
    print(f"decode error at {points} random points, relative to each channel's rms "
          f"({path}, n = {store.store_n}, K = {dealias_cutoff(store.store_n)})")
    print(f"{'n_d':>5} {'modes':>6} | vs exact series: u_x u_y S_xx S_xy omega"
          f" | vs full-grid sampling | decode ms")
    for n_d in grids:
        src = DNSStore(path, decode_n=n_d)
        flow = ReplayFlow(src, 1, interval=src.dt_store, episode_time=src.dt_store,
                          dtype=torch.float64)
        flow.start_indices = lambda count: torch.zeros(count, dtype=torch.int64)
        flow.reset()
        got = flow.sample(torch.zeros(points, dtype=torch.int64), torch.from_numpy(pts)).numpy()
        if full is None:
            full = got
        err = np.sqrt(((got - want) ** 2).mean(0)) / rms
        vs_full = np.sqrt(((got - full) ** 2).mean(0)) / rms
        t = []
        for rep in range(4):
            t0 = time.perf_counter()
            src.channels(rep, rep + 1)
            t.append(time.perf_counter() - t0)
        print(f"{n_d:>5} {src.cutoff:>6} | " + " ".join(f"{e:.1e}" for e in err)
              + " | " + " ".join(f"{e:.1e}" for e in vs_full)
              + f" | {1e3 * statistics.median(t[1:]):.1f}")


def run(cmd: list[str]) -> None:
    print("  $", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def eval_speed(path: Path, workdir: Path, variants: list[tuple[str, ...]], duration: float) -> None:
    """swimrl-eval on the store: swimmer-substeps/s from metrics.json."""
    print(f"\nswimrl-eval flow=dns_replay strategy=sto, one thread, T = {duration} tau_K")
    for i, extra in enumerate(variants):
        out = workdir / f"eval{i}"
        run([sys.executable, "-m", "swimrl.cli.eval", "flow=dns_replay",
             f"flow.path={path}", "strategy=sto", "threads=1", "eval.progress=false",
             f"episode.duration={duration}", "overwrite=true", f"hydra.run.dir={out}", *extra])
        m = json.loads((out / "metrics.json").read_text())
        print(f"  {' '.join(extra)}: {m['swimmer_substeps_per_s']:.3g} swimmer-substeps/s "
              f"({m['n_flows']} flows x {m['n_swimmers']} swimmers)")


def train_speed(path: Path, workdir: Path, variants: list[tuple[str, ...]], duration: float,
                updates: int, frames_per_batch: int = 51200, base: tuple[str, ...] = ()) -> None:
    """swimrl-train on the store: overall frames/s (median over updates 2..); ``base``:
    overrides of every run, whose batch is ``frames_per_batch`` frames."""
    print(f"\nswimrl-train flow=dns_replay, one thread, T = {duration} tau_K, {updates} updates")
    for i, extra in enumerate(variants):
        out = workdir / f"train{i}"
        run([sys.executable, "-m", "swimrl.cli.train", "flow=dns_replay", f"flow.path={path}",
             "threads=1", "train.progress=false", f"episode.duration={duration}",
             f"train.total_frames={updates * frames_per_batch}", "train.eval_every=0",
             "train.compare_baselines=false", "overwrite=true", f"hydra.run.dir={out}",
             *base, *extra])
        with open(out / "curves.csv") as f:
            fps = [float(r["time/frames_per_s"]) for r in csv.DictReader(f)
                   if r.get("time/frames_per_s")]
        print(f"  {' '.join(extra)}: {statistics.median(fps[1:]):.3g} frames/s "
              f"(updates: {', '.join(f'{x:.0f}' for x in fps)})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--store", type=Path, default=None, help="a stored run (default: surrogate)")
    ap.add_argument("--workdir", type=Path, default=None, help="surrogate store and run dirs")
    ap.add_argument("--parts", default="error,eval,train")
    ap.add_argument("--grids", default=None, help="decode grids (default 512,384,256,192)")
    ap.add_argument("--updates", type=int, default=None, help="default 4 (--smoke: 2)")
    ap.add_argument("--smoke", action="store_true",
                    help="64^2 surrogate, tiny runs (a test that the script runs)")
    args = ap.parse_args()
    torch.set_num_threads(1)
    workdir = args.workdir or Path(tempfile.mkdtemp(prefix="bench_replay_"))
    workdir.mkdir(parents=True, exist_ok=True)
    parts = args.parts.split(",")
    if args.smoke:
        smoke(args, workdir, parts)
        return
    path = args.store or surrogate_store(workdir / "surrogate_n512.zarr")
    if "error" in parts:
        decode_errors(path, [int(g) for g in (args.grids or "512,384,256,192").split(",")])
    if "eval" in parts:
        eval_speed(path, workdir, [
            ("eval.n_flows=8", "eval.n_swimmers=1250", "eval.flows_per_batch=8"),
            ("eval.n_flows=2", "eval.n_swimmers=5000", "eval.flows_per_batch=2"),
            ("eval.n_flows=8", "eval.n_swimmers=1250", "eval.flows_per_batch=8",
             "flow.flows_per_start=8"),
            ("eval.n_flows=2", "eval.n_swimmers=5000", "eval.flows_per_batch=2",
             "flow.decode_n=384"),
        ], duration=5.0)
    if "train" in parts:
        train_speed(path, workdir, [
            ("flow.flows_per_start=32",),
            ("flow.flows_per_start=64",),
            ("flow.decode_n=384", "flow.flows_per_start=32"),
        ], duration=20.0, updates=args.updates or 4)


#: --smoke: every training run of 2 flows x 4 swimmers, L = 10 decisions, eager.
SMOKE_TRAIN = ("train.n_flows=2", "train.n_swimmers=4", "train.rollout_length=10",
               "train.minibatch_size=40", "train.epochs=1", "train.compile=false",
               "eval.n_flows=1", "eval.n_swimmers=4")


def smoke(args: argparse.Namespace, workdir: Path, parts: list[str]) -> None:
    """Every part at a tiny size: a 64^2 surrogate (or ``--store``), runs of seconds."""
    path = args.store or surrogate_store(workdir / "surrogate_n64.zarr", n=64, n_times=60)
    if "error" in parts:
        decode_errors(path, [int(g) for g in (args.grids or "64,48").split(",")], points=200)
    if "eval" in parts:
        eval_speed(path, workdir, [("eval.n_flows=2", "eval.n_swimmers=8",
                                    "eval.flows_per_batch=2")], duration=1.0)
    if "train" in parts:
        train_speed(path, workdir, [("flow.flows_per_start=2",)], duration=2.0,
                    updates=args.updates or 2, frames_per_batch=80, base=SMOKE_TRAIN)


if __name__ == "__main__":
    main()
