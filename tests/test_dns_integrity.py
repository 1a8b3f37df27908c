"""Integrity of stored DNS runs: checksummed chunks, checked snapshots, ``swimrl-dns-verify``.

A damaged chunk or an impossible snapshot is one ``IntegrityError`` line naming the store,
the array and the time index, whatever reads it (the reader, the replay, the provenance
record, the resume), and ``swimrl-eval`` stops on it with exit status 1 and no result; a
store written before the checksums still reads, with one warning line.
"""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
import zarr
from hydra import compose, initialize_config_module
from zarr.codecs import ZstdCodec

from swimrl.cli.dns_verify import main as verify_main
from swimrl.config import dns_run
from swimrl.errors import IntegrityError
from swimrl.flows.dns import store as store_module
from swimrl.flows.dns.integrity import RMS_FACTOR, SnapshotCheck
from swimrl.flows.dns.run import run_dns
from swimrl.flows.dns.sources import DNSStore
from swimrl.flows.dns.store import DNSStoreWriter, store_record
from swimrl.flows.dns.verify import verify_store

from .conftest import SMALL as EVAL_SMALL

torch.set_num_threads(1)

#: a 32^2 run of 24 snapshots 0.12 tau_K apart (spin-up long enough for u_rms(t)/u_rms to stay
#: in 0.89-1.11): an episode of 2 tau_K reads snapshots j0..j0+17, j0 <= 6: every window holds BAD
DNS_SMALL = [
    "dns.n=32", "dns.nu=5e-3", "dns.dt=4e-3", "spinup.time=1.0", "spinup.measure_time=0.2",
    "store.diag_every=5", "store.n_times=24", "progress=false", "threads=1",
]
BAD = 10  # the snapshot whose chunk is damaged


def _run(path: Path, *extra: str) -> Path:
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose(config_name="dns", overrides=[*DNS_SMALL, f"store.path={path}", *extra])
    return run_dns(dns_run(cfg))


