"""DNS checkpoints are atomic: a kill at any step of a checkpoint write resumes to the same
bits as an uninterrupted run, or is refused with a clear message; never a restart from rest."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import zarr
from hydra import compose, initialize_config_module

from swimrl.config import dns_run
from swimrl.flows.dns.run import run_dns
from swimrl.flows.dns.sources import DNSStore
from swimrl.flows.dns.store import DNSStoreWriter

torch.set_num_threads(1)

SMALL = [
    "dns.n=32", "dns.nu=5e-3", "dns.dt=4e-3", "spinup.time=0.2", "spinup.measure_time=0.1",
    "store.n_times=6", "store.diag_every=5", "progress=false", "threads=1",
]
#: the steps of one checkpoint write, in order (DNSStoreWriter.save_checkpoint)
STEPS = ("omega_hat", "rng", "commit", "drop")


class Killed(BaseException):
    """Stands for SIGKILL: nothing after it runs (not even ``except Exception``)."""


def _run(path, *extra):
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose(config_name="dns", overrides=[*SMALL, f"store.path={path}", *extra])
    return run_dns(dns_run(cfg))


def _kill_at(monkeypatch, step: str, call: int) -> None:
    """Make the ``call``-th execution of checkpoint step ``step`` die before it acts."""
    count = {"n": 0}

    def dying(original):
        def wrapper(*args, **kwargs):
            count["n"] += 1
            if count["n"] == call:
                raise Killed(step)
            return original(*args, **kwargs)

        return wrapper

    if step in ("omega_hat", "rng"):
        original = DNSStoreWriter._write_array

        def write(group, name, data):
            if name.startswith(step + "_"):
                return dying(original)(group, name, data)
            return original(group, name, data)

        monkeypatch.setattr(DNSStoreWriter, "_write_array", staticmethod(write))
    elif step == "commit":
        original = DNSStoreWriter.commit

        def commit(self, **attrs):
            if "checkpoint_version" in attrs:
                return dying(original)(self, **attrs)
            return original(self, **attrs)

        monkeypatch.setattr(DNSStoreWriter, "commit", commit)
    else:
        monkeypatch.setattr(DNSStoreWriter, "_drop_checkpoints_except",
                            dying(DNSStoreWriter._drop_checkpoints_except))


@pytest.mark.parametrize("step", STEPS)
def test_kill_during_checkpoint_resumes_bit_identical(tmp_path, monkeypatch, step):
    ref = DNSStore(_run(tmp_path / "ref.zarr"))
    path = tmp_path / "killed.zarr"
    # a checkpoint after every step (checkpoint_seconds tiny): the kill hits the 55th, in the
    # storing phase (50 spin-up steps), after snapshots were appended and committed
    with monkeypatch.context() as m:
        _kill_at(m, step, call=55)
        with pytest.raises(Killed):
            _run(path, "store.checkpoint_seconds=1e-9")
    assert DNSStore(path).attrs["status"] == "storing"
    _run(path)
    res = DNSStore(path)
    assert res.complete and res.n_times == ref.n_times
    assert np.array_equal(res.times, ref.times)
    assert torch.equal(res.omega_hat(0, 6), ref.omega_hat(0, 6))
    # one checkpoint version left, the committed one
    ck = zarr.open_group(str(path), mode="r")["checkpoint"]
    v = res.attrs["checkpoint_version"]
    assert sorted(ck.array_keys()) == [f"omega_hat_{v}", f"rng_{v}"]


def test_lost_checkpoint_is_refused_not_restarted_from_rest(tmp_path):
    path = tmp_path / "run.zarr"
    _run(path, "max_steps=30")
    g = zarr.open_group(str(path), mode="r+", use_consolidated=False)
    v = g.attrs["checkpoint_version"]
    g["checkpoint"][f"omega_hat_{v}"][...] = 0  # the damage of the issue: a zeroed state
    with pytest.raises(FileExistsError, match="all zeros.*store.overwrite=true"):
        _run(path)
    del g["checkpoint"][f"omega_hat_{v}"]
    with pytest.raises(FileExistsError, match="cannot be read.*store.overwrite=true"):
        _run(path)
    assert DNSStore(path).attrs["status"] == "spinup"


def test_failed_run_without_checkpoint_does_not_block_a_corrected_rerun(tmp_path):
    """A store left by a run that died before its first checkpoint is replaced by a rerun
    with other parameters; one with a checkpoint names store.overwrite=true."""
    path = tmp_path / "run.zarr"
    with pytest.MonkeyPatch.context() as m:
        _kill_at(m, "omega_hat", call=1)
        with pytest.raises(Killed):
            _run(path, "dns.nu=6e-3")
    _run(path, "max_steps=30")  # other nu: replaced, not refused
    assert DNSStore(path).attrs["nu"] == 5e-3
    with pytest.raises(FileExistsError, match="store.overwrite=true"):
        _run(path, "dns.nu=6e-3")
