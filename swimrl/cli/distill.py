r"""``swimrl-distill``: a baseline strategy distilled into a policy network.

    swimrl-distill flow=stochastic3d flow.kubo=10 strategy=optimised3d kernel=fused \
        signals=rule_terms hydra.run.dir=outputs/distill/ku10_3d   # the 3D rule (~2 min)
    swimrl-train flow=stochastic3d flow.kubo=10 signals=rule_terms \
        train.init_policy=outputs/distill/ku10_3d ...       # PPO from the distilled rule

The teacher (``strategy=...``, a baseline) swims its own episodes; the student, the actor of
``model.*`` on ``signals.names``, is fitted to its shapes
(:mod:`swimrl.analysis.distill`). Writes ``policy.pt`` (a policy file: ``swimrl-eval
strategy=policy policy=<run dir>``, ``train.init_policy=<run dir>``) and ``distill.json``
(the fit, the teacher's score on its episodes).
"""

from __future__ import annotations

import logging
from pathlib import Path

from omegaconf import DictConfig

from swimrl.analysis.distill import fit_actor, teacher_samples
from swimrl.cli import command, run_dir
from swimrl.config import distill_config, record_of
from swimrl.runs.policy_files import policy_meta, save_policy
from swimrl.runs.records import refuse_overwrite, write_json

log = logging.getLogger(__name__)
RECORD, POLICY = "distill.json", "policy.pt"


def check(cfg: DictConfig, out: Path | None):
    """The config checked (:func:`~swimrl.config.distill_config`); the records not replaced
    unless ``overwrite``."""
    c = distill_config(cfg)
    if out is not None:
        for name in (RECORD, POLICY):
            refuse_overwrite(Path(out) / name, bool(cfg.overwrite))
    return c


@command("distill", check=check)
def main(cfg: DictConfig) -> dict:
    out = run_dir()
    c = check(cfg, out)
    setup, s = c.eval.setup, c.settings
    setup.runtime.apply()
    samples = teacher_samples(setup, c.eval.strategy, s.n_flows, s.n_swimmers, s.stride)
    log.info("teacher %s: score %.4f over %d x %d episodes; %d samples", c.eval.strategy.name,
             samples.score, s.n_flows, s.n_swimmers, len(samples.obs))
    actor, fit = fit_actor(c.model, samples.obs, samples.action, samples.action_spec, s,
                           log.info)
    meta = policy_meta(setup.params, c.model, str(setup.runtime.dtype).replace("torch.", ""),
                       action=samples.action_spec)
    save_policy(out / POLICY, actor=actor, counters={"frames": 0, "updates": 0, "wall_s": 0.0},
                config=record_of(cfg), meta=meta)
    record = {"config": record_of(cfg), "teacher": c.eval.strategy.name,
              "teacher_score": samples.score, "n_samples": len(samples.obs), **fit}
    mse, corr = fit.get("holdout_mse", float("nan")), fit.get("holdout_corr", float("nan"))
    print(f"distilled {c.eval.strategy.name}: holdout mse {mse:.5f}, corr {corr:.4f} "
          f"({len(samples.obs)} samples)", flush=True)
    log.info("wrote %s", write_json(record, out / RECORD, overwrite=bool(cfg.overwrite)))
    return record


if __name__ == "__main__":
    main()
