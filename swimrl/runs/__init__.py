"""What a run is, in memory and on disk.

In memory, its spec (:mod:`.spec`: :class:`~swimrl.runs.spec.RunSpec`, the flow, swimmer,
runtime, sizes and seed that a training and every evaluation of it are made with). On disk,
its directory (:mod:`.layout`: :class:`~swimrl.runs.layout.RunLayout`, every file named
once), the policy files and the shipped pretrained policies (:mod:`.policy_files`), the
training checkpoints and the config keys renamed since they were written (:mod:`.checkpoint`),
the training curves (:mod:`.curves`), the result records and tables (:mod:`.records`), the
one writer's lock and the preemption signals (:mod:`.jobs`), and the atomic write behind
every file (:mod:`.atomic`).
"""
