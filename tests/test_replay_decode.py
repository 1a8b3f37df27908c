"""Decoding stored DNS snapshots: on the run's grid, on a coarser grid (exact for the retained
modes while n_d > 2K, a spectral truncation below), and the bilinear sampling error of each."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from swimrl.flows.dns.grid import SpectralGrid, dealias_cutoff
from swimrl.flows.dns.sources import DNSStore, StoreSet
from swimrl.flows.dns.state import channels_hat, flow_channels, random_state
from swimrl.flows.dns.store import DNSStoreWriter
from swimrl.flows.replay import ReplayFlow

N = 64  # stored grid: K = 21 retained modes per axis


def write_store(path, seeds=(3,), n=N, n_times=4, dt_store=0.05, energy=1.0):
    """A finished store of random band-limited snapshots (one random field per snapshot)."""
    grid = SpectralGrid(n, dtype=torch.float64)
    w = DNSStoreWriter.create(path, {"n": n, "length": 2 * math.pi, "dt_store": dt_store,
                                     "u_rms": 1.0, "tau_k": 0.5})
    for j in range(n_times):
        state = random_state(grid, [seeds[0] * 1000 + j], energy=energy, k_peak=8.0)
        w.append_snapshot(state.omega_hat[0], j * dt_store)
    w.commit(status="complete")
    return path


def exact_channels(store: DNSStore, j: int, pts: np.ndarray, cutoff: int) -> np.ndarray:
    """``(u_x, u_y, S_xx, S_xy, omega)`` at ``pts`` ``(P, 2)`` by direct summation of the
    Fourier series of the stored coefficients with ``|m_x|, |m_y| <= cutoff`` (float64)."""
    k_all = dealias_cutoff(store.store_n)
    c = np.asarray(store.group["omega_hat"][j]).astype(np.complex128)  # (2K+1, K+1)
    my = np.arange(-k_all, k_all + 1)[:, None] * np.ones((1, k_all + 1))
    mx = np.ones((2 * k_all + 1, 1)) * np.arange(k_all + 1)[None, :]
    keep = (np.abs(my) <= cutoff) & (mx <= cutoff)
    k2 = mx**2 + my**2
    psi = np.where(k2 > 0, c / np.where(k2 > 0, k2, 1), 0)
    hats = [1j * my * psi, -1j * mx * psi, -(mx * my) * psi, 0.5 * (mx**2 - my**2) * psi, c]
    weight = np.where(mx == 0, 1.0, 2.0) * keep
    phase = np.exp(1j * (pts[:, 0, None, None] * mx + pts[:, 1, None, None] * my))
    return np.stack([(weight * (h * phase)).real.sum((1, 2)) for h in hats], -1)


@pytest.fixture(scope="module")
def store_path(tmp_path_factory):
    return write_store(tmp_path_factory.mktemp("decode") / "run.zarr")


def test_decode_on_the_runs_grid_is_the_default(store_path):
    full, same = DNSStore(store_path), DNSStore(store_path, decode_n=N)
    assert full.n == N and full.cutoff == dealias_cutoff(N)
    assert torch.equal(full.channels(0, 2), same.channels(0, 2))
    # the pruned transform gives the full irfft2's numbers
    unpruned = flow_channels(full.omega_hat(0, 2), SpectralGrid(N))
    assert torch.allclose(full.channels(0, 2), unpruned, rtol=0, atol=1e-6 * unpruned.abs().max())


@pytest.mark.parametrize("n_d", [N, 48, 32])
def test_decoded_nodes_are_the_fourier_series_of_the_decoded_modes(store_path, n_d):
    """n_d > 2K (64, 48): every stored mode is kept, the nodes sample the stored field
    exactly; n_d = 32 < 2K: the field truncated to |m| <= n_d/2 - 1."""
    store = DNSStore(store_path, decode_n=n_d)
    assert store.cutoff == min(dealias_cutoff(N), n_d // 2 - 1)
    q = store.channels(1, 2)[0].double().numpy()  # (n_d, n_d, 5), [iy, ix]
    x = np.arange(n_d) * 2 * math.pi / n_d
    yy, xx = np.meshgrid(x, x, indexing="ij")
    pts = np.stack([xx.ravel(), yy.ravel()], -1)
    want = exact_channels(store, 1, pts, store.cutoff).reshape(n_d, n_d, 5)
    scale = np.abs(want).max(axis=(0, 1))
    assert np.all(np.abs(q - want).max(axis=(0, 1)) <= 2e-6 * scale)
    if n_d == 32:  # the truncation is visible: the dropped modes carry part of the strain
        full = exact_channels(store, 1, pts, dealias_cutoff(N)).reshape(n_d, n_d, 5)
        assert np.abs(full - want)[..., 2:].max() > 1e-3 * scale[2:].max()


def test_bilinear_sampling_error_obeys_its_bound_and_scales_as_h2(store_path):
    """|I_h[f] - f| <= h^2/8 (max|f_xx| + max|f_yy|) per channel, and the rms error grows
    as h^2 from n_d = 64 to 48 (same modes, coarser nodes)."""
    rng = np.random.default_rng(0)
    pts = rng.uniform(0, 2 * math.pi, (400, 2))
    errs = {}
    for n_d in (N, 48):
        store = DNSStore(store_path, decode_n=n_d)
        flow = ReplayFlow(store, 1, interval=0.05, episode_time=0.1, dtype=torch.float64)
        flow.reset()
        assert int(flow.start[0]) in (0, 1)
        j = int(flow.start[0])
        got = flow.sample(torch.zeros(400, dtype=torch.int64),
                          torch.from_numpy(pts)).numpy()
        want = exact_channels(store, j, pts, store.cutoff)
        err = np.abs(got - want)
        # the bound, with max|f_xx|, max|f_yy| from the series on a 4x finer grid
        fine = SpectralGrid(4 * N, dtype=torch.float64)
        w_hat = DNSStore(store_path).omega_hat(j, j + 1, torch.complex128)
        big = torch.zeros((1, 4 * N, 2 * N + 1), dtype=torch.complex128)
        k = dealias_cutoff(N)
        src = torch.remainder(torch.arange(-k, k + 1), N)
        dst = torch.remainder(torch.arange(-k, k + 1), 4 * N)
        big[:, dst, : k + 1] = w_hat[:, src, : k + 1] * 16
        ch = channels_hat(fine, big)
        fxx = fine.to_physical(-(fine.kx**2) * ch).abs().amax((-2, -1))[0].numpy()
        fyy = fine.to_physical(-(fine.ky**2) * ch).abs().amax((-2, -1))[0].numpy()
        h = 2 * math.pi / n_d
        assert np.all(err.max(0) <= h**2 / 8 * (fxx + fyy) * 1.01)
        errs[n_d] = np.sqrt((err**2).mean(0))
    ratio = errs[48] / errs[N]
    assert np.all((ratio > 1.2) & (ratio < 2.5)), ratio  # (64/48)^2 = 1.78


def test_a_store_set_replays_each_run(tmp_path):
    a = write_store(tmp_path / "a.zarr", seeds=(1,), n_times=6)
    b = write_store(tmp_path / "b.zarr", seeds=(2,), n_times=5)
    runs = StoreSet([DNSStore(a), DNSStore(b)])
    assert runs.n_runs == 2 and runs.n_times == 5
    assert torch.equal(runs.channels(3, 4, 1), DNSStore(b).channels(3, 4))
    other = write_store(tmp_path / "c.zarr", n=32)
    with pytest.raises(ValueError, match="share the grid"):
        StoreSet([DNSStore(a), DNSStore(other)])
