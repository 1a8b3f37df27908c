"""Throughput of PPO training: env frames/s, seconds per update, overall frames/s, breakdown.

Builds the training stack of ``swimrl-train`` for each variant (a list of config overrides
on top of each preset of ``--presets``), then alternates the variants update by update
(A/B/A/B...: the machine's drift hits all of them alike) and prints, per variant, the median over
``--updates`` measured updates (after ``--warmup`` updates: ``torch.compile`` builds its
graph on the first one) of

* collection (``Collector`` rollout of ``frames_per_batch`` frames), env frames/s;
* the PPO update (GAE + ``epochs x minibatches`` gradient steps), seconds;
* overall frames/s = ``frames_per_batch / (collect + update)``;
* the update's breakdown from ``torch.profiler`` labels (``ppo/gae``, ``ppo/minibatch``,
  ``ppo/loss_backward``, ``ppo/clip_optimizer``) over one profiled update;
* the flow redraw at an episode's end (``flow.reset()`` of all training flows, median of
  ``--redraws``), seconds, and the overall frames/s over a whole episode,
  ``U fpb / (U (collect + update) + redraw)`` with ``U = N / L`` updates per episode
  (a long run's rate; the few timed updates above never reach an episode's end).

Layouts (``--presets``, comma-separated ``train_preset`` names; default
``long_floor05,parallel``: the protocol's preset against the swimmer-parallel layout) times
code variants (``--variants``, comma-separated):

* ``before``: the code as it was before the compiled path, emulated within the current
  code (whose update bookkeeping it shares): eager, ``ClipPPOLoss`` computing the
  Monte-Carlo entropy of the ``TanhNormal`` although its coefficient is 0
  (``entropy_bonus=True``), and the flow redraw through full-grid FFTs;
* ``eager``: no entropy sample when the coefficient is 0, eager;
* ``compiled``: the same with ``train.compile=true`` (what the presets use on the CPU);
* ``graphed``: ``train.compile=true train.cudagraphs=true`` (CUDA only: the gradient step, the
  GAE and the policy compiled and captured in CUDA graphs).

    python benchmarks/bench_train.py --kubo 10 --updates 5                 # CPU, one thread
    python benchmarks/bench_train.py --device cuda --variants compiled,graphed
    python benchmarks/bench_train.py --presets bigbatch --variants before,compiled
    python benchmarks/bench_train.py --smoke       # tiny grid and batch, eager, seconds

``--smoke`` (a test that the script runs) puts every preset on a 64^2 grid with 2 flows x 4
swimmers x L = 10 decisions per update (:data:`SMOKE_OVERRIDES`), one warm-up and one measured
update, the ``eager`` variant unless ``--variants`` names others.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import torch
from hydra import compose, initialize_config_module
from torch.profiler import profile

from swimrl.config import train_config
from swimrl.rl import builders as rlb
from swimrl.rl.plan import make_plan
from swimrl.rl.trainer import PPOTrainer

VARIANTS = {
    "before": ["train.compile=false"],
    "eager": ["train.compile=false"],
    "compiled": ["train.compile=true"],
    "graphed": ["train.compile=true", "train.cudagraphs=true"],
}
#: --smoke: every preset on a tiny grid and batch (episodes of N = 20 decisions, L = 10).
SMOKE_OVERRIDES = [
    "flow.n_grid=64", "flow.spacing=0.1", "episode.duration=2.0", "train.n_flows=2",
    "train.n_swimmers=4", "train.rollout_length=10", "train.total_frames=320",
    "train.minibatch_size=40", "train.minibatches_per_epoch=null", "train.epochs=2",
    "train.eval_flows=1", "train.eval_swimmers=4", "eval.n_flows=1", "eval.n_swimmers=4",
    "train.progress=false", "train.stagger=1",
]
LABELS = ("ppo/gae", "ppo/minibatch", "ppo/loss_backward", "ppo/clip_optimizer")


class Variant:
    """One training stack and its collector iterator."""

    def __init__(self, preset: str, name: str, overrides: list[str], run_dir: Path):
        with initialize_config_module("swimrl.conf", version_base="1.3"):
            cfg = train_config(compose("train", overrides=[f"train_preset={preset}"] + overrides
                                       + VARIANTS[name]))
        plan = make_plan(cfg)
        cfg.runtime.apply()
        device = cfg.runtime.device
        self.name, self.plan, self.train, self.params = (f"{preset}/{name}", plan, cfg.train,
                                                         cfg.params)
        self.sync = torch.device(device).type == "cuda"  # time kernels, not their launches
        self.trainer = PPOTrainer(cfg, plan, run_dir / preset / name)
        if name == "before":
            self.trainer.loss.entropy_bonus = True
            self.trainer.swimmer_env.flow._synthesis = None  # full-grid FFT redraw
        self.collector = rlb.make_collector(
            self.trainer.env, self.trainer.actor, cfg.train, 10**12, device
        )
        self.batches = iter(self.collector)
        self.collect_s: list[float] = []
        self.update_s: list[float] = []

    def step(self, record: bool) -> None:
        t0 = time.perf_counter()
        data = next(self.batches)
        self._sync()
        t1 = time.perf_counter()
        self.trainer.update(data)
        self.collector.update_policy_weights_()
        self._sync()
        t2 = time.perf_counter()
        if record:
            self.collect_s.append(t1 - t0)
            self.update_s.append(t2 - t1)

    def _sync(self) -> None:
        if self.sync:
            torch.cuda.synchronize()

    def redraw(self, repeats: int) -> float:
        """Median seconds of one redraw of every training flow (an episode's end)."""
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            self.trainer.swimmer_env.flow.reset()
            self._sync()
            times.append(time.perf_counter() - t0)
        return statistics.median(times)

    def breakdown(self) -> dict[str, float]:
        """Seconds per label over one profiled update (profiler overhead included; a step
        replayed from a CUDA graph shows no labels inside it)."""
        data = next(self.batches)
        with profile() as prof:
            self.trainer.update(data)
        totals = {e.key: e.cpu_time_total * 1e-6 for e in prof.key_averages() if e.key in LABELS}
        return {k: totals.get(k, 0.0) for k in LABELS}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="long_floor05,parallel")
    ap.add_argument("--kubo", default="10")
    ap.add_argument("--variants", default=None,
                    help=f"comma-separated, of {', '.join(VARIANTS)} (default compiled; "
                         "eager with --smoke)")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--updates", type=int, default=None, help="measured (default 5)")
    ap.add_argument("--warmup", type=int, default=None, help="updates before (default 2)")
    ap.add_argument("--redraws", type=int, default=None, help="timed (default 2)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (threads=)")
    ap.add_argument("--out", default="/tmp/swimrl_bench_train")
    ap.add_argument("--smoke", action="store_true",
                    help="tiny grid and batch, one update (a test that the script runs)")
    ap.add_argument("overrides", nargs="*", help="extra config overrides")
    args = ap.parse_args(argv)
    defaults = ({"variants": "eager", "updates": 1, "warmup": 1, "redraws": 1} if args.smoke
                else {"variants": "compiled", "updates": 5, "warmup": 2, "redraws": 2})
    for key, value in defaults.items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    torch.set_num_threads(args.threads)
    base = [f"flow.kubo={args.kubo}", "seed=0", f"threads={args.threads}",
            f"device={args.device}"]
    base += (SMOKE_OVERRIDES if args.smoke else []) + list(args.overrides)
    variants = [Variant(p, v, base, Path(args.out))
                for p in args.presets.split(",") for v in args.variants.split(",")]
    for i in range(args.warmup + args.updates):
        for v in variants:
            v.step(record=i >= args.warmup)
    device = torch.cuda.get_device_name() if args.device.startswith("cuda") else "cpu"
    print(f"Ku={args.kubo} device={args.device} ({device}) threads={args.threads} "
          f"(median of {args.updates} updates after {args.warmup}, variants interleaved)")
    width = max(12, *(len(v.name) + 2 for v in variants))
    head = (f"{'variant':<{width}}{'swimmers':>9}{'frames':>9}{'env frames/s':>14}"
            f"{'collect s':>11}{'update s':>10}{'frames/s':>10}")
    print(head + "".join(f"{k.split('/')[1]:>16}" for k in LABELS)
          + f"{'redraw s':>10}{'episode frames/s':>18}")
    overall, episode = {}, {}
    for v in variants:
        plan, t = v.plan, v.train
        fpb = t.frames_per_batch
        per_episode = v.params.n_decisions / plan.rollout_steps  # updates per episode, U
        c, u = statistics.median(v.collect_s), statistics.median(v.update_s)
        overall[v.name] = fpb / (c + u)
        parts = v.breakdown()
        r = v.redraw(args.redraws)
        episode[v.name] = per_episode * fpb / (per_episode * (c + u) + r)
        print(
            f"{v.name:<{width}}{t.n_flows * t.n_swimmers:>9}{fpb:>9}{fpb / c:>14.0f}"
            f"{c:>11.3f}{u:>10.3f}{overall[v.name]:>10.0f}"
            + "".join(f"{parts[k]:>16.3f}" for k in LABELS)
            + f"{r:>10.2f}{episode[v.name]:>18.0f}"
        )
    names = list(overall)
    for n in names[1:]:
        print(f"speed-up {n} / {names[0]}: {overall[n] / overall[names[0]]:.2f}x per update, "
              f"{episode[n] / episode[names[0]]:.2f}x over an episode")
    for v in variants:
        v.collector.shutdown()


if __name__ == "__main__":
    main()
