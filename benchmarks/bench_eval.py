"""Wall-clock seconds of one evaluation of a deterministic policy: F x S swimmers, one episode.

What the trainer's periodic evaluation costs (``train.eval_flows x train.eval_swimmers``, 16 x 32
in the ``long`` presets): :func:`swimrl.evaluation.rollout.evaluate` of a policy (default the
shipped ``pretrained/ku10``) on ``F`` flows of ``S`` swimmers, all flows in one chunk
(``eval.flows_per_batch = F``), ``N = T/T_u`` decisions (2000 at the default ``T = 200 tau_K``).
Prints, for each of ``--repeats`` evaluations of the same setup (the first one builds or
compiles the kernel: ``kernel=compiled`` compiles there):

* ``wall s``: the whole call (flow tables, environment, the episode, the statistics);
* ``episode s``: the episode loop alone (``N`` decisions: policy, env step, signals);
* ``decisions/s``: ``N / wall s``: decisions of all ``F x S`` swimmers at once per second;
* ``swimmer-decisions/s``: ``F S N / wall s``; and ``R_hat``, the evaluation's result.

    python benchmarks/bench_eval.py                                   # CPU, one thread, 16 x 32
    python benchmarks/bench_eval.py --device cuda --kernel compiled   # the GPU floor: <= 5 s
    python benchmarks/bench_eval.py --flows 100 --swimmers 200 flow.kubo=1e7
    python benchmarks/bench_eval.py --smoke                            # tiny grid, seconds
"""

from __future__ import annotations

import argparse
import time

import torch
from hydra import compose, initialize_config_module

from swimrl.config import eval_config
from swimrl.evaluation.rollout import actor_for, evaluate

#: --smoke: a 64^2 grid of spacing 0.1, episodes of 20 decisions, 2 flows x 8 swimmers.
SMOKE_OVERRIDES = ["flow.n_grid=64", "flow.spacing=0.1", "episode.duration=2.0"]
SMOKE_SIZES = {"flows": 2, "swimmers": 8}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--policy", default="pretrained/ku10",
                    help="policy spec (pretrained/NAME, run dir or policy file), as policy=")
    ap.add_argument("--kubo", default="10")
    ap.add_argument("--flows", type=int, default=None, help="F (default 16)")
    ap.add_argument("--swimmers", type=int, default=None, help="S per flow (default 32)")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--kernel", default="auto", help="auto | eager | fused | compiled")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=2,
                    help="evaluations timed (the same flows each time; the first one warms up)")
    ap.add_argument("--seed", type=int, default=1_000_000,
                    help="evaluation seed (default: a training run's held-out flows of seed 0)")
    ap.add_argument("--smoke", action="store_true",
                    help="tiny grid, short episode, 2 x 8 swimmers (a test that the script runs)")
    ap.add_argument("overrides", nargs="*", help="extra config overrides (swimrl-eval keys)")
    args = ap.parse_args(argv)
    defaults = SMOKE_SIZES if args.smoke else {"flows": 16, "swimmers": 32}
    for key, value in defaults.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    return args


def setup_of(args: argparse.Namespace):
    """The composed ``swimrl-eval`` config of ``args`` (policy strategy, one chunk of F flows)."""
    f, s = args.flows, args.swimmers
    overrides = [
        f"flow.kubo={args.kubo}", "strategy=policy", f"policy={args.policy}",
        f"eval.n_flows={f}", f"eval.n_swimmers={s}", f"eval.flows_per_batch={f}",
        "eval.progress=false", f"device={args.device}", f"kernel={args.kernel}",
        f"threads={args.threads}", f"seed={args.seed}",
        *(SMOKE_OVERRIDES if args.smoke else []), *args.overrides,
    ]
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        return eval_config(compose("evaluate", overrides=overrides))


def _sync(device: str) -> None:
    if device.startswith("cuda"):
        torch.cuda.synchronize()


def main(argv: list[str] | None = None) -> list[dict]:
    args = parse_args(argv)
    c = setup_of(args)
    setup, params = c.setup, c.setup.params
    actor = actor_for(c.strategy, c.policy, params)
    f, s, n = args.flows, args.swimmers, params.n_decisions
    dev = torch.cuda.get_device_name() if args.device.startswith("cuda") else "cpu"
    grid = (f" (grid {setup.flow.n_grid} x {setup.flow.spacing:g})"
            if hasattr(setup.flow, "n_grid") else "")
    print(f"# device={args.device} ({dev}) threads={args.threads} kernel={args.kernel} "
          f"policy={args.policy} Ku={args.kubo} torch={torch.__version__}: {f} flows x {s} "
          f"swimmers, one chunk, N = {n} decisions of K = {params.n_substeps} substeps, flow "
          f"{setup.flow.name}{grid}", flush=True)
    print(f"{'run':>3} {'flows':>6} {'swimmers':>9} {'decisions':>10} {'wall s':>8} "
          f"{'episode s':>10} {'decisions/s':>12} {'swimmer-decisions/s':>20} {'R_hat':>7}")
    rows = []
    for i in range(args.repeats):
        _sync(args.device)
        t0 = time.perf_counter()
        m = evaluate(setup, actor, "policy")
        _sync(args.device)
        wall = time.perf_counter() - t0
        episode = f * s * n * params.n_substeps / m["swimmer_substeps_per_s"]
        row = {"run": i + 1, "wall_s": wall, "episode_s": episode, "decisions_per_s": n / wall,
               "swimmer_decisions_per_s": f * s * n / wall, "R_hat": m["R_hat_mean"]}
        rows.append(row)
        print(f"{i + 1:>3} {f:>6} {s:>9} {n:>10} {wall:>8.3f} {episode:>10.3f} "
              f"{row['decisions_per_s']:>12.1f} {row['swimmer_decisions_per_s']:>20.3e} "
              f"{row['R_hat']:>7.4f}", flush=True)
    return rows


if __name__ == "__main__":
    main()
