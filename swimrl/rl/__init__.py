"""PPO training of shape-control policies with stock TorchRL components (docs/training.md).

Modules: :mod:`~swimrl.rl.plan` (validated sizes, schedule, seeds), :mod:`~swimrl.rl.models`
(actor, critic, deterministic policy), :mod:`~swimrl.rl.builders` (env, collector, loss,
optimisers, schedulers, logger), :mod:`~swimrl.rl.trainer` (the update loop),
:mod:`~swimrl.rl.checkpoint` (atomic checkpoints), :mod:`~swimrl.rl.run` (run directory,
resume, final evaluation).
"""
