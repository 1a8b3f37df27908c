"""Shared fixtures: small grids and short episodes so the suite runs in minutes on 2 cores."""

from __future__ import annotations

import os

import pytest
import torch
from hydra import compose, initialize_config_module

torch.set_num_threads(int(os.environ.get("SWIMRL_TEST_THREADS", "1")))


def pytest_collection_modifyitems(config, items):
    if torch.cuda.is_available():
        return
    skip = pytest.mark.skip(reason="needs a CUDA device")
    for item in items:
        if "gpu" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def compose_cfg():
    """Compose the ``evaluate`` config with overrides, as the CLI would."""

    def _compose(overrides=(), name: str = "evaluate"):
        with initialize_config_module("swimrl.conf", version_base="1.3"):
            return compose(config_name=name, overrides=list(overrides))

    return _compose


SMALL = [
    "flow.n_grid=64",
    "flow.spacing=0.1",
    "episode.duration=2.0",
    "eval.progress=false",
    "threads=1",
]
