"""Figure records (swimrl.paper.records): a missing record is computed and written,
read back equal; a record made for other sizes, seeds or policy files, of another format, or
with mixed sizes inside it is refused in one line; ``figures.refresh`` remakes it. Tiny
evaluations (64^2 grid, T = 1, a few swimmers)."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from swimrl.errors import BadFileError, ConfigError
from swimrl.paper import (
    decision_stats,
    evaluations,
    map_evaluations,
    mechanism,
    records,
    robustness,
    settings,
)
from swimrl.paper.config import figures_config
from swimrl.runs.policy_files import PRETRAINED_ROOT

TINY = ["progress=false", "threads=1", "episode.duration=1.0", "flow.n_grid=64",
        "flow.spacing=0.1", "figures.robust_flows=2", "figures.robust_swimmers=3",
        "figures.noise=[0.0,0.01]", "figures.map_flows=2", "figures.map_swimmers=3",
        "figures.map_seeds=[0,1]"]


@pytest.fixture
def tiny(compose_cfg, tmp_path):
    """``make(*overrides)``: the figures' config at tiny sizes, its policies copies of the
    shipped ones (``<tmp>/policies/ku*``, ``<tmp>/runs/ku*_seed*``), everything written under
    ``tmp_path``."""
    for name in ("ku10", "ku1e7"):
        shutil.copytree(PRETRAINED_ROOT / name, tmp_path / "policies" / name)
        for seed in (0, 1):
            shutil.copytree(PRETRAINED_ROOT / name, tmp_path / "runs" / f"{name}_seed{seed}")

    def make(*overrides: str) -> settings.FiguresConfig:
        cfg = figures_config(compose_cfg([*TINY, *overrides], name="figures"))
        return replace(cfg, out=tmp_path / "fig", cache=tmp_path / "cache",
                       records=tmp_path / "records", policies=str(tmp_path / "policies"),
                       curves=tmp_path / "runs")

    return make


def _refused(error, match: str, build, cfg) -> str:
    with pytest.raises(error, match=match) as err:
        build(cfg)
    text = str(err.value)
    assert "\n" not in text
    return text


def test_missing_record_is_computed_written_and_read_back_equal(tiny):
    cfg = tiny()
    path = cfg.records / "robustness-noise.json"
    assert not path.exists()
    drawn = robustness.build_robustness_noise(cfg)
    rec = records.read_figure_record(path)
    assert rec["format"] == records.RECORD_FORMAT and rec["figure"] == "robustness-noise"
    assert rec["sizes"] == {"sweep": {"n_flows": 2, "n_swimmers": 3, "flows_per_batch": 2}}
    assert list(rec["evaluations"]) == ["rot_diffusion=0", "rot_diffusion=0.01"]
    ev = rec["evaluations"]["rot_diffusion=0.01"]
    assert ev["setup"]["changed"] == {"rot_diffusion": 0.01} and ev["setup"]["seed"] == 0
    assert ev["setup"]["flow"]["kubo"] == 10.0
    policy = str(Path(cfg.policies) / "ku10")
    assert ev["actors"] == {"smart": policy, "naive": "naive", "STO": "sto"}
    assert ev["files"] == {policy: records.sha256_file(Path(policy) / "policy.pt")}
    assert all(len(v) == 2 for v in ev["per_flow"].values())
    want = evaluations.flow_summary(ev["per_flow"], [("smart", "STO")])
    assert ev["derived"]["mean"] == pytest.approx(want["mean"])
    assert ev["derived"]["ratio"]["smart/STO"]["value"] == pytest.approx(
        np.mean(ev["per_flow"]["smart"]) / np.mean(ev["per_flow"]["STO"]))
    assert rec["derived"]["rot_diffusion"]["x"] == [0.0, 0.01]
    assert drawn["ratio"] == pytest.approx(rec["derived"]["rot_diffusion"]["smart/STO"])
    # read, not remade: the same record (nothing evaluated: the cache is gone too)
    text = path.read_text()
    shutil.rmtree(cfg.cache)
    again = records.figure_record(cfg, "robustness-noise",
                                  robustness.sweep_evaluations(cfg, "rot_diffusion", cfg.noise),
                                  lambda ev: pytest.fail("recomputed"))
    assert again == json.loads(text) == rec and path.read_text() == text


def test_record_made_for_other_sizes_seed_or_policy_is_refused(tiny):
    cfg = tiny()
    robustness.build_robustness_noise(cfg)
    path = cfg.records / "robustness-noise.json"
    text = path.read_text()
    msg = _refused(ConfigError, "sizes.sweep.n_flows = 2 in the record, 3 now",
                   robustness.build_robustness_noise, tiny("figures.robust_flows=3"))
    assert str(path) in msg and "figures.refresh=[robustness-noise]" in msg
    _refused(ConfigError, "seed = 0 in the record, 5 now", robustness.build_robustness_noise,
             tiny("seed=5"))
    _refused(ConfigError, r"evaluations = \[.*\] in the record", robustness.build_robustness_noise,
             tiny("figures.noise=[0.0,0.1]"))
    policy = Path(cfg.policies) / "ku10" / "policy.pt"
    old = records.sha256_file(policy)
    policy.write_bytes(policy.read_bytes() + b"\0")  # other bytes: a stale hash
    msg = _refused(ConfigError, r"evaluations.rot_diffusion=0.files.",
                   robustness.build_robustness_noise, cfg)
    assert old in msg and records.sha256_file(policy) in msg
    assert path.read_text() == text  # never replaced


def test_mixed_sizes_or_another_format_in_a_record_are_refused(tiny):
    cfg = tiny()
    robustness.build_robustness_noise(cfg)
    path = cfg.records / "robustness-noise.json"
    good = json.loads(path.read_text())

    def write(edit) -> None:
        rec = json.loads(json.dumps(good))
        edit(rec)
        path.write_text(json.dumps(rec))

    def more_flows(rec):
        ev = rec["evaluations"]["rot_diffusion=0.01"]
        ev["setup"]["n_flows"] = 3
        ev["per_flow"] = {k: v + v[:1] for k, v in ev["per_flow"].items()}

    write(more_flows)
    _refused(BadFileError, r"rot_diffusion=0.01.setup.n_flows = 3 but sizes.sweep.n_flows = 2: "
             "mixed sizes", robustness.build_robustness_noise, cfg)
    write(lambda rec: rec["evaluations"]["rot_diffusion=0"]["per_flow"]["STO"].pop())
    _refused(BadFileError, "per_flow.STO holds 1 flows", robustness.build_robustness_noise, cfg)
    write(lambda rec: rec.update(format=0))
    _refused(ConfigError, "format = 0 in the record, 1 now", robustness.build_robustness_noise,
             cfg)
    path.write_text("{")
    _refused(BadFileError, "not a readable figure record", robustness.build_robustness_noise,
             cfg)


def test_refresh_remakes_the_record(tiny):
    cfg = tiny()
    robustness.build_robustness_noise(cfg)
    path = cfg.records / "robustness-noise.json"
    made = json.loads(path.read_text())
    tampered = json.loads(json.dumps(made))
    tampered["evaluations"]["rot_diffusion=0"]["per_flow"]["smart"] = [9.0, 9.0]
    path.write_text(json.dumps(tampered))
    robustness.build_robustness_noise(tiny("figures.refresh=[robustness-noise]"))
    assert json.loads(path.read_text()) == made  # remade from the cache, as computed
    bigger = tiny("figures.refresh=[robustness-noise]", "figures.robust_swimmers=4")
    robustness.build_robustness_noise(bigger)
    assert json.loads(path.read_text())["sizes"]["sweep"]["n_swimmers"] == 4
    robustness.build_robustness_noise(tiny("figures.robust_swimmers=4"))  # read as made
    with pytest.raises(ConfigError, match="figures.refresh"):
        tiny("figures.refresh=[swimmer]")  # a figure without a record


def test_mechanism_records_hold_per_seed_statistics(tiny):
    """kuInf: every decision of each seed's run streamed into its statistics; the record
    holds per seed the per-flow R_hat, the counts and the S_nn statistic, and the figure
    draws the first seed's maps."""
    cfg = tiny()
    out = mechanism.build_ku_inf(cfg)
    rec = records.read_figure_record(cfg.records / "kuInf.json")
    assert rec["sizes"] == {"statistics": {"n_flows": 2, "n_swimmers": 3, "flows_per_batch": 2}}
    assert list(rec["evaluations"]) == ["ku1e7_seed0", "ku1e7_seed1"]
    ev = rec["evaluations"]["ku1e7_seed1"]
    run = cfg.curves / "ku1e7_seed1" / "policy.pt"
    assert ev["actors"] == {"smart": str(run)}
    assert ev["files"] == {str(run): records.sha256_file(run)}
    assert ev["counts"] == {"trajectories": 6, "decisions": 60}
    assert ev["derived"]["snn"]["n"] == 60 and len(ev["per_flow"]["smart"]) == 2
    seeds = rec["derived"]["per_seed"]
    assert seeds["1"]["p_pos_given_low"] == ev["derived"]["snn"]["p_pos_given_low"]
    arrays = map_evaluations.map_record(cfg, map_evaluations.map_evaluation(cfg, 1e7, 0))
    assert out["snn"] == decision_stats.snn_statistic(arrays)
    assert arrays["map_omega_count"].sum() <= 60 and arrays["sample_Lambda"].size > 0
    assert (cfg.out / "kuInf.png").stat().st_size > 1000


