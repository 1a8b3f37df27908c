"""Every script in benchmarks/ runs end to end at its tiny ``--smoke`` size (issue 46, "scripts
that cannot rot"): each as a subprocess from outside the source tree, exit status 0 and its table
printed with positive figures. ``gpu_session.sh`` makes its CPU dry run (``SMOKE=1``, the gpu
tests skipped) and writes its records flat into OUT."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
#: The scripts the tests below run, one test each (test_every_script_has_a_smoke_test).
COVERED = {"bench_env.py", "bench_train.py", "bench_dns.py", "bench_replay.py",
           "bench_pyqg_reference.py", "bench_eval.py", "gpu_session.sh", "gpu_wheels.sh",
           "bit_for_bit.py"}
NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def run(args: list[str], cwd: Path, env: dict | None = None, check: bool = True,
        timeout: float = 600) -> subprocess.CompletedProcess:
    """``args`` in ``cwd`` (a scratch directory: the installed swimrl is imported), output kept."""
    proc = subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})
    if check:
        assert proc.returncode == 0, (
            f"{' '.join(map(str, args))}: exit {proc.returncode}\n--- stdout\n{proc.stdout}"
            f"\n--- stderr\n{proc.stderr[-4000:]}")
    return proc


def script(name: str, *args: str, cwd: Path) -> str:
    """stdout of ``python benchmarks/NAME ARGS`` (exit status 0 asserted)."""
    return run([sys.executable, str(BENCH / name), *args], cwd).stdout


def table(text: str, first_column: str) -> tuple[list[str], list[list[str]]]:
    """The header line starting with ``first_column`` and the whitespace-split rows below it
    (until a line that is blank or starts otherwise, e.g. a comment)."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.split()[:1] == [first_column])
    rows = []
    for line in lines[start + 1:]:
        if line.startswith("USDT"):  # torch.profiler's lines, where stderr is merged
            continue
        if not line.strip() or line.startswith(("#", "speed-up", "==")):
            break
        rows.append(line.split())
    return lines[start].split(), rows


def positive(value: str) -> float:
    assert NUMBER.match(value), value
    x = float(value)
    assert x > 0, value
    return x


def test_every_script_has_a_smoke_test():
    scripts = {p.name for p in BENCH.iterdir() if p.suffix in (".py", ".sh")}
    assert scripts == COVERED, f"give every benchmark a smoke test here: {scripts ^ COVERED}"


@pytest.mark.slow  # the benchmark script end to end, three kernels (~8-12 s)
def test_bench_env_smoke(tmp_path):
    out = script("bench_env.py", "--smoke", "--threads", "1", "--kernels", "eager", "fused",
                 "compiled", cwd=tmp_path)
    head, rows = table(out, "batch")
    assert "substeps/s" in head and "ms/interval" in head and "step" in head, out
    assert head[-2:] == ["sys", "%"] and "malloc=retain" in out, out
    assert [r[2] for r in rows] == ["eager", "fused", "compiled"], out
    for r in rows:
        assert r[:2] == ["2x8", "16"], out
        for value in r[3:6]:  # substeps/s, ms/interval, ms/env step
            positive(value)
        assert 0 <= float(r[7]) <= 100, out


def test_bench_env_3d_smoke(tmp_path):
    out = script("bench_env.py", "--smoke", "--threads", "1", "--flow", "stochastic3d",
                 "--n-waves", "4", "--kernels", "eager", "fused", "--malloc", "default",
                 cwd=tmp_path)
    assert "malloc=default" in out, out
    _, rows = table(out, "batch")  # fused: the 3D kernel (issue 62)
    assert [r[:3] for r in rows] == [["2x8", "16", "eager"], ["2x8", "16", "fused"]], out
    for r in rows:
        for value in r[3:6]:
            positive(value)


@pytest.mark.slow  # the benchmark script end to end, two training layouts (~6-9 s)
def test_bench_train_smoke(tmp_path):
    out = script("bench_train.py", "--smoke", "--out", str(tmp_path / "runs"), cwd=tmp_path)
    head, rows = table(out, "variant")
    assert head[:4] == ["variant", "swimmers", "frames", "env"], out
    assert [r[0] for r in rows] == ["long_floor05/eager", "parallel/eager"], out
    for r in rows:
        assert r[1:3] == ["8", "80"], out  # 2 flows x 4 swimmers, L = 10
        positive(r[3])  # env frames/s
        positive(r[6])  # frames/s per update
        positive(r[-1])  # frames/s over an episode
    assert re.search(r"speed-up parallel/eager / long_floor05/eager: \d", out), out


def test_bench_dns_smoke(tmp_path):
    out = script("bench_dns.py", "--smoke", "--json", str(tmp_path / "dns.json"), cwd=tmp_path)
    head, rows = table(out, "device")
    assert "ms/step" in head, out
    assert len(rows) == 1 and rows[0][:5] == ["cpu", "1", "32", "1", "basdevant"], out
    positive(rows[0][6])  # steps/s
    (rec,) = json.loads((tmp_path / "dns.json").read_text())
    assert rec["n"] == 32 and rec["ms_per_step"] > 0 and rec["ms_floor_step"] > 0


@pytest.mark.slow  # the benchmark script end to end: DNS runs, replay, training (~12-20 s)
def test_bench_replay_smoke(tmp_path):
    out = script("bench_replay.py", "--smoke", "--workdir", str(tmp_path / "work"), cwd=tmp_path)
    head, rows = table(out, "n_d")
    assert [r[0] for r in rows] == ["64", "48"], out
    assert float(rows[0][3]) < 0.2  # u_x against the exact series on the full grid
    positive(rows[1][9])  # u_x on the 48^2 grid against the full grid's sampling
    m = re.search(r"eval\.flows_per_batch=2: (\S+) swimmer-substeps/s \(2 flows x 8", out)
    assert m, out
    positive(m.group(1))
    m = re.search(r"flow\.flows_per_start=2: (\S+) frames/s \(updates: ", out)
    assert m, out
    positive(m.group(1))


