"""PPO training of shape-control policies with stock TorchRL components (docs/training.md).

Modules: :mod:`~swimrl.rl.plan` (typed settings, sizes, schedule, seeds),
:mod:`~swimrl.rl.builders` (env, actor, critic, collector, loss, optimisers, schedulers,
logger), :mod:`~swimrl.rl.trainer` (the update loop), :mod:`~swimrl.rl.checkpoint` (atomic
checkpoints), :mod:`~swimrl.rl.run` (run directory, resume, final evaluation). The networks
and the policy files are in :mod:`swimrl.policies`.
"""