REPO = Path(__file__).resolve().parent.parent


def test_every_record_at_tiny_sizes_and_no_input_under_shipped_before(tiny, monkeypatch,
                                                                    tmp_path):
    """Each figure with a record makes it from the committed inputs (the protocol's
    comparisons, the ablation's held-out comparisons, the fits) and the shipped policies;
    no record names a file under shipped_before/; dnsFlow names no input there and draws the
    transfer (c) with the ratio to the three DNS-trained runs and their curves (f) from the
    committed records (its replay record was made at the full sizes, so at these it is
    refused and (a) is pending)."""
    from swimrl.paper.build import build_figures

    monkeypatch.chdir(REPO)  # the comparisons name their policies from the repository root
    for name in ("ku0.1", "ku1"):
        shutil.copytree(PRETRAINED_ROOT / name, tmp_path / "policies" / name)
        for seed in (0, 1):
            shutil.copytree(PRETRAINED_ROOT / name, tmp_path / "runs" / f"{name}_seed{seed}")
    cfg = tiny("figures.n_flows=1", "figures.n_swimmers=3", "figures.n_traj=2",
               "figures.durations=[0.5,1.0]", "figures.update_intervals=[0.1,0.2]",
               "figures.swim_speeds=[0.707]")
    built = {}
    for name in settings.RECORDED:
        built.update(build_figures(replace(cfg, only=name), log=lambda _: None))
    assert not any("pending" in v for v in built.values())
    for name in settings.RECORDED:
        rec = records.read_figure_record(cfg.records / f"{name}.json")
        named = [*rec["sources"], *(f for e in rec["evaluations"].values() for f in e["files"])]
        assert not [f for f in named if settings.under_shipped_before(f)], name
    ablation = json.loads((cfg.records / "ablation.json").read_text())
    sets = {tuple(s["signals"]): s for s in ablation["derived"]["signal_sets"]}
    assert sets[("n_theta", "S_np")]["seeds"] == [0, 1, 2]
    assert len(sets[("n_r", "n_theta", "S_nn", "S_np", "omega")]["seeds"]) == 3
    assert ablation["derived"]["held_out"] == {"seed": 0, "n_flows": 100}
    assert any(s.startswith("docs/results/ablation_1e8/held_out/") for s in ablation["sources"])
    perf = json.loads((cfg.records / "smartPerformance.json").read_text())
    assert perf["derived"]["protocol"]["ku10"]["n_flows"] == 100
    pattern = json.loads((cfg.records / "ku_pattern.json").read_text())
    assert set(pattern["derived"]["ku10"]["map_correlation"]) == {"n_theta", "omega"}
    from swimrl.paper.dns_replay import shipped_before_inputs

    assert shipped_before_inputs(cfg.dns) == []
    dns = build_figures(replace(cfg, only="dnsFlow"), log=lambda _: None)["dnsFlow"]
    assert "a" not in dns and "made with other" in dns["pending"]
    assert "no training curve" not in dns["pending"] and len(dns["f"]) == 3
    ratio = dns["trained_ratio"]
    assert ratio["transferred"] == "policy(pretrained/ku10)" and len(ratio["trained"]) == 3
    assert len(ratio["per_realisation"]) == 4 and dns["c"]["smart"]


