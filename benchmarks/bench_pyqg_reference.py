"""Same-hardware reference for ``bench_dns.py``: pyqg's 2D barotropic model at N^2, one thread.

The issue's anchors (GeophysicalFlows.jl ~7.6 ms/step, pyqg ~12.5 ms/step at 512^2 on one CPU
thread) were measured on another machine with the BenchFourierFlows set-up: decaying 2D
turbulence, float64, Adams-Bashforth 3 (one nonlinear-term evaluation, 5 FFTs, per step).
This script times pyqg's ``BTModel`` the same way on *this* machine, so the two solvers can be
compared on one hardware class. pyqg is not a dependency of swimrl; install it in a separate
environment (pyqg 0.7.2 needs Cython < 3 to build):

    python -m venv /tmp/pyqgenv
    /tmp/pyqgenv/bin/pip install "cython<3" "numpy<2" setuptools wheel pyfftw
    /tmp/pyqgenv/bin/pip install --no-build-isolation pyqg
    OMP_NUM_THREADS=1 /tmp/pyqgenv/bin/python benchmarks/bench_pyqg_reference.py --sizes 256 512
    /tmp/pyqgenv/bin/python benchmarks/bench_pyqg_reference.py --smoke   # 32^2, 5 steps

Without pyqg it says so on stderr and exits with status 3 (:data:`NO_PYQG_EXIT`).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time

import numpy as np

#: Exit status when pyqg is not importable (the benchmark cannot run; nothing is timed).
NO_PYQG_EXIT = 3


def time_pyqg(n: int, n_steps: int, dt: float = 1e-4) -> float:
    """ms per step of pyqg ``BTModel`` (AB3, float64, 1 FFT thread) from a McWilliams-like state."""
    import pyqg  # noqa: PLC0415 (optional, see module docstring)

    m = pyqg.BTModel(L=2 * np.pi, nx=n, beta=0.0, H=1.0, rek=0.0, rd=None, dt=dt,
                     tmax=np.inf, twrite=np.inf, taveint=np.inf, ntd=1)
    rng = np.random.default_rng(1234)
    k2 = m.wv2
    ck = np.zeros_like(k2)
    nz = k2 != 0
    ck[nz] = np.sqrt(k2[nz] * (1 + (k2[nz] / 36.0) ** 2)) ** -1
    psi_hat = (rng.standard_normal(k2.shape) + 1j * rng.standard_normal(k2.shape)) * ck
    q = m.ifft(-k2 * psi_hat[None])
    m.set_q(q / np.abs(q).max())
    for _ in range(5):  # warm-up (first AB3 steps are lower order)
        m._step_forward()
    t0 = time.perf_counter()
    for _ in range(n_steps):
        m._step_forward()
    return (time.perf_counter() - t0) / n_steps * 1e3


def main() -> None:
    """Print ms/step of pyqg at each requested N."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=None, help="N (default 256 512)")
    ap.add_argument("--steps", type=int, default=None, help="timed per N (default 200)")
    ap.add_argument("--smoke", action="store_true",
                    help="32^2, 5 steps (a test that the script runs)")
    args = ap.parse_args()
    if args.sizes is None:
        args.sizes = [32] if args.smoke else [256, 512]
    if args.steps is None:
        args.steps = 5 if args.smoke else 200
    if importlib.util.find_spec("pyqg") is None:
        print(f"pyqg is not installed in {sys.executable}: it is not a dependency of swimrl; "
              "install it in a separate environment (see this script's docstring)",
              file=sys.stderr)
        sys.exit(NO_PYQG_EXIT)
    print(f"{'N':>5} {'pyqg ms/step (AB3, 1 RHS)':>26}")
    for n in args.sizes:
        print(f"{n:>5} {time_pyqg(n, args.steps):>26.2f}", flush=True)


if __name__ == "__main__":
    main()
