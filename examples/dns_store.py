# %% [markdown]
# # A stored DNS run, read with xarray
#
# `swimrl-dns` integrates the forced 2D Navier–Stokes equations (vorticity form, hypo-friction,
# white-in-time forcing at `k_f = 3`) and stores snapshots in a zarr store that the replay
# flow (`flow=dns_replay`) interpolates in time. The store is plain zarr v3 with named
# dimensions, so xarray reads it directly.
#
# The example first writes a small run (64² by default, 32² with `SWIMRL_EXAMPLE_SMALL=1`)
# into a temporary directory with the library's run function, so it needs no data; to read
# a run of your own instead, skip the run and set `STORE` to its path
# (`data/dns/dns_n512_seed1.zarr`: 3300 snapshots, read lazily).
# `SWIMRL_EXAMPLE_OUT=DIR` chooses where the figure goes (default `examples/out/`).

# %%
import os
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from hydra import compose, initialize_config_module

from swimrl.config import dns_run
from swimrl.flows.dns.run import run_dns, summary

SMALL = os.environ.get("SWIMRL_EXAMPLE_SMALL") == "1"
# figures: $SWIMRL_EXAMPLE_OUT, else examples/out/ (run from the repository root or examples/)
OUT = Path(os.environ.get("SWIMRL_EXAMPLE_OUT")
           or ("examples/out" if Path("examples").is_dir() else "out"))
OUT.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## A tiny run
#
# The run is `swimrl-dns`'s, its config composed with Hydra from the command line's
# overrides: the solver (`dns.*`; the production run is 512² with `ν = 10⁻⁴`, a coarse grid
# needs a larger viscosity), a spin-up from rest over whose end `u_rms` and `τ_K` are
# measured (`spinup.*`: 4 time units here, not quite steady; 12 in the production run),
# then `store.n_times` snapshots every `≈ 0.1 τ_K`. `dns_run` checks the values and returns
# the typed run (`DNSRun`, with its `DNSParams`); `run_dns` runs it.

# %%
n = 32 if SMALL else 64
TMP = Path(tempfile.mkdtemp(prefix="swimrl_dns_"))                # removed at the end
STORE = TMP / f"dns_n{n}.zarr"
overrides = [
    f"dns.n={n}", f"dns.nu={5e-3 if SMALL else 2e-3}", "dns.dt=4e-3",
    f"spinup.time={0.4 if SMALL else 4.0}", f"spinup.measure_time={0.2 if SMALL else 1.0}",
    f"store.path={STORE}", f"store.n_times={8 if SMALL else 40}", "store.diag_every=5",
    "progress=false", "threads=1",
]
with initialize_config_module("swimrl.conf", version_base="1.3"):
    run = dns_run(compose(config_name="dns", overrides=overrides))
print(run.params)
run_dns(run)
print(summary(STORE))

# %% [markdown]
# ## The store in xarray
#
# `omega_hat (time, ky, kx)` holds the Fourier coefficients `c_k` of the vorticity,
# `ω(x) = Σ c_k exp(i k·x)` (`c = rfft2(ω)/N²`), on the retained (de-aliased) modes only:
# `ky = −K..K`, `kx = 0..K`. The root attributes hold the parameters and the measured
# scales; the `diagnostics` group the time series of the whole run.

# %%
ds = xr.open_zarr(STORE)
diagnostics = xr.open_zarr(STORE, group="diagnostics")
print(ds)
n, length = int(ds.attrs["n"]), float(ds.attrs["length"])
print(f"u_rms = {ds.attrs['u_rms']:.3f}, tau_K = {ds.attrs['tau_k']:.3f}, "
      f"dt_store = {ds.attrs['dt_store']:.4f} (code units)")

# %% [markdown]
# ## Vorticity on the grid
#
# Put the stored coefficients back into an `rfft2` array of the run's grid and invert it.

# %%
last = ds["omega_hat"].isel(time=-1).values                     # (ky, kx)
coefficients = np.zeros((n, n // 2 + 1), dtype=complex)
coefficients[np.ix_(ds["ky"].values % n, ds["kx"].values)] = last
omega = np.fft.irfft2(coefficients, s=(n, n)) * n**2              # omega[iy, ix]

# %% [markdown]
# ## Energy spectrum
#
# `E(k)`: the energy `½|û_k|² = ½|c_k|²/|k|²` of the modes summed over shells
# `|k| ∈ [j − ½, j + ½)` (in box wavenumbers `2π/L`), averaged over the last (at most 50)
# snapshots; modes with `kx > 0` count twice (they stand for their complex conjugates).
# Over all the snapshots, the spectrum sums to the stored `u_rms²/2`.

# %%
k_unit = 2 * np.pi / length
k2 = (ds["kx"] ** 2 + ds["ky"] ** 2) * k_unit**2
weight = xr.where(ds["kx"] == 0, 1.0, 2.0)
snapshots = ds["omega_hat"].isel(time=slice(-50, None))          # the last 50 at most
energy = (0.5 * weight * abs(snapshots) ** 2 / k2.where(k2 > 0)).mean("time")
shell = np.rint(np.sqrt(ds["kx"] ** 2 + ds["ky"] ** 2)).rename("shell")
spectrum = energy.groupby(shell).sum().compute() / k_unit           # E(k_j), per unit k
spectrum = spectrum.isel(shell=slice(1, None))                    # k = 0 holds no energy
print(f"sum of E(k) dk = {float(spectrum.sum()) * k_unit:.4f}, "
      f"u_rms^2 / 2 = {ds.attrs['u_rms'] ** 2 / 2:.4f}")

# %%
fig, (ax0, ax1, ax2) = plt.subplots(1, 3, figsize=(13, 4))
lim = float(np.abs(omega).max())
im = ax0.imshow(omega, origin="lower", cmap="RdBu_r", vmin=-lim, vmax=lim,
                extent=(0, length, 0, length))
fig.colorbar(im, ax=ax0, label="$\\omega$")
ax0.set(title=f"vorticity, t = {float(ds['time'][-1]):.2f}", xlabel="x", ylabel="y")
ax1.loglog(spectrum["shell"] * k_unit, spectrum, "o-", ms=3)
ax1.axvline(float(ds.attrs["k_f"]), color="0.6", ls=":", label="$k_f$")
ax1.set(xlabel="$k$", ylabel="$E(k)$",
        title=f"energy spectrum, {snapshots.sizes['time']} snapshots")
ax1.legend()
ax2.plot(diagnostics["t"], diagnostics["energy"], label="E")
ax2.axvline(float(ds["time"][0]), color="0.6", ls=":", label="first snapshot")
ax2.set(xlabel="t", ylabel="E", title="energy (diagnostics group)")
ax2.legend()
fig.tight_layout()
fig.savefig(OUT / "dns_store.png", dpi=120)
print("wrote", OUT / "dns_store.png")

# %%
ds.close()
diagnostics.close()
shutil.rmtree(TMP)