def test_ku01_record_gains_the_sign_agreement_and_nothing_else_changes(tiny, tmp_path):
    """ku0.1: the fraction of decisions with sign(Lambda) = sign(Lambda_STO) per seed (and
    its mean over seeds) in the record; a record made before it was kept gains it from the
    cached evaluation (with how far that lies from the record) and changes no other field."""
    for seed in (0, 1):
        shutil.copytree(PRETRAINED_ROOT / "ku0.1", tmp_path / "runs" / f"ku0.1_seed{seed}")
    shutil.copytree(PRETRAINED_ROOT / "ku0.1", tmp_path / "policies" / "ku0.1")
    cfg = tiny("figures.n_flows=1", "figures.n_swimmers=3", "figures.n_traj=2")
    first = mechanism.build_ku01(cfg)
    path = cfg.records / "ku0.1.json"
    made = json.loads(path.read_text())
    signs = {s: made["evaluations"][f"ku0.1_seed{s}"]["derived"]["sign_STO"] for s in (0, 1)}
    assert signs[1]["n"] == 60 and signs[1]["undetermined"] >= 6  # n_theta = 0 at the start
    assert "resimulated" not in signs[1] and 0 <= signs[1]["fraction"] <= 1
    per = made["derived"]["per_seed"]
    assert per["1"]["sign_agreement_STO"] == signs[1]["fraction"]
    assert per["sign_agreement_STO_mean"] == pytest.approx(
        np.mean([signs[s]["fraction"] for s in (0, 1)]))
    assert first["sign_smart"] == signs[0]
    old = json.loads(path.read_text())  # as a record made before the counts were kept
    for s in (0, 1):
        del old["evaluations"][f"ku0.1_seed{s}"]["derived"]["sign_STO"]
        del old["derived"]["per_seed"][str(s)]["sign_agreement_STO"]
    for key in ("sign_agreement_STO_mean", "sign_agreement_STO_std"):
        del old["derived"]["per_seed"][key]
    path.write_text(json.dumps(old, indent=2))
    mechanism.build_ku01(cfg)
    new = json.loads(path.read_text())
    assert records._changed(old, new) is None  # only added
    added = new["evaluations"]["ku0.1_seed1"]["derived"]["sign_STO"]
    assert added.pop("resimulated") == {"per_flow_max_abs_diff": 0.0, "same_decisions": True}
    assert added == signs[1] and new["derived"]["per_seed"] == per
    text = path.read_text()
    mechanism.build_ku01(cfg)  # complete: read, not rewritten
    assert path.read_text() == text


def test_ku_inf_record_states_what_is_drawn(tiny):
    """kuInf: the record says which policy and decisions (a) draws and the colour rule of
    (b), (c); the figure's sample is the one stated."""
    cfg = tiny()
    out = mechanism.build_ku_inf(cfg)
    rec = records.read_figure_record(cfg.records / "kuInf.json")
    drawn = rec["derived"]["drawn"]
    assert drawn["seed"] == 0 and drawn["a"]["policy"] == str(cfg.curves / "ku1e7_seed0" /
                                                                "policy.pt")
    assert drawn["a"]["flows"] == 2 and drawn["a"]["sample"] == out["a"]["sample"] == 6
    assert drawn["bc_colour"] == mechanism.occupancy_rule(30)
    text = (cfg.records / "kuInf.json").read_text()
    mechanism.build_ku_inf(cfg)
    assert (cfg.records / "kuInf.json").read_text() == text  # read as made
