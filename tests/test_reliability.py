"""Issue 31's probe cases, given to the real commands: uncreatable run directories, memory
that the machine does not have, policy files with non-finite weights. Each gives one line
naming the key (or file), exit status 2, no traceback and nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from swimrl.errors import BadFileError
from swimrl.runs.policy_files import load_file, resolve_policy_file

from .conftest import SMALL
from .test_bad_input import COMPARE, EVAL, TRAIN, _run_cases
from .test_train import TINY

#: far beyond any machine: 1e7 flows of 64^2 nodes x 5 modes x 5 channels (4 TB)
HUGE_EVAL = ["eval.n_flows=10000000", "eval.flows_per_batch=10000000"]


def _nan_policy(tmp: Path) -> Path:
    data = torch.load(resolve_policy_file("pretrained/ku10"), weights_only=True)
    name = next(iter(data["actor"]))
    data["actor"][name] = torch.full_like(data["actor"][name], float("nan"))
    (tmp / "nanpolicy").mkdir()
    torch.save(data, tmp / "nanpolicy" / "policy.pt")
    return tmp / "nanpolicy"


def test_policy_with_nonfinite_weights_is_refused_at_load(tmp_path):
    path = _nan_policy(tmp_path) / "policy.pt"
    with pytest.raises(BadFileError, match="non-finite weights") as err:
        load_file(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_probe_cases_are_one_line_exit_2_and_leave_nothing(tmp_path):
    _nan_policy(tmp_path)
    (tmp_path / "file").write_text("a file, not a directory\n")
    run = str(tmp_path / "run")
    cases = [
        (EVAL, [*SMALL, "hydra.run.dir=/proc/nope"], "hydra.run.dir='/proc/nope'"),
        (EVAL, [*SMALL, f"hydra.run.dir={tmp_path}/file/run"], "hydra.run.dir="),
        (TRAIN, [*TINY, f"hydra.run.dir={tmp_path}/file/run"], "hydra.run.dir="),
        (COMPARE, [*SMALL, f"hydra.run.dir={tmp_path}/file/run"], "hydra.run.dir="),
        (EVAL, [*SMALL, *HUGE_EVAL, f"hydra.run.dir={run}0"], "eval.flows_per_batch"),
        (COMPARE, [*SMALL, *HUGE_EVAL, f"hydra.run.dir={run}1"], "eval.flows_per_batch"),
        (TRAIN, [*TINY, "train.n_flows=100000000", "train.rollout_length=40",
                 "train.total_frames=4000000000", f"hydra.run.dir={run}2"], "train.n_flows"),
        (EVAL, [*SMALL, "strategy=policy", f"policy={tmp_path}/nanpolicy",
                f"hydra.run.dir={run}3"], f"{tmp_path}/nanpolicy"),
    ]
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    results = _run_cases([[m, a] for m, a, _ in cases], tmp_path)
    failures = []
    for (module, args, key), res in zip(cases, results, strict=True):
        lines = res["stderr"].strip().splitlines()
        last = lines[-1] if lines else ""
        if res["rc"] != 2 or key not in last or "Traceback" in res["stderr"]:
            failures.append(f"{module} {args[-2:]}: rc={res['rc']} stderr={res['stderr'][-600:]!r}")
    assert not failures, "\n".join(failures)
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before
