"""Evaluation: the rollout loop (:mod:`.rollout`, single and shared flows), statistics over
flows (:mod:`.statistics`), trajectories (:mod:`.trajectories`) and comparisons
(:mod:`.compare`). Records and tables are written by :mod:`swimrl.runs.records`."""
