"""Evaluation: the rollout loop (:mod:`.rollout`, single and shared flows), statistics over
flows (:mod:`.statistics`), comparisons (:mod:`.compare`) and result records and tables
(:mod:`.records`)."""
