"""docs/recipes.md runs as written: the files it shows are the files on disk, and the commands
of each recipe (its ``bash`` blocks, in order) run at a tiny size in a fresh directory.

The page's commands are run as they stand, through bash, from a temporary directory that
holds a link to ``examples/``; each ``swimrl-*`` or ``python`` command gets overrides appended
that shrink it (few frames, 1 flow x 8 swimmers, episodes of 2 tau_K, the eager kernel;
Hydra takes the last value of a key). The Slurm sweep runs with the basic launcher instead of
Slurm's, and the Slurm launcher's keys are checked on the batch script submitit would submit.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "recipes.md"
BIN = Path(sys.executable).parent
FENCE = re.compile(r"^```(\w+)\n(.*?)^```$", re.S | re.M)
#: A block that shows a file: its first line names it, relative to the repository root.
FILE_LINE = re.compile(r"# ((?:examples|conf)/\S+)\n")

#: Tiny sizes: the stochastic flow on a coarse grid, short episodes, the eager kernel.
EVAL_TINY = ["threads=1", "kernel=eager", "flow.n_grid=64", "flow.spacing=0.1",
             "episode.duration=2", "eval.n_flows=1", "eval.n_swimmers=8", "eval.progress=false"]
TRAIN_TINY = ["train.n_flows=2", "train.n_swimmers=4", "train.rollout_length=10",
              "train.total_frames=160", "train.minibatch_size=40", "train.eval_every=0",
              "train.compile=false", "train.progress=false"]
#: The same for a flow evaluated at the swimmers (no grid keys; its kernel is eager).
POINT_TINY = ["threads=1", "episode.duration=2", "eval.n_flows=1", "eval.n_swimmers=8",
              "eval.progress=false"]


def sections() -> dict[str, list[tuple[str, str]]]:
    """``{heading: [(language, code), ...]}`` of the page's ``##`` sections."""
    parts = re.split(r"^## (.+)$", PAGE.read_text(encoding="utf-8"), flags=re.M)
    return {title.strip(): FENCE.findall(body) for title, body in zip(parts[1::2], parts[2::2],
                                                                        strict=True)}


def commands(section: str) -> list[str]:
    """The bash blocks of a section, in order."""
    return [code for lang, code in sections()[section] if lang == "bash"]


def outputs(section: str) -> list[str]:
    """The text blocks (printed output) of a section, in order."""
    return [code for lang, code in sections()[section] if lang == "text"]


def shrink(block: str, extra: dict[str, list[str]], adapt=None) -> str:
    """``block`` with ``extra[command]`` appended to each command it names (``swimrl-train``,
    or the script's file name for ``python SCRIPT``), after ``adapt(words)``."""
    out = []
    for line in block.replace("\\\n", " ").splitlines():
        words = shlex.split(line, comments=True)
        if not words or words[0] == "export":
            out.append(line)
            continue
        key = Path(words[1]).name if words[0] == "python" and len(words) > 1 else words[0]
        assert key in extra, f"no tiny size for {key!r}: {line}"
        if adapt is not None:
            words = adapt(words)
        out.append(shlex.join(words + extra[key]))
    return "\n".join(out) + "\n"


def run(script: str, cwd: Path, env: dict | None = None) -> str:
    """``script`` through bash in ``cwd`` (this interpreter's commands first on PATH)."""
    environ = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}",
               "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg", **(env or {})}
    environ.pop("PYTHONPATH", None)
    proc = subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=cwd, env=environ,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"{script}\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}"
    return proc.stdout


@pytest.fixture
def workdir(tmp_path) -> Path:
    """A fresh directory with the recipes' files where the page's commands expect them."""
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    return tmp_path


def test_the_page_shows_the_recipe_files_as_they_are():
    shown = {}
    for _, code in FENCE.findall(PAGE.read_text(encoding="utf-8")):
        m = FILE_LINE.match(code)
        if m:
            shown[m.group(1)] = code
    on_disk = {p.relative_to(ROOT).as_posix() for p in (ROOT / "examples" / "recipes").rglob("*")
               if p.is_file() and "__pycache__" not in p.parts}
    assert set(shown) == on_disk
    for path, code in shown.items():
        assert code == (ROOT / path).read_text(encoding="utf-8"), f"{path} differs from the page"
    assert set(sections()) == {"Train on your own signal set", "A sweep on Slurm",
                               "A new flow end to end"}


@pytest.mark.slow  # the recipe's commands end to end: train, compare, a script (~22 s)
def test_own_signal_set_and_computed_signal(workdir):
    train, python = commands("Train on your own signal set")
    tiny = {"swimrl-train": EVAL_TINY + TRAIN_TINY, "swimrl-compare": EVAL_TINY,
            "alignment_signal.py": EVAL_TINY + TRAIN_TINY}
    run(shrink(train, tiny), workdir)
    out = workdir / "outputs" / "recipes"
    metrics = json.loads((out / "ku1_nth_snp_w" / "metrics.json").read_text())
    assert metrics["config"]["signals"]["names"] == ["n_theta", "S_np", "omega"]
    assert metrics["config"]["flow"]["kubo"] == 1
    rows = json.loads((out / "ku1_nth_snp_w" / "comparison.json").read_text())["rows"]
    trained = {row["label"].split("(")[0]: row for row in rows}
    assert set(trained) == {"sto", "naive", "policy"}
    again = json.loads((out / "ku1_nth_snp_w_compare" / "comparison.json").read_text())["rows"]
    assert [row["label"].split("(")[0] for row in again] == ["sto", "naive", "policy"]

    printed = run(shrink(python, tiny), workdir)
    record = json.loads((out / "ku1_alignment" / "alignment_signal.json").read_text())
    assert record["signals"] == ["n_theta", "S_np", "omega*S_np"]
    assert (out / "ku1_alignment" / "actor.pt").is_file()
    assert "| policy[n_theta,S_np,omega*S_np] |" in printed
    # the same held-out flows and starts as swimrl-train's final evaluation: the same STO
    assert record["sto"] == pytest.approx(trained["sto"]["per_flow"], rel=1e-6)


