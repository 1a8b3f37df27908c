"""The steering strategies (hand rule, 12-state table), the table search and the two gyrotaxis
commands at a tiny size."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from swimrl.actuation import ActuationSpec
from swimrl.analysis.table_search import NAIVE_TABLE, coordinate_ascent, evaluate_tables
from swimrl.env import EnvParams
from swimrl.errors import ConfigError
from swimrl.policies.steering import HandRule, TableStrategy, parse_table, table_text
from swimrl.runtime import Runtime
from swimrl.task import TaskSpec

ROOT = Path(__file__).resolve().parents[1]
F32 = Runtime.from_names("cpu", "float32", 1)


def _params(duration=30.0, burn_in=10.0):
    return EnvParams(swim_speed=0.6 * math.sqrt(2), bottom_heaviness=0.5, duration=duration,
                     task=TaskSpec(name="vertical", burn_in=burn_in),
                     actuation=ActuationSpec(name="steer"), signals=("n_r", "n_theta", "omega"))


def test_hand_rule_is_its_table():
    """The hand rule reads omega against the 12 states' edge: it is the table 'llll uuuu rrrr'
    on any signals (two independent codings of the same rule)."""
    g = torch.Generator().manual_seed(0)
    sig = torch.randn(4000, 5, generator=g)
    for discrete in (True, False):
        rule = HandRule(2 / 3, discrete)(sig)
        table = TableStrategy(parse_table("lllluuuurrrr"), discrete)(sig)
        assert torch.equal(rule, table)
    assert HandRule(2 / 3, True)(torch.tensor([[1, 0, 0, 0, 0.9]])).item() == 0   # right
    with pytest.raises(ConfigError, match="strategy=hand_rule.*2D"):
        HandRule(2 / 3, True)(torch.zeros(3, 7))


def test_table_text_round_trip_and_bad_tables():
    assert table_text(parse_table("ruldruldrudl")) == "ruldruldrudl"
    for bad in ("uuu", "uuuuuuuuuuux", 12):
        with pytest.raises(ConfigError, match="strategy.table"):
            parse_table(bad)


def test_tables_are_scored_on_shared_starts():
    """The naive table does not rise at Phi = 0.3, Psi = 1 (trapped); the hand rule's table
    does; the same table in two rows scores the same (common starts)."""
    v = evaluate_tables([NAIVE_TABLE, parse_table("lllluuuurrrr"), parse_table("lllluuuurrrr")],
                        _params(), 16, 5, F32)
    assert abs(float(v[0])) < 0.05 and float(v[1]) > 0.5
    assert float(v[1]) == float(v[2])


def test_coordinate_ascent_never_loses():
    res = coordinate_ascent(_params(duration=8.0, burn_in=2.0), 8, 1, F32, n_random_starts=1,
                            max_sweeps=1)
    for r in res.starts:
        assert r["value"] >= r["path"][0] - 1e-6
    assert res.value == max(r["value"] for r in res.starts)


def _cli(module: str, args: list[str], tmp: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *args, f"hydra.run.dir={tmp}"],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)


def test_trapping_command_tiny(tmp_path):
    out = _cli("swimrl.cli.trapping", ["trapping.phi=[0.3,0.6]", "trapping.psi=[1]",
                                       "trapping.n_swimmers=8", "trapping.duration=20",
                                       "trapping.burn_in=10"], tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    rec = json.loads((tmp_path / "trapping.json").read_text())
    assert [p["predicted"] for p in rec["points"]] == [True, False]
    assert (tmp_path / "trapping.png").stat().st_size > 0
    again = _cli("swimrl.cli.trapping", ["trapping.phi=[0.3]", "trapping.psi=[1]"], tmp_path)
    assert again.returncode != 0 and "overwrite" in again.stderr.strip().splitlines()[-1]


def test_table_search_command_tiny(tmp_path):
    out = _cli("swimrl.cli.table_search", ["table_search.n_swimmers=4",
                                           "table_search.n_random_starts=0",
                                           "table_search.starts=[uuuuuuuuuuuu]",
                                           "table_search.max_sweeps=1", "episode.duration=2",
                                           "task.burn_in=1"], tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    rec = json.loads((tmp_path / "table_search.json").read_text())
    assert len(rec["best_table"]) == 12 and rec["evaluations"] == 1 + 48


def test_gyrotaxis_figures_from_the_committed_records(tmp_path):
    """The figure script on the committed records: the policy map of a continuous and a
    discrete steering policy (the discrete one constant on each of the 12 states), the
    trajectories."""
    import numpy as np

    from swimrl.analysis.gyrotaxis_figures import direction_map, main

    runs = ROOT / "docs/results/gyrotaxis/ppo"
    phi = np.radians([0.0, 10.0, 30.0, 170.0])
    m = direction_map(str(runs / "disc_psi1_seed0"), phi, np.array([0.0, 0.1, 1.5]))
    assert set(np.round(np.degrees(m).ravel()).tolist()) <= {0.0, 90.0, -90.0, 180.0, -180.0}
    assert m[0, 0] == m[0, 1] == m[1, 2]        # one state (|omega| small, heading up)
    traj = ROOT / "docs/results/gyrotaxis/trajectories"
    main(["policy-map", str(tmp_path / "map.png"), str(runs / "cont_psi1_seed0")])
    main(["trajectories", str(tmp_path / "t.png"), "--until", "5",
          f"naive={traj / 'naive/trajectories.npz'}"])
    assert (tmp_path / "map.png").stat().st_size > 0 and (tmp_path / "t.png").stat().st_size > 0
