"""Acceptance (issue 12): bad input never becomes a result.

Every bad input of the table below, given to the real command: exit status 2, the key (or
option, or file) named on the last line of standard error, no traceback, no run directory,
no result file, no DNS store. The cases run a few per process (``tests/cli_cases.py``):
each must fail before any compute, so the whole table takes seconds.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from swimrl.flows.dns.store import DNSStoreWriter

from .conftest import SMALL
from .test_train import TINY

EVAL, TRAIN, DNS = "swimrl.cli.eval", "swimrl.cli.train", "swimrl.cli.dns"
COMPARE, TABLE, DNS_PLOTS = "swimrl.cli.compare", "swimrl.cli.table", "swimrl.cli.dns_plots"

#: (command, arguments, what the last stderr line must name); {tmp}: the test's directory
CASES = [
    # non-finite and degenerate physics (issue item 1)
    (EVAL, ["swimmer.swim_speed=inf"], "swimmer.swim_speed=inf"),
    (EVAL, ["swimmer.swim_speed=0"], "swimmer.swim_speed=0"),
    (EVAL, ["swimmer.swim_speed=nan"], "swimmer.swim_speed=nan"),
    (EVAL, ["swimmer.rot_diffusion=inf"], "swimmer.rot_diffusion=inf"),
    (EVAL, ["swimmer.rot_diffusion=-0.1"], "swimmer.rot_diffusion"),
    (EVAL, ["swimmer.shape_factor_max=nan"], "swimmer.shape_factor_max"),
    (TRAIN, ["optim.lr_actor=inf"], "optim.lr_actor=inf"),
    (TRAIN, ["optim.lr_critic=nan"], "optim.lr_critic=nan"),
    # keys named by their own errors (item 6)
    (EVAL, ["episode.duration=0"], "episode.duration=0"),
    (EVAL, ["episode.duration=-5"], "episode.duration=-5"),
    (EVAL, ["episode.duration=nan"], "episode.duration=nan"),
    (EVAL, ["episode.duration=inf"], "episode.duration=inf"),
    (EVAL, ["episode.dt=0.03"], "episode.dt"),
    (EVAL, ["episode.update_interval=300"], "episode.update_interval"),
    (TRAIN, ["train.total_frames=inf"], "train.total_frames=inf"),
    (TRAIN, ["loss.gamma=nan"], "loss.gamma"),
    (TRAIN, ["model.init_std=inf"], "model.init_std"),
    (TRAIN, ["model.min_std=2.0"], "model.min_std=2.0"),
    (TRAIN, ["model.min_std=0"], "model.min_std=0"),
    (TRAIN, ["resume=maybe"], "resume"),
    (EVAL, ["seed=-1"], "seed=-1"),
    (TRAIN, ["seed=-1"], "seed=-1"),
    (EVAL, ["flow.spacing=inf"], "flow.spacing=inf"),
    (EVAL, ["flow.kubo=inf"], "flow.kubo=inf"),
    (EVAL, ["flow.kubo=-1"], "flow.kubo"),
    (EVAL, ["flow.n_modes=inf"], "flow.n_modes"),
    (EVAL, ["flow.n_grid=63"], "flow.n_grid"),
    (EVAL, ["eval.n_swimmers=inf"], "eval.n_swimmers"),
    (EVAL, ["threads=0"], "threads"),
    (EVAL, ["device=tpu"], "device"),
    (EVAL, ["strategy=naive", "strategy.shape_factor=nan"], "strategy.shape_factor"),
    (EVAL, ["strategy=policy"], "policy="),
    (EVAL, ["strategy=policy", "policy={tmp}/policy.txt"], "{tmp}/policy.txt"),
    (EVAL, ["strategy=policy", "policy={tmp}/nowhere"], "{tmp}/nowhere"),
    (EVAL, ["flow=dns", "flow.spinup.time=inf"], "flow.spinup.time"),
    (EVAL, ["flow=dns", "flow.dns.nu=inf"], "flow.dns.nu"),
    (COMPARE, ["compare.naive_shape_factors=[nan]"], "shape_factor"),
    (COMPARE, ["compare.strategies=[minimal]", "compare.minimal_fits=[{tmp}/nowhere]"],
     "{tmp}/nowhere"),
    (COMPARE, ["compare.strategies=[sto]", "compare.minimal_fits=[{tmp}/fit]"],
     "compare.minimal_fits"),
    (COMPARE, ["compare.strategies=[minimal]", "compare.minimal_fits=[{tmp}/nanfit]"],
     "{tmp}/nanfit"),
    # incomplete DNS store (item 7)
    (EVAL, ["flow=dns_replay", "flow.path={tmp}/incomplete.zarr"], "flow.allow_incomplete"),
    (EVAL, ["flow=dns_replay", "flow.path={tmp}/nowhere.zarr"], "flow.path"),
    (EVAL, ["flow=dns_replay", "flow.path=[{tmp}/incomplete.zarr,{tmp}/nowhere.zarr]",
            "flow.allow_incomplete=true"], "{tmp}/nowhere.zarr"),
    (EVAL, ["flow=dns_replay", "flow.path={tmp}/incomplete.zarr", "flow.allow_incomplete=true",
            "flow.decode_n=7"], "flow.decode_n"),
    (EVAL, ["flow=dns_replay", "flow.path={tmp}/incomplete.zarr", "flow.allow_incomplete=true",
            "flow.flows_per_start=0"], "flow.flows_per_start"),
    # DNS config gaps (item 3): store.path={tmp}/store.zarr must not appear
    (DNS, ["store.n_times=0"], "store.n_times=0"),
    (DNS, ["store.chunk_times=0"], "store.chunk_times=0"),
    (DNS, ["spinup.time=-1"], "spinup.time"),
    (DNS, ["store.interval_tau_k=-1"], "store.interval_tau_k"),
    (DNS, ["init.kind=bogus"], "init.kind"),
    (DNS, ["dns.nu=inf"], "dns.nu"),
    (DNS, ["max_steps=inf"], "max_steps"),
    (DNS, ["store.path={tmp}/foreign"], "{tmp}/foreign"),
    # gyrotaxis and steering: one line naming the key, before compute
    (EVAL, ["swimmer.bottom_heaviness=0"], "swimmer.bottom_heaviness=0"),
    (EVAL, ["swimmer.bottom_heaviness=-1"], "swimmer.bottom_heaviness=-1"),
    (EVAL, ["actuation=steer"], "actuation.name='steer'"),
    (EVAL, ["flow=stochastic3d", "signals=state12"], "signals.names"),
    (EVAL, ["flow=taylor_green", "actuation=steer", "swimmer.psi=1", "strategy=sto"],
     "strategy=sto"),
    (EVAL, ["flow=taylor_green", "strategy=hand_rule"], "strategy=hand_rule"),
    (EVAL, ["flow=taylor_green", "actuation=steer", "swimmer.psi=1", "strategy=table",
            "strategy.table=uuux"], "strategy.table"),
    (EVAL, ["swimmer.phi=0.3"], "swimmer.phi=0.3"),
    (EVAL, ["flow=taylor_green", "actuation=shape_steer", "actuation.directions=discrete",
            "swimmer.psi=1"], "actuation.directions='discrete'"),
    (EVAL, ["flow=taylor_green", "task=vertical", "task.burn_in=500"], "task.burn_in=500"),
    # swimrl-distill: a baseline teacher, the fit's keys
    ("swimrl.cli.distill", ["strategy=policy", "policy=pretrained/ku10"], "strategy"),
    ("swimrl.cli.distill", ["distill.holdout=1"], "distill.holdout=1"),
    ("swimrl.cli.distill", ["distill.stride=0"], "distill.stride=0"),
    ("swimrl.cli.distill", ["distill.lr=-1"], "distill.lr=-1"),
    ("swimrl.cli.distill", ["flow=taylor_green", "actuation=steer",
                            "actuation.directions=discrete", "swimmer.psi=1",
                            "strategy=hand_rule"], "actuation.directions"),
    # argparse commands (item 7)
    (TABLE, ["{tmp}/sweep", "--average", "sead"], "--average sead"),
    (TABLE, ["{tmp}/sweep", "--bogus"], "--bogus"),
    (DNS_PLOTS, ["{tmp}/incomplete.zarr", "--snapshots", "0"], "--snapshots"),
    (DNS_PLOTS, ["{tmp}/incomplete.zarr", "--bogus"], "--bogus"),
]


def _fill(text: str, tmp: Path) -> str:
    return text.replace("{tmp}", str(tmp))


def _fixtures(tmp: Path) -> None:
    (tmp / "policy.txt").write_text("not a policy\n")
    DNSStoreWriter.create(tmp / "incomplete.zarr", {"n": 8})  # status "created"
    for name, c1 in (("fit", 1.0), ("nanfit", "NaN")):
        (tmp / name).mkdir()
        (tmp / name / "fit.json").write_text(json.dumps(
            {"coefficients": {"c1": c1, "c2": 0.0, "c3": 0.0, "c4": 0.0}}))
    (tmp / "foreign").mkdir()
    (tmp / "foreign" / "keep.txt").write_text("precious")
    run = tmp / "sweep" / "0"
    run.mkdir(parents=True)
    (run / "metrics.json").write_text(json.dumps({
        "strategy": "sto", "R_hat_mean": 0.5, "R_hat_sem": 0.01, "R_hat_std": 0.02,
        "n_flows": 2, "n_swimmers": 4, "config": {"seed": 0, "flow": {"name": "stochastic"}}}))


def _args(module: str, args: list[str], tmp: Path, i: int) -> list[str]:
    args = [_fill(a, tmp) for a in args]
    if module in (EVAL, COMPARE):
        small = [a for a in SMALL if not a.startswith("flow.")] if any(
            a.startswith("flow=") for a in args) else SMALL
        return [*small, *args, f"hydra.run.dir={tmp}/run{i}"]
    if module == TRAIN:
        return [*TINY, *args, f"hydra.run.dir={tmp}/run{i}"]
    if module == DNS:
        path = [] if any(a.startswith("store.path=") for a in args) else [
            f"store.path={tmp}/store{i}.zarr"]
        return ["progress=false", *args, *path, f"hydra.run.dir={tmp}/run{i}"]
    return args


def _run_cases(cases: list, cwd: Path) -> list[dict]:
    out = subprocess.run([sys.executable, "-m", "tests.cli_cases"], input=json.dumps(cases),
                         capture_output=True, text=True, timeout=600, cwd=cwd,
                         env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1])})
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_every_bad_input_is_one_line_exit_2_and_leaves_nothing(tmp_path):
    _fixtures(tmp_path)
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    cases = [[m, _args(m, a, tmp_path, i)] for i, (m, a, _) in enumerate(CASES)]
    results = _run_cases(cases, tmp_path)
    failures = []
    for (module, args, key), res in zip(CASES, results, strict=True):
        lines = res["stderr"].strip().splitlines()
        last = lines[-1] if lines else ""
        if res["rc"] != 2 or _fill(key, tmp_path) not in last or "Traceback" in res["stderr"]:
            failures.append(f"{module} {args}: rc={res['rc']} stderr={res['stderr'][-500:]!r}")
    assert not failures, "\n".join(failures)
    # no run directory, no result file, no store; the fixtures untouched
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before
    assert (tmp_path / "foreign" / "keep.txt").read_text() == "precious"


def _tree(root: Path) -> dict[str, tuple[str, int]]:
    """``relative path -> (sha256, mtime_ns)`` of every file below ``root``."""
    return {str(p.relative_to(root)): (hashlib.sha256(p.read_bytes()).hexdigest(),
                                       p.stat().st_mtime_ns)
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.slow  # a two-job training sweep, run twice, in subprocesses (~15 s)
def test_sweep_relaunch_with_resume_is_a_no_op(tmp_path):
    """``-m seed=0,1 resume=true`` over two finished jobs exits 0 and changes nothing."""
    sweep = tmp_path / "sweep"
    cmd = [sys.executable, "-m", TRAIN, "-m", *TINY, "train.eval_every=0", "seed=0,1",
           "resume=true", f"hydra.sweep.dir={sweep}"]
    first = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert first.returncode == 0, first.stderr[-3000:]
    assert sorted(p.parent.name for p in sweep.rglob("metrics.json")) == ["0", "1"]
    jobs = {j: _tree(sweep / j) for j in ("0", "1")}
    multirun_yaml = (sweep / "multirun.yaml").read_text()
    again = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert again.returncode == 0, again.stderr[-3000:]
    assert again.stdout.count("already finished") == 2
    assert {j: _tree(sweep / j) for j in ("0", "1")} == jobs
    # Hydra's launcher rewrites the sweep's own multirun.yaml: same content
    assert (sweep / "multirun.yaml").read_text() == multirun_yaml
    # a refused rerun (no resume, no overwrite) of a finished job touches nothing either
    single = [sys.executable, "-m", TRAIN, *TINY, "train.eval_every=0", "seed=0",
              f"hydra.run.dir={sweep / '0'}"]
    refused = subprocess.run(single, capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert refused.returncode == 2 and "overwrite=true" in refused.stderr.splitlines()[-1]
    assert "Traceback" not in refused.stderr
    assert _tree(sweep / "0") == jobs["0"]


@pytest.mark.parametrize("damage", ["truncate", "text"])
def test_corrupt_policy_file_is_one_line_with_its_path(tmp_path, damage):
    from swimrl.errors import BadFileError
    from swimrl.runs.policy_files import load_file, resolve_policy_file

    src = resolve_policy_file("pretrained/ku10").read_bytes()
    bad = tmp_path / "policy.pt"
    bad.write_bytes(src[: len(src) // 2] if damage == "truncate" else b"hello\n")
    with pytest.raises(BadFileError) as err:
        load_file(bad)
    msg = str(err.value)
    assert str(bad) in msg and "\n" not in msg and "weights_only" not in msg
