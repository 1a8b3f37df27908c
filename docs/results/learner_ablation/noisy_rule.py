"""Does training's exploration noise hide the optimised rule's gain? (issue 62, item 4)

PPO explores with a TanhNormal actor: the action is ``Lambda_max tanh(mu + sigma xi)``. A rule
whose gain needs a precise shape would look no better than STO to a learner that explores
with the sigma of training (0.3-0.5 at the end of the 3D runs, 1 at the start). This script
evaluates the optimised 3D rule with that noise, ``Lambda = Lambda_max tanh(atanh(Lambda_rule /
Lambda_max) + sigma xi)``, ``xi`` standard normal at every decision, on the same flows and
starts for every sigma (blocks of one environment), and prints R_hat per sigma as JSON.

    python docs/results/learner_ablation/noisy_rule.py OUT.json --sigmas 0,0.2,0.35,0.5,1 \
        --kubo 10 --flows 4 --swimmers 100 --seed 2000000
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch
from hydra import compose, initialize_config_module

from swimrl.config import eval_config
from swimrl.evaluation.rollout import evaluate_shared
from swimrl.policies.baselines import as_actor
from swimrl.policies.optimised import OptimisedRule, preset_coefficients


class NoisyRule(torch.nn.Module):
    r"""$\Lambda = \Lambda_\max\tanh(\mathrm{atanh}(\Lambda_\mathrm{rule}/\Lambda_\max)
    + \sigma\xi)$: the rule's shape seen through the exploration noise of a TanhNormal actor."""

    def __init__(self, preset: str, shape_factor_max: float, sigma: float, seed: int):
        super().__init__()
        self.rule = OptimisedRule(preset_coefficients(preset, 3), shape_factor_max)
        self.shape_factor_max, self.sigma = shape_factor_max, sigma
        self.generator = torch.Generator().manual_seed(seed)

    def forward(self, signals: torch.Tensor) -> torch.Tensor:
        lam = self.rule(signals)
        if self.sigma == 0:
            return lam
        z = torch.atanh((lam / self.shape_factor_max).clamp(-1 + 1e-6, 1 - 1e-6))
        xi = torch.randn(z.shape, generator=self.generator, dtype=z.dtype)
        return self.shape_factor_max * torch.tanh(z + self.sigma * xi)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--sigmas", default="0,0.2,0.35,0.5,1")
    ap.add_argument("--kubo", type=float, default=10.0)
    ap.add_argument("--preset", default="ku10_3d")
    ap.add_argument("--flows", type=int, default=4)
    ap.add_argument("--swimmers", type=int, default=100)
    ap.add_argument("--duration", type=float, default=None, help="episode T in tau_K")
    ap.add_argument("--seed", type=int, default=2000000)
    args = ap.parse_args()
    sigmas = [float(s) for s in args.sigmas.split(",")]
    over = ["flow=stochastic3d", f"flow.kubo={args.kubo}", "kernel=fused",
            f"eval.n_flows={args.flows}", f"eval.n_swimmers={args.swimmers}",
            f"eval.flows_per_batch={args.flows}", f"seed={args.seed}", "threads=1",
            "eval.progress=false"]
    if args.duration is not None:
        over.append(f"episode.duration={args.duration}")
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose("evaluate", overrides=over)
    setup = eval_config(cfg).setup
    torch.set_num_threads(1)
    lam_max = setup.params.shape_factor_max
    actors = [as_actor(NoisyRule(args.preset, lam_max, s, i)) for i, s in enumerate(sigmas)]
    rows = [{"sigma": s, "R_hat_mean": m["R_hat_mean"], "R_hat_sem": m["R_hat_sem"]}
            for s, m in zip(sigmas, evaluate_shared(setup, actors), strict=True)]
    rec = {"preset": args.preset, "kubo": args.kubo, "flows": args.flows,
           "swimmers": args.swimmers, "seed": args.seed, "rows": rows}
    args.out.write_text(json.dumps(rec, indent=1) + "\n")
    for r in rows:
        print(f"sigma={r['sigma']}: R_hat {r['R_hat_mean']:.4f} +- {r['R_hat_sem']:.4f}")


if __name__ == "__main__":
    main()