def _flip(chunk: Path, at: int | None = None) -> None:
    """Flip one byte of the chunk file ``chunk`` (in its middle by default)."""
    data = bytearray(chunk.read_bytes())
    data[len(data) // 2 if at is None else at] ^= 0x5A
    chunk.write_bytes(bytes(data))


def _attrs(path: Path, **changes) -> None:
    """Change root attributes (and the consolidated metadata the readers use)."""
    g = zarr.open_group(str(path), mode="r+", use_consolidated=False)
    g.attrs.update(changes)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "consolidated metadata is not in the v3 spec"
        zarr.consolidate_metadata(str(path))


@pytest.fixture(scope="module")
def clean(tmp_path_factory) -> Path:
    return _run(tmp_path_factory.mktemp("integrity") / "run.zarr")


@pytest.fixture
def store(clean, tmp_path) -> Path:
    """A fresh copy of the clean store, to damage."""
    return Path(shutil.copytree(clean, tmp_path / "run.zarr"))


def test_new_stores_checksum_every_array(clean):
    g = zarr.open_group(str(clean), mode="r")
    names = [k for k, a in g.members(max_depth=None) if isinstance(a, zarr.Array)]
    assert {"omega_hat", "time", "ky", "kx", "diagnostics/energy"} <= set(names)
    assert any(k.startswith("checkpoint/omega_hat_") for k in names)
    for name in names:
        assert [c.to_dict()["name"] for c in g[name].compressors][-1] == "crc32c", name
    assert DNSStore(clean).checksums and store_record(clean)["checksums"] is True
    report = verify_store(clean)
    assert report.clean and report.verdict == "clean", report.lines()
    assert {c.name: c.status for c in report.checks} == {
        "checksums": "ok", "time axis": "ok", "finite": "ok", "rms velocity": "ok",
        "energy vs diagnostics": "ok", "enstrophy vs diagnostics": "ok", "scales": "ok"}


def test_a_damaged_chunk_is_one_line_naming_store_array_and_index(store):
    _flip(store / "omega_hat" / "c" / str(BAD) / "0" / "0")
    s = DNSStore(store)
    assert s.channels(0, BAD).shape[0] == BAD  # the snapshots before it read as before
    for read in (lambda: s.channels(BAD - 2, BAD + 3), lambda: s.omega_hat(BAD, BAD + 1),
                 lambda: s.decoded_hat(0, s.n_times)):
        with pytest.raises(IntegrityError) as err:
            read()
        msg = str(err.value)
        assert "\n" not in msg and str(store) in msg and "omega_hat" in msg
        assert f"time index {BAD} " in msg and "crc32c checksum" in msg
        assert f"swimrl-dns-verify {store}" in msg
    # the provenance record (first and last snapshot) checks what it hashes
    _flip(store / "omega_hat" / "c" / "0" / "0" / "0")
    with pytest.raises(IntegrityError, match=r"omega_hat at time index 0 fails"):
        store_record(store)


def test_verify_reports_the_damaged_chunk(store, capsys):
    _flip(store / "omega_hat" / "c" / str(BAD) / "0" / "0")
    _flip(store / "diagnostics" / "energy" / "c" / "0")
    report = verify_store(store)
    checks = {c.name: c for c in report.checks}
    assert not report.clean and checks["checksums"].status == "FAIL"
    assert f"omega_hat at time index {BAD}" in checks["checksums"].detail
    assert "diagnostics/energy at index 0.." in checks["checksums"].detail
    # the other snapshots are still checked; the damaged one is counted, not used
    assert checks["finite"].status == "ok" and "1 unreadable" in checks["finite"].detail
    assert checks["rms velocity"].status == "ok"
    assert verify_main([str(store)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith(f"{store}: status complete, 24 snapshots")
    assert any(line.split()[:2] == ["FAIL", "checksums:"] for line in out)
    assert "verdict: 2 problems (checksums, energy vs diagnostics)" in out[-1]


def test_verify_command_on_a_clean_store_exits_0(clean, tmp_path, capsys):
    assert verify_main([str(clean), str(clean)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[-1] == "verdict: 2 of 2 stores clean"
    assert sum(line.strip().startswith("ok") for line in out) == 2 * 7
    with pytest.raises(SystemExit) as exit_:
        verify_main([str(tmp_path / "nowhere.zarr")])
    assert exit_.value.code == 2


def test_swimrl_eval_on_a_damaged_store_stops_with_one_error_line(store, tmp_path):
    """The probe of the issue: ``swimrl-eval flow=dns_replay ... strategy=sto`` on a store with
    a damaged chunk exits 1 with one ``error:`` line and writes no metrics.json."""
    _flip(store / "omega_hat" / "c" / str(BAD) / "0" / "0")
    run = tmp_path / "eval"
    small = [o for o in EVAL_SMALL if not o.startswith(("flow.", "episode.duration"))]
    cmd = [sys.executable, "-m", "swimrl.cli.eval", *small, "flow=dns_replay",
           f"flow.path={store}", "strategy=sto", "episode.duration=2", "eval.n_flows=1",
           "eval.flows_per_batch=1", "eval.n_swimmers=4", "kernel=eager", f"hydra.run.dir={run}"]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1]),
                              "OMP_NUM_THREADS": "1"})
    errors = [line for line in out.stderr.splitlines() if line.startswith("error:")]
    assert out.returncode == 1, out.stderr[-3000:]
    assert len(errors) == 1 and "Traceback" not in out.stderr, out.stderr[-3000:]
    assert str(store) in errors[0] and f"omega_hat at time index {BAD} " in errors[0]
    assert not (run / "metrics.json").exists()


def test_old_store_without_checksums_reads_the_same_with_one_warning(clean, tmp_path,
                                                                     monkeypatch, caplog):
    """A store written as before the checksums (omega_hat uncompressed, the other arrays with
    zarr's default zstd, no crc32c) reads bit for bit as the checksummed one, with one
    warning line naming the verify command; verify runs its other checks."""

    def old_codecs(compress: bool = True):
        return (ZstdCodec(level=0, checksum=False),) if compress else None

    monkeypatch.setattr(store_module, "compressors", old_codecs)
    old = _run(tmp_path / "old.zarr")
    monkeypatch.undo()
    assert zarr.open_group(str(old), mode="r")["omega_hat"].compressors == ()
    with caplog.at_level(logging.WARNING, logger="swimrl.flows.dns.sources"):
        s = DNSStore(old)
        again = DNSStore(old)
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warned) == 1 and "\n" not in warned[0], warned
    assert "unverified (no checksums" in warned[0] and f"swimrl-dns-verify {old}" in warned[0]
    new = DNSStore(clean)
    assert not s.checksums and again.n_times == new.n_times
    assert torch.equal(s.omega_hat(0, s.n_times), new.omega_hat(0, new.n_times))
    assert torch.equal(s.channels(0, 3), new.channels(0, 3))
    assert np.array_equal(s.times, new.times)
    assert store_record(old)["content_hash"] == store_record(clean)["content_hash"]
    assert store_record(old)["checksums"] is False
    report = verify_store(old)
    checks = {c.name: c for c in report.checks}
    assert checks["checksums"].status == "unverified"
    assert "unverified: no checksums" in checks["checksums"].detail
    assert all(c.status == "ok" for c in report.checks if c.name != "checksums")
    assert report.clean and report.verdict == "clean, unverified: no checksums"


