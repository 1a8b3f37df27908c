"""Bit-for-bit check of a refactoring: this checkout against a base commit.

Three checks, each printed as one line ``PASS`` / ``FAIL`` with what differed:

1. **figures** -- ``swimrl-figures`` (optionally ``only=<figure>``) on a fresh clone of this
   checkout's HEAD leaves ``git status`` clean: every committed figure and record is redrawn
   byte for byte.
2. **evaluations** -- ``swimrl-eval`` of every case of :data:`CASES` (shipped policies 2D and
   3D, the target and energy policies, the baselines and the optimised rules, in gridded,
   3D and analytic flows) in the base commit's tree and in this one, with the same seed and
   sizes and every decision of the recorded swimmers: the trajectories (signals, actions,
   positions, orientations) and the per-swimmer ``R_hat`` are equal exactly (``np.array_equal``),
   the per-flow metrics too.
3. **resume** -- the committed legacy checkpoint (``tests/data/legacy_checkpoint``) resumed by
   ``swimrl-train`` in both trees to the same budget: equal per-flow metrics and equal final
   actor weights.

Each tree runs its own code: the base commit is checked out with ``git worktree`` into a
temporary directory and every command runs with that directory first on ``PYTHONPATH``.

    python benchmarks/bit_for_bit.py --base <commit>             # the full check
    python benchmarks/bit_for_bit.py --base HEAD --tiny          # seconds (the test suite)
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: ``(name, overrides)`` of the evaluations compared: each is a ``swimrl-eval`` command.
CASES: list[tuple[str, list[str]]] = [
    *[(f"pretrained_{k}", ["strategy=policy", f"policy=pretrained/{k}",
                           f"flow.kubo={k.removeprefix('ku')}"])
      for k in ("ku0.1", "ku1", "ku10", "ku1e7")],
    ("sto_ku10", ["strategy=sto", "flow.kubo=10"]),
    ("naive_ku10", ["strategy=naive", "flow.kubo=10"]),
    ("minimal_ku10", ["strategy=minimal", "flow.kubo=10"]),
    ("optimised_ku10", ["strategy=optimised", "flow.kubo=10"]),
    ("target_ku10", ["strategy=policy", "flow.kubo=10", "task=target",
                     "policy=docs/results/beyond/runs/target_ku10_seed0/policy.pt"]),
    ("energy_ku10", ["strategy=policy", "flow.kubo=10", "reward.energy_weight=0.3",
                     "policy=docs/results/beyond/runs/energy_ku10_w0.3_seed0/policy.pt"]),
    ("shape_obs_ku10", ["strategy=policy", "flow.kubo=10", "reward.shape_change_weight=1",
                        "signals.names=[n_r,n_theta,S_nn,S_np,omega,Lambda]",
                        "policy=docs/results/beyond/runs/shape_ku10_wc1_obs_seed0/policy.pt"]),
    ("sto3d_ku10", ["flow=stochastic3d", "flow.kubo=10", "strategy=sto"]),
    ("optimised3d_ku10", ["flow=stochastic3d", "flow.kubo=10", "strategy=optimised3d"]),
    ("policy3d_ku10", ["flow=stochastic3d", "flow.kubo=10", "strategy=policy",
                       "policy=docs/results/three_d/runs/ku10_seed0/policy.pt"]),
    ("fused3d_ku1", ["flow=stochastic3d", "flow.kubo=1", "strategy=sto", "kernel=fused"]),
    ("sto3d_noise", ["flow=stochastic3d", "flow.kubo=1", "strategy=sto",
                     "swimmer.rot_diffusion=0.1"]),
    ("sto_noise", ["strategy=sto", "flow.kubo=1", "swimmer.rot_diffusion=0.1"]),
    ("abc_sto", ["flow=abc", "strategy=sto"]),
    ("taylor_green_naive", ["flow=taylor_green", "strategy=naive"]),
    ("taylor_green_target", ["flow=taylor_green", "strategy=sto", "task=target"]),
    ("linear_sto", ["flow=linear", "strategy=sto"]),
]
TINY = ["sto_ku10", "sto3d_noise", "taylor_green_target"]


def run(cmd: list[str], tree: Path, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``cmd`` with ``tree`` first on ``PYTHONPATH`` (its ``swimrl`` is the one imported)."""
    env = dict(os.environ, PYTHONPATH=f"{tree}{os.pathsep}{os.environ.get('PYTHONPATH', '')}",
               HYDRA_FULL_ERROR="1", OMP_NUM_THREADS="1")
    return subprocess.run(cmd, cwd=cwd or tree, env=env, capture_output=True, text=True)


def evaluate(tree: Path, case: list[str], out: Path, sizes: list[str]) -> None:
    """One ``swimrl-eval`` of ``case`` in ``tree``, into ``out``."""
    cmd = [sys.executable, "-m", "swimrl.cli.eval", *case, *sizes, "seed=5", "threads=1",
           "eval.progress=false", f"hydra.run.dir={out}"]
    p = run(cmd, tree)
    if p.returncode:
        raise RuntimeError(f"{' '.join(case)} failed in {tree}:\n{p.stderr[-2000:]}")


def same_eval(a: Path, b: Path) -> str | None:
    """None where the two evaluations are equal exactly, else what differs."""
    za, zb = np.load(a / "trajectories.npz"), np.load(b / "trajectories.npz")
    if sorted(za.files) != sorted(zb.files):
        return f"trajectory keys {sorted(za.files)} != {sorted(zb.files)}"
    for k in za.files:
        if not np.array_equal(za[k], zb[k], equal_nan=za[k].dtype.kind == "f"):
            return f"trajectories[{k!r}] differ"
    ma, mb = (json.loads((d / "metrics.json").read_text()) for d in (a, b))
    for k in ("per_flow", "R_hat_mean", "R_hat_sem"):
        if ma.get(k) != mb.get(k):
            return f"metrics[{k!r}]: {ma.get(k)} != {mb.get(k)}"
    return None


