"""Hydra configs of the swimrl commands, shipped with the package as ``swimrl.conf``."""
