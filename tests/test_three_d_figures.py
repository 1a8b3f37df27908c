"""The 3D study's figures (:mod:`swimrl.paper.three_d`) from records: summaries read from
the comparison rows, paths of two strategies from the same starts, the policy maps."""

from __future__ import annotations

import json

import numpy as np
import pytest

from swimrl.config import eval_config
from swimrl.evaluation.rollout import actor_for, evaluate
from swimrl.evaluation.trajectories import TrajectoryRecorder, save_trajectories
from swimrl.paper import three_d


def _comparison(path, ku_dir, rows):
    (path / ku_dir).mkdir(parents=True)
    rec = {"rows": [{"label": k, "R_hat_mean": v, "R_hat_sem": 0.01} for k, v in rows],
           "n_flows": 100, "n_swimmers": 200}
    (path / ku_dir / "comparison.json").write_text(json.dumps(rec))


def test_three_d_ku_reads_every_row(tmp_path):
    two, three = tmp_path / "2d", tmp_path / "3d"
    assert "pending" in three_d.build_three_d_ku(two, three, tmp_path / "a.png")
    for ku in ("ku1", "ku10"):
        _comparison(two, ku, [("sto", 0.5), ("naive(+0.98)", 0.3), ("policy(a)", 0.6),
                              ("policy(b)", 0.7)])
        _comparison(three, ku, [("sto", 0.4), ("naive(+0.98)", 0.2), ("policy(c)", 0.5)])
    out = three_d.build_three_d_ku(two, three, tmp_path / "a.png")
    assert (tmp_path / "a.png").is_file()
    assert out["2D"]["ku10"]["smart"]["R_hat"] == pytest.approx(0.65)
    assert out["2D"]["ku10"]["smart"]["over_STO"] == pytest.approx([1.2, 1.4])
    assert out["3D"]["ku1"]["STO"]["R_hat"] == 0.4 and out["3D"]["ku1"]["naive"]["R_hat"] == 0.2
    assert out["3D"]["ku1"]["smart"]["policies"] == ["c"]


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """Trajectory records of STO and naive in the 3D flow: same seed, sizes and starts."""
    from hydra import compose, initialize_config_module

    out = {}
    root = tmp_path_factory.mktemp("three_d")
    for name in ("sto", "naive"):
        with initialize_config_module("swimrl.conf", version_base="1.3"):
            cfg = compose("evaluate", [f"strategy={name}", "flow=stochastic3d", "flow.kubo=1",
                                       "flow.n_waves=8", "episode.duration=2.0",
                                       "eval.n_flows=1", "eval.n_swimmers=6",
                                       "eval.flows_per_batch=1", "eval.progress=false",
                                       "threads=1"])
        c = eval_config(cfg)
        rec = TrajectoryRecorder(6)
        evaluate(c.setup, actor_for(c.strategy, None, c.setup.params), name, rec)
        out[name] = save_trajectories(rec.arrays(), root / f"{name}.npz", [name], {})
    return out


def test_three_d_paths_and_maps(records, tmp_path):
    out = three_d.build_three_d_paths({"smart": records["naive"], "STO": records["sto"]},
                                      tmp_path / "paths.png", n_paths=2)
    assert (tmp_path / "paths.png").is_file() and len(out["R_hat"]["STO"]) == 2
    maps = three_d.build_three_d_maps(records["sto"], tmp_path / "maps.png")
    assert (tmp_path / "maps.png").is_file()
    # STO is Lambda_max sign(S_np1): that signal is the one most correlated with Lambda
    assert maps["pairs"][0][0] == "S_np1" and maps["correlations"]["S_np1"] > 0.5
    assert maps["decisions"] == 6 * 20


def test_three_d_paths_refuse_other_starts(records, tmp_path):
    other = dict(np.load(records["naive"]))
    other["position"] = other["position"] + 1.0
    np.savez(tmp_path / "moved.npz", **other)
    with pytest.raises(ValueError, match="same positions"):
        three_d.build_three_d_paths({"smart": tmp_path / "moved.npz", "STO": records["sto"]},
                                    tmp_path / "p.png")


def test_swimrl_figures_names_draw_from_the_study_dir(records, tmp_path):
    """threeDKu / threeDPaths / threeDMaps as ``swimrl-figures`` builds them: pending without
    records, drawn from ``<three_d>/compare`` and ``<three_d>/paths`` with them."""
    import shutil
    from types import SimpleNamespace

    cfg = SimpleNamespace(three_d=tmp_path / "3d", results=tmp_path / "2d", out=tmp_path / "fig")
    for build in (three_d.build_three_d_ku_figure, three_d.build_three_d_paths_figure,
                  three_d.build_three_d_maps_figure):
        assert "pending" in build(cfg)
    _comparison(tmp_path / "3d" / "compare", "ku10", [("sto", 0.4), ("policy(a)", 0.5)])
    for name, src in (("ku10_policy", "naive"), ("ku10_sto", "sto")):
        (tmp_path / "3d" / "paths" / name).mkdir(parents=True)
        shutil.copy(records[src], tmp_path / "3d" / "paths" / name / "trajectories.npz")
    assert three_d.build_three_d_ku_figure(cfg)["3D"]["ku10"]["smart"]["R_hat"] == 0.5
    assert "R_hat" in three_d.build_three_d_paths_figure(cfg)
    assert "correlations" in three_d.build_three_d_maps_figure(cfg)
    assert {p.name for p in (tmp_path / "fig").iterdir()} == {
        "threeDKu.png", "threeDPaths.png", "threeDMaps.png"}


def _curves(run, rows, finished):
    run.mkdir(parents=True)
    lines = ["frames,eval/R_hat,eval/R_hat_sem,train/R_hat"]
    lines += [f"{f},{r},0.01," for f, r in rows] + ["5000,,,0.9"]  # no held-out evaluation
    (run / "curves.csv").write_text("\n".join(lines) + "\n")
    if finished:
        (run / "policy.pt").write_bytes(b"")


def test_three_d_curves_per_ku_and_seed(tmp_path):
    runs, compare = tmp_path / "runs", tmp_path / "compare"
    assert "pending" in three_d.build_three_d_curves(runs, compare, tmp_path / "c.png")
    _curves(runs / "ku10_seed0", [(0, 0.2), (2000, 0.5), (4000, 0.55)], finished=True)
    _curves(runs / "ku10_seed2", [(0, 0.25), (2000, 0.52)], finished=False)
    _curves(runs / "ku1_seed1", [(0, 0.3)], finished=False)
    (runs / "ku10_notes").mkdir()  # not a run directory: ignored
    _comparison(compare, "ku10", [("sto", 0.4), ("naive(+0.98)", 0.2), ("policy(a)", 0.5)])
    out = three_d.build_three_d_curves(runs, compare, tmp_path / "c.png")
    assert (tmp_path / "c.png").is_file()
    assert set(out) == {"path", "ku1", "ku10"} and set(out["ku10"]) == {"seed0", "seed2"}
    # only the rows where the held-out evaluation was logged, in frame order
    assert out["ku10"]["seed0"] == {"frames": [0.0, 2000.0, 4000.0], "R_hat": [0.2, 0.5, 0.55],
                                    "finished": True}
    assert out["ku10"]["seed2"]["finished"] is False and out["ku1"]["seed1"]["R_hat"] == [0.3]
