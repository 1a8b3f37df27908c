"""zarr store of DNS runs: round trip, metadata, xarray, no silent overwrite, resume."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
import xarray as xr
import zarr
from hydra import compose, initialize_config_module

from swimrl.config import dns_run
from swimrl.flows.dns import DNSParams, SpectralGrid, flow_channels
from swimrl.flows.dns.run import run_dns as _run_dns
from swimrl.flows.dns.sources import DNSStore
from swimrl.flows.dns.store import DNSStoreWriter

torch.set_num_threads(1)

SMALL = [
    "dns.n=32", "dns.nu=5e-3", "dns.dt=4e-3", "spinup.time=0.2", "spinup.measure_time=0.1",
    "store.n_times=6", "store.diag_every=5", "progress=false", "threads=1",
]


def _cfg(path: Path, *extra: str):
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        return compose(config_name="dns", overrides=[*SMALL, f"store.path={path}", *extra])


def run_dns(cfg) -> Path:
    """``swimrl-dns`` on a composed config."""
    return _run_dns(dns_run(cfg))


def test_default_config_is_the_documented_production_run():
    with initialize_config_module("swimrl.conf", version_base="1.3"):
        cfg = compose(config_name="dns")
        flow = compose(config_name="evaluate", overrides=["flow=dns"]).flow
    assert cfg.dns.n == 512 and cfg.dns.k_f == 3.0 and cfg.store.interval_tau_k == 0.1
    assert str(cfg.store.path).startswith("data/")
    # one solver group: swimrl-dns, flow=dns and the DNSParams defaults agree
    assert flow.dns == cfg.dns and flow.spinup == cfg.spinup
    assert dns_run(cfg).params == DNSParams()


def test_store_round_trip_and_metadata(tmp_path):
    path = run_dns(_cfg(tmp_path / "run.zarr"))
    s = DNSStore(path)
    assert s.complete and s.n_times == 6 and len(s) == 6 and s.n == 32
    assert s.length == pytest.approx(2 * math.pi)
    a = s.attrs
    assert s.dt_store == pytest.approx(a["store_every"] * a["dt"])
    # dt_store ~ 0.1 tau_K measured at the end of the spin-up, in whole steps
    assert abs(s.dt_store - 0.1 * a["tau_k_spinup"]) <= 0.5 * a["dt"] + 1e-12
    assert s.u_rms > 0 and s.tau_k > 0 and math.isfinite(s.u_rms) and math.isfinite(s.tau_k)
    for key in ("nu", "alpha", "hypo_power", "epsilon", "k_f", "forcing_width", "n", "dt",
                "dt_store", "u_rms", "tau_k", "length", "channel_names", "channel_units", "units",
                "seed"):
        assert key in a, key
    assert tuple(a["channel_names"]) == ("u_x", "u_y", "S_xx", "S_xy", "omega")
    np.testing.assert_allclose(np.diff(s.times), s.dt_store, rtol=1e-9)
    q = s.channels(2, 6)
    assert q.shape == (4, 32, 32, 5) and q.dtype == torch.float32
    # the last snapshot equals the solver state checkpointed at the end (float32 rounding)
    w, _ = DNSStoreWriter(path).load_checkpoint()
    ref = flow_channels(w[None], SpectralGrid(32, dtype=torch.float64))[0]
    assert torch.allclose(q[-1].double(), ref, rtol=0, atol=2e-6 * float(ref.abs().max()))
    # u_rms / tau_K attributes are the averages over the stored snapshots
    qa = s.channels(0, 6).double()
    u2 = (qa[..., 0] ** 2 + qa[..., 1] ** 2).mean()
    a2 = (2 * qa[..., 2] ** 2 + 2 * qa[..., 3] ** 2 + 0.5 * qa[..., 4] ** 2).mean()
    assert s.u_rms == pytest.approx(float(u2.sqrt()), rel=1e-5)
    assert s.tau_k == pytest.approx(float(a2**-0.5), rel=1e-5)
    # xarray reads the store with named dimensions and coordinates
    ds = xr.open_zarr(path)
    assert ds["omega_hat"].dims == ("time", "ky", "kx") and ds.sizes["time"] == 6
    assert ds["ky"].values.tolist() == list(range(-10, 11))
    assert ds.attrs["n"] == 32
    diag = xr.open_zarr(path, group="diagnostics")
    assert "energy" in diag and diag.sizes["t"] >= 1
    with pytest.raises(IndexError):
        s.channels(5, 7)


def test_finished_store_is_not_overwritten_silently(tmp_path):
    path = tmp_path / "run.zarr"
    run_dns(_cfg(path))
    before = np.asarray(zarr.open_group(str(path), mode="r")["omega_hat"][...])
    with pytest.raises(FileExistsError, match="finished DNS store; set store.overwrite=true"):
        run_dns(_cfg(path, "seed=1"))
    after = np.asarray(zarr.open_group(str(path), mode="r")["omega_hat"][...])
    assert np.array_equal(before, after)
    run_dns(_cfg(path, "seed=1", "store.overwrite=true"))
    assert DNSStore(path).attrs["seed"] == 1
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "keep.txt").write_text("precious")
    for extra in ([], ["store.overwrite=true"]):
        with pytest.raises(FileExistsError, match="not a swimrl DNS store; it is never deleted"):
            run_dns(_cfg(foreign, *extra))
    assert (foreign / "keep.txt").read_text() == "precious"


def test_interrupted_run_resumes_to_identical_store(tmp_path):
    """Chunks of max_steps (interrupting both spin-up and storing) give the same bits."""
    ref = DNSStore(run_dns(_cfg(tmp_path / "ref.zarr")))
    path = tmp_path / "resumed.zarr"
    statuses = []
    for _ in range(20):
        run_dns(_cfg(path, "max_steps=17"))
        statuses.append(DNSStore(path).attrs["status"])
        if statuses[-1] == "complete":
            break
    assert "spinup" in statuses and "storing" in statuses and statuses[-1] == "complete"
    res = DNSStore(path)
    assert res.n_times == ref.n_times
    assert np.array_equal(res.times, ref.times)
    assert torch.equal(res.omega_hat(0, 6), ref.omega_hat(0, 6))
    assert res.u_rms == ref.u_rms and res.tau_k == ref.tau_k


def test_resume_refuses_changed_parameters(tmp_path):
    path = tmp_path / "run.zarr"
    run_dns(_cfg(path, "max_steps=10"))
    with pytest.raises(FileExistsError,
                       match=r"cannot resume .*: nu=0.005 in the store but 0.006.*store.overwrite"):
        run_dns(_cfg(path, "dns.nu=6e-3"))


def test_console_entry_point_runs(tmp_path):
    """``python -m swimrl.flows.dns.cli`` (== ``swimrl-dns``) with Hydra overrides."""
    path = tmp_path / "cli.zarr"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    out = subprocess.run(
        [sys.executable, "-m", "swimrl.cli.dns", *SMALL, f"store.path={path}",
         f"hydra.run.dir={tmp_path / 'hydra'}"],
        capture_output=True, text=True, env=env, timeout=120, check=False,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert "status: complete" in out.stdout
    assert DNSStore(path).n_times == 6


def test_plots_from_a_small_store(tmp_path):
    from swimrl.analysis.dns_plots import make_plots

    path = run_dns(_cfg(tmp_path / "run.zarr"))
    summary = make_plots(path, tmp_path / "img", n_snapshots=3, fit=(3.0, 8.0))
    for name in ("spectrum", "pdfs", "timeseries", "vorticity"):
        assert (tmp_path / "img" / f"dns_{name}.png").stat().st_size > 1000
    assert summary["n_times"] == 6 and math.isfinite(summary["spectrum_slope"])
    assert set(summary["moments"]) == {"omega", "S_xx", "S_xy"}


@pytest.mark.slow  # two DNS runs, then swimrl-dns-plots over them (~10-15 s)
def test_checks_across_independent_runs(tmp_path):
    """swimrl-dns-plots A B: per-run summaries, stability of u_rms and tau_K through each
    stored window, pooled PDFs and the resolution check over every run."""
    from swimrl.analysis.dns_plots import stored_window_series
    from swimrl.cli.dns_plots import main
    from swimrl.cli.dns_plots import run as run_plots

    paths = [run_dns(_cfg(tmp_path / f"s{seed}.zarr", f"seed={seed}")) for seed in (1, 2)]
    checks = run_plots([str(p) for p in paths] + ["--out", str(tmp_path / "checks"),
                                             "--snapshots", "3", "--fit", "3", "8"])
    for name in ("dns_stability.png", "dns_pdfs_all.png", "dns_checks.json"):
        assert (tmp_path / "checks" / name).stat().st_size > 100
    assert [r["seed"] for r in checks["runs"]] == [1, 2]
    assert checks["all_resolved"] == all(r["kmax_l_nu"] >= 1 for r in checks["runs"])
    for path, run in zip(paths, checks["runs"], strict=True):
        assert (Path(str(path.with_suffix("")) + "_plots") / "dns_spectrum.png").exists()
        store = DNSStore(path)
        series = stored_window_series(path, store)
        assert series["t"][0] == 0 and series["t"][-1] > 0  # the stored window only
        # the stored u_rms and tau_K are averages over the stored snapshots: the window's
        # diagnostics average to them within the sampling of a short window
        assert np.mean(series["u_rms"]) == pytest.approx(store.u_rms, rel=0.1)
        assert np.mean(series["tau_k"]) == pytest.approx(store.tau_k, rel=0.1)
        assert run["u_rms_t"]["rel_std"] >= 0 and math.isfinite(run["tau_k_t"]["drift"])
    assert set(checks["pooled_moments"]) == {"omega", "S_xx", "S_xy"}
    for curve in checks["pooled_pdfs"].values():  # the drawn PDFs, for Fig. dnsFlow(b)
        z, pdf = np.asarray(curve["z"]), np.asarray(curve["pdf"])
        assert (pdf * (z[1] - z[0])).sum() == pytest.approx(1.0, abs=0.01)
    # runs are added one at a time from their records: the same checks without the stores
    again = run_plots([str(paths[0]), "--checks", "--out", str(tmp_path / "one"),
                       "--snapshots", "3", "--fit", "3", "8"])
    assert [r["seed"] for r in again["runs"]] == [1]
    (tmp_path / "one" / "runs" / f"{paths[1].stem}.json").write_text(
        (tmp_path / "checks" / "runs" / f"{paths[1].stem}.json").read_text())
    paths[1].rename(tmp_path / "gone.zarr")
    both = run_plots([str(paths[0]), "--checks", "--out", str(tmp_path / "one"),
                      "--snapshots", "3", "--fit", "3", "8"])
    assert both["runs"] == checks["runs"] and both["pooled_pdfs"] == checks["pooled_pdfs"]
    # the console entry (setuptools calls sys.exit(main())) exits 0 on success, not with the
    # summary as its status
    assert main([str(paths[0]), "--checks", "--out", str(tmp_path / "one"), "--snapshots", "3",
                 "--fit", "3", "8"]) == 0


def test_finished_store_extends_to_the_longer_run(tmp_path):
    """store.extend=true appends to a finished store exactly what a longer run stores."""
    ref = DNSStore(run_dns(_cfg(tmp_path / "ref.zarr", "store.n_times=9")))
    path = tmp_path / "ext.zarr"
    run_dns(_cfg(path))
    for n_times, msg in (("6", r"store.n_times=6 is invalid: allowed > 6"), ("4", r"=4 is")):
        with pytest.raises(ValueError, match=msg):
            run_dns(_cfg(path, f"store.n_times={n_times}", "store.extend=true"))
    with pytest.raises(FileExistsError, match="store.extend=true"):
        run_dns(_cfg(path, "store.n_times=9"))
    run_dns(_cfg(path, "store.n_times=9", "store.extend=true"))
    ext = DNSStore(path)
    assert ext.complete and ext.n_times == ref.n_times == 9
    assert np.array_equal(ext.times, ref.times)
    assert torch.equal(ext.omega_hat(0, 9), ref.omega_hat(0, 9))
    assert math.isclose(ext.u_rms, ref.u_rms, rel_tol=1e-12)
    assert math.isclose(ext.tau_k, ref.tau_k, rel_tol=1e-12)