@pytest.mark.slow  # the recipe's sweep run locally end to end (~24 s)
def test_slurm_sweep_runs_locally_and_its_launcher_keys_reach_sbatch(workdir, tmp_path_factory):
    check, sweep = commands("A sweep on Slurm")
    printed = run(shrink(check, {"swimrl-train": []}), workdir)
    launcher = yaml.safe_load(printed)
    assert launcher["_target_"].endswith("submitit_launcher.SlurmLauncher")
    assert (launcher["partition"], launcher["timeout_min"], launcher["cpus_per_task"],
            launcher["mem_gb"]) == ("compute", 60, 1, 4)
    assert printed.strip() == outputs("A sweep on Slurm")[0].strip()
    assert sbatch_lines(launcher, tmp_path_factory.mktemp("submitit")) >= {
        "--partition=compute", "--time=60", "--cpus-per-task=1", "--mem=4GB"}

    def local(words):
        """The sweep with Hydra's basic launcher, at 2 Kubo numbers x 1 seed."""
        assert "hydra/launcher=slurm" in words and words[1] == "-m"
        words = ["hydra/launcher=basic" if w == "hydra/launcher=slurm" else w for w in words
                 if not w.startswith("hydra.launcher.")]
        return words + ["flow.kubo=1,10", "seed=0"]

    def adapt(words):
        return local(words) if words[0] == "swimrl-train" else words

    run(shrink(sweep, {"swimrl-train": EVAL_TINY + TRAIN_TINY, "swimrl-performance": []},
               adapt), workdir)
    jobs = workdir / "multirun" / "ku_seeds"
    kubo = {json.loads((jobs / j / "metrics.json").read_text())["config"]["flow"]["kubo"]
            for j in ("0", "1")}
    assert kubo == {1, 10} and (jobs / "1" / "comparison.json").is_file()
    table = (jobs / "performance.md").read_text()
    assert re.search(r"^\| 1 \|", table, re.M) and re.search(r"^\| 10 \|", table, re.M)
    assert (jobs / "performance.png").stat().st_size > 1000


def sbatch_lines(launcher: dict, folder: Path) -> set[str]:
    """The ``#SBATCH`` options of the batch script the submitit launcher would submit for
    ``launcher`` (its ``hydra.launcher`` config), without a cluster: the executor is built as
    ``SlurmLauncher.launch`` builds it, with a stand-in ``srun`` on PATH for its check."""
    submitit = pytest.importorskip("submitit")
    from hydra_plugins.hydra_submitit_launcher.config import BaseQueueConf
    from omegaconf import OmegaConf

    fake = folder / "bin"
    fake.mkdir()
    (fake / "srun").write_text("#!/bin/sh\nexit 1\n")
    (fake / "srun").chmod(0o755)
    params = {k: v for k, v in launcher.items() if k not in ("_target_", "submitit_folder")}
    params["name"] = "swimrl-train"
    init = {"slurm_max_num_timeout": params.pop("max_num_timeout")}
    base = set(OmegaConf.structured(BaseQueueConf).keys())
    path = os.environ["PATH"]
    os.environ["PATH"] = f"{fake}{os.pathsep}{path}"
    try:
        executor = submitit.AutoExecutor(cluster="slurm", folder=folder, **init)
    finally:
        os.environ["PATH"] = path
    executor.update_parameters(**{k if k in base else f"slurm_{k}": v for k, v in params.items()})
    text = executor._executor._make_submission_file_text("true", "0")
    return {line.removeprefix("#SBATCH ") for line in text.splitlines()
            if line.startswith("#SBATCH ")}


@pytest.mark.slow  # the recipe's new flow: train and compare end to end (~22 s)
def test_new_flow_end_to_end(workdir):
    (block,) = commands("A new flow end to end")
    tiny = {"oscillating_cells.py": [], "swimrl-compare": POINT_TINY,
            "swimrl-train": POINT_TINY + TRAIN_TINY}
    printed = run(shrink(block, tiny), workdir)
    assert printed.splitlines()[0] == outputs("A new flow end to end")[0].strip()
    out = workdir / "outputs" / "recipes"
    rows = json.loads((out / "cells_baselines" / "comparison.json").read_text())["rows"]
    assert [row["label"] for row in rows] == ["sto", "naive(+0.98)", "naive(+0.00)",
                                             "naive(-0.98)"]
    metrics = json.loads((out / "cells_seed0" / "metrics.json").read_text())
    assert metrics["config"]["flow"] == {"name": "oscillating_cells", "amplitude": 1.0,
                                         "wavenumber": 1.0, "oscillation": 0.3,
                                         "frequency": 1.0}
    assert (out / "cells_seed0" / "comparison.md").is_file()
