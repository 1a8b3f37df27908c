"""What chooses the shape factor: baselines (:mod:`.baselines`: naive, STO, minimal model),
actor and critic networks (:mod:`.networks`), policy files and the shipped pretrained
policies (:mod:`.files`, ``pretrained/``)."""
