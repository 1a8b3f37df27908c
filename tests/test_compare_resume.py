"""An interrupted comparison continues from ``comparison.partial.json`` (``compare.resume``)
and gives the uninterrupted comparison's record, simulating only the chunks not yet done."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

import swimrl.evaluation.rollout
from swimrl.config import compare_config
from swimrl.env import build_env
from swimrl.errors import BadFileError, ConfigError
from swimrl.evaluation.compare import compare
from swimrl.policies import pretrained
from swimrl.runs.layout import RunLayout
from swimrl.runs.policy_files import sha256_file

from .conftest import SMALL
from .test_bad_input import COMPARE, _run_cases

SIZE = ["eval.n_flows=3", "eval.flows_per_batch=1", "eval.n_swimmers=4"]


def _config(compose_cfg, *over):
    return compare_config(compose_cfg(SMALL + SIZE + ["compare.strategies=[sto,naive]", *over],
                                      name="compare"))


def _count_builds(monkeypatch) -> list:
    calls = []
    build = build_env

    def counted(*args, **kwargs):
        calls.append(args[-1])  # the chunk seed
        return build(*args, **kwargs)

    monkeypatch.setattr(swimrl.evaluation.rollout, "build_env", counted)
    return calls


@pytest.mark.parametrize("shared", [False, True])
def test_resumed_comparison_is_the_uninterrupted_one(compose_cfg, tmp_path, monkeypatch, shared):
    over = [f"compare.shared_flows={str(shared).lower()}"]
    partial = RunLayout(tmp_path).comparison_partial
    full = compare(_config(compose_cfg, *over), partial)
    # interrupted after the first chunk of each group (3 chunks of 1 flow per group)
    state = json.loads(partial.read_text())
    assert [len(d) for d in state["done"]] == ([3] if shared else [3, 3])
    state["done"] = [d[:1] for d in state["done"]]
    partial.write_text(json.dumps(state))
    calls = _count_builds(monkeypatch)
    resumed = compare(_config(compose_cfg, *over, "compare.resume=true"), partial)
    assert len(calls) == (2 if shared else 4)  # only the two chunks left, per group
    for a, b in zip(full["rows"], resumed["rows"], strict=True):
        assert a["label"] == b["label"] and a["per_flow"] == b["per_flow"]
        assert (a["R_hat_mean"], a["ratio_to_first"]) == (b["R_hat_mean"], b["ratio_to_first"])
    assert full["flow_stats"] == resumed["flow_stats"]


def test_resume_of_another_comparison_is_refused(compose_cfg, tmp_path):
    partial = RunLayout(tmp_path).comparison_partial
    compare(_config(compose_cfg), partial)
    with pytest.raises(ConfigError, match=r"seed: saved 0, now 5"):
        compare(_config(compose_cfg, "seed=5", "compare.resume=true"), partial)
    with pytest.raises(ConfigError, match=r"compare.strategies"):
        compare(_config(compose_cfg, "compare.strategies=[sto]", "compare.resume=true"), partial)
    # a different thread count or progress bar is the same comparison
    again = compare(_config(compose_cfg, "threads=2", "eval.progress=true",
                            "compare.resume=true"), partial)
    assert len(again["rows"][0]["per_flow"]) == 3


def test_malformed_partial_is_refused(compose_cfg, tmp_path):
    partial = RunLayout(tmp_path).comparison_partial
    compare(_config(compose_cfg), partial)
    state = json.loads(partial.read_text())
    state["done"][0][1]["per_flow"][0] = []
    partial.write_text(json.dumps(state))
    with pytest.raises(BadFileError, match=r"chunk 1 is not 1 flows for each of 1 strategies"):
        compare(_config(compose_cfg, "compare.resume=true"), partial)
    partial.write_text("{not json")
    with pytest.raises(BadFileError, match=r"not readable JSON"):
        compare(_config(compose_cfg, "compare.resume=true"), partial)


@pytest.mark.slow  # four swimrl-compare processes (resume in-process: tests above) (~20 s)
def test_cli_resume(compose_cfg, tmp_path):
    """The command: a run directory holding a partial comparison is refused in one line without
    compare.resume (or overwrite) and left as it was; with it the comparison completes as the
    uninterrupted one, the partial file is gone, and relaunching a finished comparison with
    compare.resume=true changes nothing."""
    over = [*SMALL, *SIZE, "compare.strategies=[sto,naive]"]
    whole, part = tmp_path / "whole", tmp_path / "part"
    part.mkdir()
    compare(compare_config(compose_cfg(over, name="compare")), RunLayout(part).comparison_partial)
    (part / "comparison.json").unlink(missing_ok=True)
    state = json.loads(RunLayout(part).comparison_partial.read_text())
    state["done"] = [d[:1] for d in state["done"]]
    RunLayout(part).comparison_partial.write_text(json.dumps(state))
    kept = RunLayout(part).comparison_partial.read_text()
    bad, bad_value = _run_cases([
        [COMPARE, [*over, f"hydra.run.dir={part}"]],
        [COMPARE, [*over, "compare.resume=maybe", f"hydra.run.dir={part}"]],
    ], tmp_path)
    assert bad["rc"] == 2 and "compare.resume=true" in bad["stderr"].strip().splitlines()[-1]
    assert bad_value["rc"] == 2 and "compare.resume" in bad_value["stderr"].splitlines()[-1]
    assert sorted(p for p in part.iterdir()) == [RunLayout(part).comparison_partial]
    assert RunLayout(part).comparison_partial.read_text() == kept
    ok, finished = _run_cases([
        [COMPARE, [*over, "compare.resume=true", f"hydra.run.dir={part}"]],
        [COMPARE, [*over, f"hydra.run.dir={whole}"]],
    ], tmp_path)
    assert ok["rc"] == 0 and finished["rc"] == 0, ok["stderr"][-2000:] + finished["stderr"][-2000:]
    assert not RunLayout(part).comparison_partial.exists()
    resumed = json.loads((part / "comparison.json").read_text())
    uninterrupted = json.loads((whole / "comparison.json").read_text())
    for a, b in zip(resumed["rows"], uninterrupted["rows"], strict=True):
        assert a["per_flow"] == b["per_flow"]
    before = (part / "comparison.json").stat().st_mtime_ns
    (again,) = _run_cases([[COMPARE, [*over, "compare.resume=true", f"hydra.run.dir={part}"]]],
                          tmp_path)
    assert again["rc"] == 0 and (part / "comparison.json").stat().st_mtime_ns == before


def test_resume_with_a_replaced_policy_file_is_refused(compose_cfg, tmp_path):
    """Same path, other parameters: the policies' digests tell the comparisons apart."""
    root = Path(pretrained.__path__[0])
    policy = tmp_path / "policy.pt"
    policy.write_bytes((root / "ku10" / "policy.pt").read_bytes())
    over = ["compare.strategies=[sto,policy]", f"compare.policies=[{policy}]"]
    partial = RunLayout(tmp_path).comparison_partial
    record = compare(_config(compose_cfg, *over), partial)
    # each policy row names the exact file it evaluated; baselines name none
    assert "policy_sha256" not in record["rows"][0]
    assert record["rows"][1]["policy"] == str(policy)
    assert record["rows"][1]["policy_sha256"] == sha256_file(policy)
    assert sha256_file(policy) == hashlib.sha256(policy.read_bytes()).hexdigest()
    policy.write_bytes((root / "ku1" / "policy.pt").read_bytes())
    with pytest.raises(ConfigError, match=r"digests"):
        compare(_config(compose_cfg, *over, "compare.resume=true"), partial)
