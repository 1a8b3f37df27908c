"""PPO training of shape-control policies with stock TorchRL components (docs/training.md).

Modules: :mod:`~swimrl.rl.plan` (typed settings, sizes, schedule, seeds),
:mod:`~swimrl.rl.builders` (env, actor, critic, collector, loss, optimisers, schedulers,
logger), :mod:`~swimrl.rl.trainer` (the update loop), :mod:`~swimrl.rl.run` (resume, final
evaluation). The networks are in :mod:`swimrl.policies`; the run's spec, its directory,
policy files, checkpoints and curves in :mod:`swimrl.runs`.
"""
