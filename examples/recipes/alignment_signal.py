# examples/recipes/alignment_signal.py
r"""Train on a computed signal: the swimmer also senses ``omega S_np tau_K^2``.

    python examples/recipes/alignment_signal.py OUT_DIR [swimrl-train overrides ...]

``dtheta/dt = omega/2 + Lambda S_np``: the product ``omega S_np`` (``= -n.(omega x S n)``) says
whether an elongated swimmer (``Lambda > 0``) is turned with the flow's rotation or against
it; unlike ``omega`` and ``S_np`` alone it keeps its sign under a reflection of the plane.
A TorchRL transform appends it to the observation of the signal set (``signals=nth_snp``
unless overridden: ``[n_theta, S_np, omega S_np]``), PPO trains on it with the pieces of
``swimrl-train`` (:mod:`swimrl.rl.builders`: environment, actor and critic, GAE and
``ClipPPOLoss``, Adam, collector; the config of ``swimrl-train`` and its overrides), and
the deterministic policy and STO are evaluated on the same held-out flows from the same
starts (seed ``seed + 1e6``, as ``swimrl-train``'s final evaluation). Writes
``OUT_DIR/alignment_signal.json`` and the actor's weights ``OUT_DIR/actor.pt``.
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from hydra import compose, initialize_config_module
from torchrl.data import Unbounded
from torchrl.envs import Transform

from swimrl import StrategySpec
from swimrl.config import train_config
from swimrl.evaluation.rollout import evaluate_shared
from swimrl.evaluation.statistics import paired_ratio
from swimrl.policies.networks import deterministic_actor
from swimrl.rl.builders import make_agent, make_collector, make_env
from swimrl.rl.plan import make_plan


class AlignmentRate(Transform):
    """Appends ``omega S_np tau_K^2`` to the observation."""

    def __init__(self):
        super().__init__(in_keys=["signals"], out_keys=["observation"])

    def _call(self, next_tensordict):
        s = next_tensordict["signals"]                  # n_r, n_theta, S_nn, S_np, omega
        extra = (s[..., 3] * s[..., 4]).unsqueeze(-1)
        observation = torch.cat((next_tensordict["observation"], extra), -1)
        return next_tensordict.set("observation", observation)

    def _reset(self, tensordict, tensordict_reset):
        return self._call(tensordict_reset)

    def forward(self, tensordict):                      # as a module in front of a policy
        return self._call(tensordict)

    def transform_observation_spec(self, observation_spec):
        old = observation_spec["observation"]
        observation_spec["observation"] = Unbounded(
            shape=(*old.shape[:-1], old.shape[-1] + 1), device=old.device, dtype=old.dtype)
        return observation_spec


out = Path(sys.argv[1])
with initialize_config_module("swimrl.conf", version_base="1.3"):
    cfg = train_config(compose("train", overrides=["signals=nth_snp", *sys.argv[2:]]))
plan = make_plan(cfg)
cfg.runtime.apply()                                     # threads
torch.manual_seed(cfg.seed)

# PPO as swimrl-train does it (without its compiled update, checkpoints and logs)
env = make_env(cfg.spec.flow, cfg.params, cfg.runtime, cfg.train, cfg.loss, plan.train_seed)
env.append_transform(AlignmentRate())
agent = make_agent(cfg, plan, env)
collector = make_collector(env, agent.actor, cfg.train, plan.total_frames, cfg.runtime.device)
clip = cfg.optim.max_grad_norm or float("inf")
mb, n_mb = cfg.train.minibatch_size, plan.minibatches_per_epoch
for update, data in enumerate(collector, 1):
    with torch.no_grad():
        data = agent.gae(data)                          # advantage and value target
    flat = data.reshape(-1)
    for _ in range(cfg.train.epochs):
        shuffled = flat[torch.randperm(flat.numel())[: n_mb * mb]]
        for k in range(n_mb):
            terms = agent.loss(shuffled[k * mb: (k + 1) * mb])
            sum(v for key, v in terms.items() if key.startswith("loss_")).backward()
            for net, opt in zip((agent.actor, agent.critic), agent.optimizers, strict=True):
                torch.nn.utils.clip_grad_norm_(net.parameters(), clip)
                opt.step()
                opt.zero_grad()
    for scheduler in agent.schedulers:
        scheduler.step()
    collector.update_policy_weights_()
    if update % 10 == 0 or update == plan.n_updates:
        print(f"update {update}/{plan.n_updates}", flush=True)
collector.shutdown()

# the deterministic policy and STO on the held-out flows of swimrl-train's final evaluation
# (seed + 1e6), from the same starts; the policy computes its extra signal itself
held = replace(cfg.held_out, seed=plan.eval_seed)
policy = torch.nn.Sequential(AlignmentRate(), deterministic_actor(agent.actor))
sto, smart = evaluate_shared(held, [StrategySpec("sto"), policy])
ratio, ratio_sem = paired_ratio(np.array(smart["per_flow"]), np.array(sto["per_flow"]))
names = [*cfg.params.signals, "omega*S_np"]
print(f"{held.sizes.n_flows} held-out flows x {held.sizes.n_swimmers} swimmers, "
      f"seed {held.seed}\n")
print("| strategy | R_hat (mean +- SEM) | ratio to sto (paired) |\n|---|---|---|")
print(f"| sto | {sto['R_hat_mean']:.4f} +- {sto['R_hat_sem']:.4f} | 1.000 +- 0.000 |")
print(f"| policy[{','.join(names)}] | {smart['R_hat_mean']:.4f} +- {smart['R_hat_sem']:.4f} "
      f"| {ratio:.3f} +- {ratio_sem:.3f} |")
out.mkdir(parents=True, exist_ok=True)
torch.save(agent.actor.state_dict(), out / "actor.pt")
record = {"signals": names, "frames": plan.total_frames, "eval_seed": held.seed,
          "sto": sto["per_flow"], "policy": smart["per_flow"],
          "ratio_to_sto": ratio, "ratio_to_sto_sem": ratio_sem}
(out / "alignment_signal.json").write_text(json.dumps(record, indent=1) + "\n")