def test_bench_pyqg_reference_smoke(tmp_path):
    usage = script("bench_pyqg_reference.py", "--help", cwd=tmp_path)
    assert "--smoke" in usage and "--sizes" in usage
    proc = run([sys.executable, str(BENCH / "bench_pyqg_reference.py"), "--smoke"], tmp_path,
               check=False)
    if importlib.util.find_spec("pyqg") is None:
        assert proc.returncode == 3 and "pyqg is not installed" in proc.stderr, proc
        pytest.skip("pyqg is not installed (not a dependency of swimrl: see the script's "
                    "docstring); the script parsed its arguments and said so")
    assert proc.returncode == 0, proc.stderr
    _, rows = table(proc.stdout, "N")
    assert rows[0][0] == "32", proc.stdout
    positive(rows[0][1])


@pytest.mark.slow  # the benchmark script end to end (~5-7 s)
def test_bench_eval_smoke(tmp_path):
    out = script("bench_eval.py", "--smoke", cwd=tmp_path)
    head, rows = table(out, "run")
    assert "decisions/s" in head and "wall" in head, out
    assert [r[:4] for r in rows] == [["1", "2", "8", "20"], ["2", "2", "8", "20"]], out
    for r in rows:
        for value in r[4:8]:  # wall s, episode s, decisions/s, swimmer-decisions/s
            positive(value)
    assert rows[0][8] == rows[1][8], out  # the same flows and policy: the same R_hat


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
@pytest.mark.slow  # all of gpu_session.sh on the CPU: benchmarks, training, records (~30 s)
def test_gpu_session_cpu_dry_run(tmp_path):
    """``SMOKE=1 SKIP_TESTS=1 gpu_session.sh OUT cpu 160 1``: every step on the CPU at a tiny
    size, from a scratch directory; OUT holds the ten flat records."""
    out = tmp_path / "out"
    proc = run(["bash", str(BENCH / "gpu_session.sh"), str(out), "cpu", "160", "1"], tmp_path,
               env={"PYTHON": sys.executable, "SMOKE": "1", "SKIP_TESTS": "1",
                    "TMPDIR": str(tmp_path)})
    assert "all steps done" in proc.stdout, proc.stdout
    files = {p.name for p in out.iterdir()}
    assert files == {"gpu_tests.log", "bench_train_cpu.txt", "bench_env_cpu.txt",
                     "bench_eval_cpu.txt", "train.log", "wall.json", "metrics.json",
                     "curves.csv", "policy.pt", "policies.tar"}, files
    assert all(p.is_file() for p in out.iterdir())
    assert re.search(r"swimrl \S+ from \S+ conf \S+", (out / "gpu_tests.log").read_text())
    _, rows = table((out / "bench_train_cpu.txt").read_text(), "variant")
    assert [r[0] for r in rows] == ["long_floor05/eager", "wide_gpu/eager"]
    _, rows = table((out / "bench_env_cpu.txt").read_text(), "batch")
    positive(rows[0][3])
    _, rows = table((out / "bench_eval_cpu.txt").read_text(), "run")
    positive(rows[0][4])
    wall = json.loads((out / "wall.json").read_text())
    assert wall["frames"] == 160 and wall["wall_s"] > 0 and wall["frames_per_s_training"] > 0
    assert json.loads((out / "metrics.json").read_text())["training"]["n_updates"] == 2


def test_gpu_wheels_parses():
    """gpu_wheels.sh downloads wheels (network): only its syntax is checked here."""
    for name in ("gpu_wheels.sh", "gpu_session.sh"):
        proc = subprocess.run(["bash", "-n", str(BENCH / name)], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr


@pytest.mark.slow  # two trees: three evaluations, a resume, one figure on a fresh clone (~1-2 min)
@pytest.mark.skipif(shutil.which("git") is None or not (BENCH.parent / ".git").exists(),
                    reason="needs the git checkout")
def test_bit_for_bit_tiny_against_head():
    """``bit_for_bit.py --base HEAD --tiny``: the script runs end to end and finds this
    checkout equal to its own HEAD's code (the committed code, in a worktree)."""
    p = subprocess.run([sys.executable, str(BENCH / "bit_for_bit.py"), "--base", "HEAD",
                        "--tiny"], cwd=BENCH.parent, capture_output=True, text=True,
                       timeout=1200)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    assert "PASS: bit for bit" in p.stdout
    assert p.stdout.count(": equal") == 4  # three evaluations and the resume


def test_bit_for_bit_comparison_finds_a_difference(tmp_path):
    """The comparison can fail: one changed number in the trajectories or the metrics."""
    spec = importlib.util.spec_from_file_location("bit_for_bit", BENCH / "bit_for_bit.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    a, b = tmp_path / "a", tmp_path / "b"
    for d in (a, b):
        d.mkdir()
        np.savez(d / "trajectories.npz", Lambda=np.arange(6.0).reshape(2, 3))
        (d / "metrics.json").write_text(json.dumps({"per_flow": [0.5, 0.6]}))
    assert mod.same_eval(a, b) is None
    np.savez(b / "trajectories.npz", Lambda=np.arange(6.0).reshape(2, 3) + 1e-12)
    assert "Lambda" in mod.same_eval(a, b)
    np.savez(b / "trajectories.npz", Lambda=np.arange(6.0).reshape(2, 3))
    (b / "metrics.json").write_text(json.dumps({"per_flow": [0.5, 0.6000001]}))
    assert "per_flow" in mod.same_eval(a, b)
