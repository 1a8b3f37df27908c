"""Results are written only if finite; training stops at the first non-finite loss and keeps
its last good checkpoint; a corrupt last.pt falls back to prev.pt."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import torch

from swimrl.config import train_config
from swimrl.errors import BadFileError, NonFiniteError
from swimrl.rl.run import train
from swimrl.rl.trainer import PPOTrainer
from swimrl.runs.checkpoint import load_checkpoint
from swimrl.runs.layout import RunLayout
from swimrl.runs.policy_files import load_file
from swimrl.runs.records import write_json

from .test_train import TINY

LEGACY = Path(__file__).parent / "data" / "legacy_checkpoint" / "last.pt"


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_a_non_finite_record_is_not_written(tmp_path, value):
    path = tmp_path / "metrics.json"
    with pytest.raises(NonFiniteError, match=r"per_flow.1=(nan|inf|-inf) is not finite"):
        write_json({"R_hat_mean": 0.5, "per_flow": [0.4, value]}, path)
    assert not path.exists() and not list(tmp_path.iterdir())


def test_training_stops_at_the_first_non_finite_loss(compose_cfg, tmp_path, monkeypatch):
    update = PPOTrainer.update
    calls = {"n": 0}

    def poisoned(self, data):
        stats = update(self, data)
        calls["n"] += 1
        if calls["n"] == 3:
            stats["loss_objective"] = torch.tensor(float("nan"))
        return stats

    monkeypatch.setattr(PPOTrainer, "update", poisoned)
    cfg = train_config(compose_cfg([*TINY, "train.eval_every=0"], name="train"))
    with pytest.raises(NonFiniteError, match="update 3: loss_objective=nan"):
        train(cfg, tmp_path)
    assert not (tmp_path / "metrics.json").exists() and not (tmp_path / "policy.pt").exists()
    assert load_file(RunLayout(tmp_path).checkpoint)["counters"]["updates"] == 2
    assert load_file(tmp_path / "checkpoints" / "prev.pt")["counters"]["updates"] == 1


def test_corrupt_last_checkpoint_falls_back_to_prev(tmp_path):
    ck = tmp_path / "checkpoints"
    ck.mkdir()
    shutil.copy(LEGACY, ck / "prev.pt")
    (ck / "last.pt").write_bytes(LEGACY.read_bytes()[:1000])
    path, state = load_checkpoint(tmp_path)
    assert path == ck / "prev.pt" and state["format"] == load_file(LEGACY)["format"]
    (ck / "prev.pt").unlink()
    with pytest.raises(BadFileError, match=r"last\.pt cannot be read.*overwrite=true"):
        load_checkpoint(tmp_path)