@pytest.mark.parametrize("damage", ["nan", "u_rms_x10", "u_rms_div10", "lost_chunk"])
def test_impossible_snapshots_are_refused(store, damage):
    """A NaN snapshot (written with a valid checksum), a u_rms attribute off by 10x either
    way, and a lost chunk (read as zeros) are refused on reading and reported by verify."""
    u_rms = DNSStore(store).u_rms
    if damage == "nan":
        g = zarr.open_group(str(store), mode="r+", use_consolidated=False)
        g["omega_hat"][BAD, 3, 2] = np.nan
    elif damage == "lost_chunk":
        (store / "omega_hat" / "c" / str(BAD) / "0" / "0").unlink()
    else:
        _attrs(store, u_rms=u_rms * (10 if damage == "u_rms_x10" else 0.1))
    s = DNSStore(store)
    first = BAD if damage in ("nan", "lost_chunk") else 0
    with pytest.raises(IntegrityError) as err:
        s.channels(0, s.n_times)
    msg = str(err.value)
    assert "\n" not in msg and str(store) in msg and f"time index {first} " in msg
    if damage == "nan":
        assert "not finite" in msg
    else:
        lo, hi = s.u_rms / RMS_FACTOR, s.u_rms * RMS_FACTOR
        assert "rms velocity" in msg and f"[{lo:.4g}, {hi:.4g}]" in msg
    checks = {c.name: c.status for c in verify_store(store).checks}
    failed = {"nan": {"finite"}, "lost_chunk": {"rms velocity", "energy vs diagnostics",
                                                "enstrophy vs diagnostics", "scales"},
              "u_rms_x10": {"rms velocity", "scales"}, "u_rms_div10": {"rms velocity", "scales"}}
    assert {k for k, v in checks.items() if v == "FAIL"} >= failed[damage], checks


def test_snapshot_rms_is_the_velocity_of_the_decoded_field(clean):
    """The check's u_rms(t) (Parseval on the stored modes) equals <u.u>^{1/2} of the decoded
    nodes, and its mean over the snapshots is the store's u_rms attribute."""
    s = DNSStore(clean)
    q = s.channels(0, s.n_times).double()
    nodes = (q[..., 0] ** 2 + q[..., 1] ** 2).mean((1, 2)).sqrt()
    rms = s.check.rms(s._stored(0, s.n_times)).double()
    assert torch.allclose(rms, nodes, rtol=1e-5, atol=0)
    assert float((rms**2).mean().sqrt()) == pytest.approx(s.u_rms, rel=1e-5)
    check = SnapshotCheck(32, 2 * np.pi, 1.0, "x")
    assert check.bounds == (1 / RMS_FACTOR, RMS_FACTOR)
    assert check.problem(RMS_FACTOR * 1.01) and check.problem(float("nan"))
    assert check.problem(1.0) is None


def test_a_damaged_checkpoint_stops_the_resume(tmp_path):
    """Resuming a run whose checkpoint chunk is damaged: one IntegrityError line naming the
    checkpoint array, never a restart from a corrupt state."""
    path = _run(tmp_path / "run.zarr", "max_steps=30")
    v = DNSStoreWriter(path).checkpoint_version
    for chunk in (path / "checkpoint" / f"omega_hat_{v}" / "c").rglob("*"):
        if chunk.is_file():
            _flip(chunk)
    with pytest.raises(IntegrityError) as err:
        _run(path)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and f"checkpoint/omega_hat_{v}" in msg
    assert "crc32c checksum" in msg and "store.overwrite=true" in msg
