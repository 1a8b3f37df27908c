"""What chooses the shape factor: baselines (:mod:`.baselines`: naive, STO, minimal model) and
actor and critic networks (:mod:`.networks`); ``pretrained/`` holds the shipped policies' files
(loaded by :mod:`swimrl.runs.policy_files`)."""
