"""Bad input fails with one clear line naming the key and the allowed range, before compute."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from hydra.errors import ConfigCompositionException

from swimrl.config import eval_config

from .conftest import SMALL


@pytest.mark.parametrize(
    ("override", "key"),
    [
        ("flow.kubo=0", "flow.kubo"),
        ("flow.kubo=-1", "flow.kubo"),
        ("swimmer.shape_factor_max=1.0", "swimmer.shape_factor_max"),
        ("swimmer.shape_factor_max=1.5", "swimmer.shape_factor_max"),
        ("episode.dt=0.03", "episode.dt"),
        ("episode.update_interval=300", "episode.update_interval"),
        ("episode.duration=0.25", "episode.update_interval"),
        ("flow.n_grid=63", "flow.n_grid"),
        ("flow.spacing=0", "flow.spacing"),
        ("swimmer.swim_speed=-1", "swimmer.swim_speed"),
        ("swimmer.rot_diffusion=-0.1", "swimmer.rot_diffusion"),
        ("signals.names=[n_r,foo]", "signals.names"),
        ("signals.names=[]", "signals.names"),
        ("strategy=naive strategy.shape_factor=0.99", "strategy.shape_factor"),
        ("strategy=naive strategy.shape_factor=-1.2", "strategy.shape_factor"),
        ("eval.n_flows=0", "eval.n_flows"),
        ("device=tpu", "device"),
        ("dtype=float16", "dtype"),
        ("kernel=magic", "kernel"),
        ("threads=0", "threads"),
    ],
)
def test_bad_values_name_the_key(compose_cfg, override, key):
    cfg = compose_cfg(SMALL + override.split())
    with pytest.raises(ValueError) as err:
        eval_config(cfg)
    msg = str(err.value)
    assert key in msg and "\n" not in msg


def test_validation_precedes_compute(compose_cfg, monkeypatch):
    """The flow is never built for an invalid config: parsing the config checks it all."""
    import swimrl.env.build

    def boom(*a, **k):
        raise AssertionError("flow built before validation")

    monkeypatch.setattr(swimrl.env.build, "build_flow", boom)
    with pytest.raises(ValueError, match="episode.dt"):
        eval_config(compose_cfg(SMALL + ["episode.dt=0.03"]))
    cfg = compose_cfg(SMALL + ["episode.dt=0.05"])
    assert eval_config(cfg).setup.params.n_substeps == 2


def test_unknown_strategy_is_a_composition_error_listing_choices(compose_cfg):
    with pytest.raises(ConfigCompositionException, match="strategy"):
        compose_cfg(SMALL + ["strategy=bogus"])


def test_policy_strategy_needs_a_policy(compose_cfg):
    with pytest.raises(ValueError, match="policy="):
        eval_config(compose_cfg(SMALL + ["strategy=policy"]))


def test_cli_writes_metrics_and_never_overwrites(tmp_path):
    run = tmp_path / "run"
    cmd = [
        sys.executable,
        "-m",
        "swimrl.cli.eval",
        *SMALL,
        "strategy=sto",
        "flow.kubo=10",
        "eval.n_flows=3",
        "eval.n_swimmers=20",
        f"hydra.run.dir={run}",
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    assert "sto Ku=10: R_hat =" in out.stdout
    m = json.loads((run / "metrics.json").read_text())
    for key in (
        "R_hat_mean",
        "R_hat_std",
        "R_hat_sem",
        "per_flow",
        "config",
        "flow_stats",
        "wall_s",
        "swimmer_substeps_per_s",
    ):
        assert key in m
    assert len(m["per_flow"]) == 3 and m["config"]["flow"]["kubo"] == 10
    assert m["R_hat_sem"] == pytest.approx(m["R_hat_std"] / 3**0.5)
    before = (run / "metrics.json").read_text()
    again = subprocess.run(cmd, capture_output=True, text=True)
    assert again.returncode != 0 and "overwrite=true" in again.stderr
    assert (run / "metrics.json").read_text() == before


def test_cli_bad_value_is_one_line_with_exit_code_2(tmp_path):
    cmd = [sys.executable, "-m", "swimrl.cli.eval", *SMALL, "flow.kubo=-1",
           f"hydra.run.dir={tmp_path / 'run'}"]
    out = subprocess.run(cmd, capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        "error: flow.kubo=-1.0 is invalid: allowed > 0 (e.g. 0.1, 1, 10, 1e7)"]
    full = subprocess.run(cmd, capture_output=True, text=True,
                          env={**os.environ, "HYDRA_FULL_ERROR": "1"})
    assert full.returncode != 0 and "Traceback" in full.stderr and "flow.kubo" in full.stderr


@pytest.mark.parametrize("kubo, label", [("0.1", "0.1"), ("1", "1"), ("10", "10"),
                                         ("1e7", "1e7"), ("1e-3", "0.001"), ("2.5e12", "2.5e12")])
def test_ku_resolver_names_records_per_kubo(compose_cfg, kubo, label):
    """``${ku:${flow.kubo}}`` gives the Ku part of the shipped policies' and records' names,
    so one multirun over Ku can pick each Ku's policy."""
    cfg = compose_cfg([f"flow.kubo={kubo}",
                       "compare.policies=['pretrained/ku${ku:${flow.kubo}}']"], name="compare")
    assert cfg.compare.policies == [f"pretrained/ku{label}"]


def test_gain_scan_writes_its_record_and_never_overwrites(tmp_path):
    """``swimrl-gain-scan`` writes ``gain_scan.json`` / ``.md`` (the printed table) and
    refuses, before any compute, to replace them without ``overwrite=true``."""
    run = tmp_path / "scan"
    cmd = [sys.executable, "-m", "swimrl.cli.gain_scan", *SMALL, "flow.kubo=10",
           "policy=pretrained/ku10", "gains=[1,3]", "eval.n_flows=2", "eval.n_swimmers=8",
           f"hydra.run.dir={run}"]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    record = json.loads((run / "gain_scan.json").read_text())
    assert record["gains"] == [1.0, 3.0] and record["policy"].endswith("ku10")
    assert [r["gain"] for r in record["rows"]] == [1.0, 3.0]
    assert all(len(r["per_flow"]) == 2 for r in record["rows"])
    assert record["config"]["flow"]["kubo"] == 10
    table = (run / "gain_scan.md").read_text()
    assert table.strip() in out.stdout and f"{record['rows'][1]['R_hat_mean']:.4f}" in table
    kept = {name: (run / name).read_text()
            for name in ("gain_scan.json", "gain_scan.md", ".hydra/config.yaml")}
    again = subprocess.run(cmd, capture_output=True, text=True)
    assert again.returncode == 2 and "overwrite=true" in again.stderr
    assert again.stdout == ""  # refused before the scan ran (it prints the table)
    assert {name: (run / name).read_text() for name in kept} == kept
    # a directory holding only a (hand-written) table is refused too, the table kept
    table_only = tmp_path / "table_only"
    table_only.mkdir()
    (table_only / "gain_scan.md").write_text("notes\n")
    cmd_t = [*cmd[:-1], f"hydra.run.dir={table_only}"]
    refused = subprocess.run(cmd_t, capture_output=True, text=True)
    assert refused.returncode == 2 and "gain_scan.md exists" in refused.stderr
    assert (table_only / "gain_scan.md").read_text() == "notes\n"
    assert not (table_only / "gain_scan.json").exists()
