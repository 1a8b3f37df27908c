"""Cluster-safe runs: a preemption signal stops a run at its next safe point with its state
saved (exit status 75, one log line) and ``resume=true`` finishes it; one process at a time
works in a run directory (``.lock``), and a lock file left by a dead process does not block.

The commands run as real processes and get real signals (``os.kill``)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from swimrl.config import compare_config, train_config
from swimrl.evaluation.compare import compare
from swimrl.rl.run import train
from swimrl.runs.jobs import (
    PREEMPTED_EXIT,
    Preempted,
    RunDirInUseError,
    preemption_signals,
    refuse_if_locked,
    run_lock,
)
from swimrl.runs.layout import RunLayout
from swimrl.runs.policy_files import load_file

from .conftest import SMALL
from .test_bad_input import COMPARE, EVAL, TRAIN, _run_cases
from .test_train import TINY

#: 30 updates of 80 frames, a checkpoint after each, no periodic evaluation
LONGER = [*TINY, "train.total_frames=2400", "train.eval_every=0"]
#: 2 strategies x 4 chunks of one flow, each chunk ~0.3 s
COMPARISON = [*(a for a in SMALL if not a.startswith("episode.")), "episode.duration=5.0",
              "eval.n_flows=4", "eval.flows_per_batch=1", "eval.n_swimmers=4",
              "compare.strategies=[sto,naive]"]


def _start(module: str, args: list[str], cwd: Path) -> tuple[subprocess.Popen, Path]:
    """The command as a process, its stdout and stderr into ``cwd/output.txt``."""
    log = cwd / "output.txt"
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(Path(__file__).parents[1])}
    with log.open("w") as f:
        proc = subprocess.Popen([sys.executable, "-m", module, *args], cwd=cwd, env=env,
                                stdout=f, stderr=subprocess.STDOUT)
    return proc, log


def _wait_for(path: Path, proc: subprocess.Popen, log: Path, timeout: float = 180) -> None:
    t0 = time.monotonic()
    while not path.exists():
        assert proc.poll() is None, f"exited {proc.returncode} early:\n{log.read_text()[-3000:]}"
        assert time.monotonic() - t0 < timeout, f"no {path} after {timeout} s"
        time.sleep(0.02)


def _stop(proc: subprocess.Popen, signum: int, log: Path) -> tuple[int, str]:
    assert proc.poll() is None, f"finished before the signal:\n{log.read_text()[-3000:]}"
    os.kill(proc.pid, signum)
    try:
        rc = proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    return rc, log.read_text()


def _preempted(rc: int, text: str, pattern: str) -> re.Match:
    """Exit status 75, no traceback and exactly one ``preempted`` line, matching ``pattern``."""
    assert rc == PREEMPTED_EXIT, text[-3000:]
    lines = [line for line in text.splitlines() if "preempted" in line]
    assert len(lines) == 1 and "Traceback" not in text, text[-3000:]
    m = re.search(pattern, lines[0])
    assert m, lines[0]
    return m


def _dead_pid() -> int:
    """The PID of a process that has exited."""
    done = subprocess.Popen([sys.executable, "-c", "pass"])
    done.wait()
    return done.pid


def test_sigterm_stops_training_after_the_update_in_flight_and_resume_finishes(
        compose_cfg, tmp_path):
    out = tmp_path / "run"
    resumed = train_config(compose_cfg([*LONGER, "resume=true"], name="train"))
    proc, log = _start(TRAIN, [*LONGER, f"hydra.run.dir={out}"], tmp_path)
    _wait_for(RunLayout(out).prev_checkpoint, proc, log)  # two updates done
    # a second process on the running directory is refused before any compute
    holder = f"PID {proc.pid} on host "
    with pytest.raises(RunDirInUseError, match=holder):
        refuse_if_locked(out)
    with pytest.raises(RunDirInUseError, match=holder):
        train(resumed, out)
    rc, text = _stop(proc, signal.SIGTERM, log)
    m = _preempted(rc, text, r"preempted by SIGTERM after update (\d+)/30 \((\d+) frames\): "
                   r"checkpoint written to (\S+); continue with resume=true$")
    assert Path(m[3]) == RunLayout(out).checkpoint, m[0]
    updates = int(m[1])
    assert 2 <= updates < 30 and int(m[2]) == 80 * updates
    assert load_file(RunLayout(out).checkpoint)["counters"]["updates"] == updates
    assert m[0] in (out / "train.log").read_text()
    assert not RunLayout(out).lock.exists() and not (out / "metrics.json").exists()
    # a lock file left by a killed process blocks nothing; resume=true finishes the run
    RunLayout(out).lock.write_text(json.dumps({"pid": _dead_pid(), "host": "x", "command": "x",
                                             "since": "x"}))
    metrics = train(resumed, out)
    assert metrics["training"]["updates"] == 30 and metrics["training"]["frames"] == 2400
    assert (out / "metrics.json").is_file() and not RunLayout(out).lock.exists()


#: TINY with a periodic evaluation of 2 flows x 100 000 swimmers (seconds per evaluation)
BIG_EVAL = [*TINY, "train.eval_every=2", "train.eval_flows=2", "train.eval_swimmers=100000",
            "eval.flows_per_batch=2"]


@pytest.mark.slow  # a real SIGTERM in a 2 x 100 000-swimmer evaluation, then resume (~40 s)
def test_sigterm_inside_a_periodic_evaluation_checkpoints_at_once_and_resume_makes_it(
        compose_cfg, tmp_path):
    """A signal that arrives during an evaluation is answered before the evaluation's next
    decision (exit 75 within 10 s, one line), the checkpoint marks the evaluation pending and
    ``resume=true`` makes it first, then finishes the run."""
    out = tmp_path / "run"
    proc, log = _start(TRAIN, [*BIG_EVAL, f"hydra.run.dir={out}"], tmp_path)
    _wait_for(RunLayout(out).periodic_policy(0), proc, log)  # the first evaluation started
    time.sleep(0.5)
    t0 = time.monotonic()
    rc, text = _stop(proc, signal.SIGTERM, log)
    assert time.monotonic() - t0 < 10, text[-2000:]
    _preempted(rc, text, r"preempted by SIGTERM during the periodic evaluation after update "
               r"0/4 \(0 frames\): checkpoint written to \S+; continue with resume=true$")
    ck = load_file(RunLayout(out).checkpoint)
    assert ck["counters"]["updates"] == 0 and ck["counters"]["eval_pending"] is True
    metrics = train(train_config(compose_cfg([*BIG_EVAL, "resume=true"], name="train")), out)
    assert metrics["training"]["updates"] == 4 and "eval_pending" not in metrics["training"]
    curve = (out / "curves.csv").read_text().splitlines()
    evals = [row.split(",")[0] for row in curve[1:] if row.split(",")[1]]
    assert evals == ["0", "160", "320"], curve


@pytest.mark.slow  # a real SIGUSR1 to a swimrl-compare process, then its resume (~13 s)
def test_sigusr1_stops_a_comparison_inside_the_chunk_in_flight(compose_cfg, tmp_path):
    out = tmp_path / "run"
    proc, log = _start(COMPARE, [*COMPARISON, f"hydra.run.dir={out}"], tmp_path)
    _wait_for(RunLayout(out).comparison_partial, proc, log)  # the first chunk is done
    rc, text = _stop(proc, signal.SIGUSR1, log)
    m = _preempted(rc, text, r"preempted by SIGUSR1 with (\d+) flow chunk\(s\) of 8 left: "
                   r"partial record written to (\S+); continue with compare.resume=true$")
    assert Path(m[2]) == RunLayout(out).comparison_partial, m[0]
    state = json.loads(RunLayout(out).comparison_partial.read_text())
    assert 1 <= sum(len(d) for d in state["done"]) == 8 - int(m[1]) < 8
    assert not (out / "comparison.json").exists() and not RunLayout(out).lock.exists()
    # compare.resume=true completes it: the uninterrupted comparison's numbers
    resumed = compare(compare_config(compose_cfg([*COMPARISON, "compare.resume=true"],
                                                 name="compare")),
                      RunLayout(out).comparison_partial)
    whole = compare(compare_config(compose_cfg(COMPARISON, name="compare")))
    for a, b in zip(resumed["rows"], whole["rows"], strict=True):
        assert a["label"] == b["label"] and a["per_flow"] == b["per_flow"]
        assert (a["R_hat_mean"], a["ratio_to_first"]) == (b["R_hat_mean"], b["ratio_to_first"])
    assert resumed["flow_stats"] == whole["flow_stats"]


def test_every_command_refuses_a_locked_run_directory(tmp_path):
    """While another process (this one) holds a run directory, swimrl-train, -compare and -eval
    on it exit with status 2 and one line naming the holder, and write nothing there (the
    check runs before Hydra writes ``.hydra/``); a multirun job is refused the same way."""
    run = tmp_path / "run"
    sweep = tmp_path / "sweep"
    with run_lock(run, "test"), run_lock(sweep / "0", "test"):
        results = _run_cases([
            [TRAIN, [*TINY, "resume=true", f"hydra.run.dir={run}"]],
            [COMPARE, [*SMALL, "compare.resume=true", f"hydra.run.dir={run}"]],
            [EVAL, [*SMALL, f"hydra.run.dir={run}"]],
            [TRAIN, ["-m", *TINY, "seed=0", "resume=true", f"hydra.sweep.dir={sweep}"]],
        ], tmp_path)
        assert sorted(p for p in run.iterdir()) == [RunLayout(run).lock]
    for res in results:
        last = res["stderr"].strip().splitlines()[-1]
        assert res["rc"] == 2 and "Traceback" not in res["stderr"], res
        assert f"is locked by PID {os.getpid()} on host" in last and "(test since" in last, last
    assert not any(run.iterdir())


def test_a_stale_lock_file_does_not_block_and_a_held_one_does(tmp_path):
    RunLayout(tmp_path).lock.write_text(json.dumps({"pid": _dead_pid(), "host": "gone"}))
    refuse_if_locked(tmp_path)  # nobody holds it
    with run_lock(tmp_path, "first") as path:
        info = json.loads(path.read_text())
        assert (info["pid"], info["command"]) == (os.getpid(), "first")
        refuse_if_locked(tmp_path)  # our own lock
        second = run_lock(tmp_path, "second")
        with pytest.raises(RunDirInUseError, match=rf"PID {os.getpid()} on host .*\(first since"):
            second.__enter__()
    assert not path.exists()
    with run_lock(tmp_path, "third"):  # free again
        pass


def test_signals_are_recorded_then_chained_and_the_handlers_restored():
    """Inside the context a signal only sets the flag; :meth:`stop` calls a Python handler
    that was there before (submitit's requeue) and raises ``Preempted`` (exit status 75); an
    ignored signal stays ignored, and the previous handlers come back."""
    chained = []
    before = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGUSR1, signal.SIGUSR2)}
    try:
        signal.signal(signal.SIGUSR1, signal.SIG_IGN)
        signal.signal(signal.SIGUSR2, lambda signum, frame: chained.append(signum))
        installed = {s: signal.getsignal(s) for s in before}
        with preemption_signals() as p:
            for signum in (signal.SIGUSR1, signal.SIGTERM, signal.SIGUSR2):
                os.kill(os.getpid(), signum)
            for _ in range(100):
                if len(p.received) == 2:
                    break
                time.sleep(0.01)
            assert p.received == [signal.SIGTERM, signal.SIGUSR2] and not chained
            with pytest.raises(Preempted) as stopped:
                p.stop("after the test")
        assert stopped.value.code == PREEMPTED_EXIT
        assert str(stopped.value) == "preempted by SIGTERM+SIGUSR2 after the test"
        assert chained == [signal.SIGUSR2]
        assert {s: signal.getsignal(s) for s in before} == installed
    finally:
        for signum, handler in before.items():
            signal.signal(signum, handler)