def check_evaluations(base: Path, names: list[str], sizes: list[str], work: Path) -> list[str]:
    """Every case of ``names`` in both trees (``sizes``: the overrides of the sizes; the
    ``flow.*`` ones only for the gridded flow)."""
    failures = []
    for name, case in CASES:
        if name not in names:
            continue
        outs = [work / "eval" / side / name for side in ("base", "head")]
        gridded = not any(o.startswith("flow=") for o in case)
        extra = [s for s in sizes if gridded or not s.startswith("flow.")]
        for tree, out in zip((base, ROOT), outs, strict=True):
            evaluate(tree, case, out, extra)
        diff = same_eval(*outs)
        print(f"  evaluation {name}: {'equal' if diff is None else diff}", flush=True)
        if diff is not None:
            failures.append(f"{name}: {diff}")
    return failures


def check_resume(base: Path, work: Path) -> list[str]:
    """The legacy checkpoint resumed in both trees (``tests/test_train.py``'s overrides)."""
    data = ROOT / "tests" / "data" / "legacy_checkpoint"
    overrides = [o.replace("episode.shape_factor_max", "swimmer.shape_factor_max")
                 .replace("train.frames_per_batch=80", "train.rollout_length=10")
                 for o in json.loads((data / "expected.json").read_text())["overrides"]]
    overrides += ["optim.anneal=linear", "train.compile=false", "resume=true"]
    import torch

    results = []
    for side, tree in (("base", base), ("head", ROOT)):
        run_dir = work / "resume" / side
        (run_dir / "checkpoints").mkdir(parents=True)
        shutil.copy(data / "last.pt", run_dir / "checkpoints" / "last.pt")
        p = run([sys.executable, "-m", "swimrl.cli.train", *overrides,
                 f"hydra.run.dir={run_dir}"], tree)
        if p.returncode:
            return [f"resume failed in {side}: {p.stderr[-1500:]}"]
        metrics = json.loads((run_dir / "metrics.json").read_text())
        policy = torch.load(run_dir / "policy.pt", map_location="cpu", weights_only=False)
        results.append((metrics["per_flow"], policy))
    (flows_a, pol_a), (flows_b, pol_b) = results
    failures = [] if flows_a == flows_b else [f"per_flow {flows_a} != {flows_b}"]
    sa, sb = pol_a["actor"], pol_b["actor"]
    if sa.keys() != sb.keys() or any(not torch.equal(sa[k], sb[k]) for k in sa):
        failures.append("final actor weights differ")
    print(f"  resume: {failures or 'equal'}", flush=True)
    return failures


def check_figures(only: list[str] | None, work: Path) -> list[str]:
    """``swimrl-figures`` (each of ``only``, or all) on a fresh clone of HEAD; ``git status``
    must stay clean."""
    clone = work / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    for name in only or [None]:
        cmd = [sys.executable, "-m", "swimrl.cli.figures", "threads=1",
               f"hydra.run.dir={work / 'figures_run' / str(name)}",
               *([f"only={name}"] if name else [])]
        p = run(cmd, clone)
        if p.returncode:
            return [f"swimrl-figures only={name} failed: {p.stderr[-1500:]}"]
        status = subprocess.run(["git", "status", "--porcelain"], cwd=clone,
                                capture_output=True, text=True, check=True).stdout.strip()
        print(f"  figures{'' if name is None else ' only=' + name}: "
              f"{status or 'git status clean'}", flush=True)
        if status:
            return [f"git status after swimrl-figures only={name}:\n{status}"]
    return []


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--base", required=True, help="the commit compared against")
    ap.add_argument("--tiny", action="store_true", help="three cases, tiny sizes, one figure")
    ap.add_argument("--only", nargs="*", default=None,
                    help="swimrl-figures only=<figure>, each in turn (default: all at once)")
    ap.add_argument("--skip", nargs="*", default=[], choices=["figures", "evaluations",
                                                                "resume"])
    args = ap.parse_args(argv)
    if args.tiny:
        names = TINY
        sizes = ["eval.n_flows=2", "eval.n_swimmers=4", "eval.record=2",
                 "episode.duration=1.0", "flow.n_grid=64", "flow.spacing=0.1"]
        only = args.only or ["threeDKu"]
    else:
        names = [n for n, _ in CASES]
        sizes = ["eval.n_flows=2", "eval.n_swimmers=16", "eval.record=4",
                 "episode.duration=20.0"]
        only = args.only
    failures: list[str] = []
    with tempfile.TemporaryDirectory(prefix="bit_for_bit_") as tmp:
        work = Path(tmp)
        base = work / "base"
        subprocess.run(["git", "worktree", "add", "-q", "--detach", str(base), args.base],
                       cwd=ROOT, check=True)
        # the base tree's own configs: swimrl.conf is the top-level conf/ (an editable install
        # maps it to this checkout's), so the base's is linked where its package finds it first
        (base / "swimrl" / "conf").symlink_to(base / "conf", target_is_directory=True)
        try:
            print(f"base {args.base} ({base}) against {ROOT}", flush=True)
            if "evaluations" not in args.skip:
                failures += check_evaluations(base, names, sizes, work)
            if "resume" not in args.skip:
                failures += check_resume(base, work)
            if "figures" not in args.skip:
                failures += check_figures(only, work)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base)], cwd=ROOT,
                           check=False)
    print("PASS: bit for bit" if not failures else "FAIL:\n" + "\n".join(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
