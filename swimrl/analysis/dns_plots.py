"""Figures of a stored DNS run: spectrum, PDFs, time series and a vorticity snapshot.

``swimrl-dns-plots <store> [--out docs/img] [--snapshots 50]`` writes

* ``dns_spectrum.png``: time-averaged ``E(k)`` with a ``k^-3`` reference line and the fitted
  slope, and the enstrophy flux ``Pi_Z(k)`` normalised by the viscous enstrophy dissipation;
* ``dns_pdfs.png``: PDFs of ``omega``, ``S_xx``, ``S_xy`` (each divided by its standard
  deviation) against the standard Gaussian (paper Fig. 6b);
* ``dns_timeseries.png``: energy, enstrophy and their rates through spin-up and storing;
* ``dns_vorticity.png``: the vorticity of the first stored snapshot (paper Fig. 6a);

and prints a JSON summary (slope, moments, ``u_rms``, ``tau_K``, resolution ``k_max l_nu``).

With several stores (independent realisations, e.g. ``swimrl-dns -m seed=...``),
``swimrl-dns-plots A.zarr B.zarr ... --out DIR`` writes each store's figures to
``<store>_plots/`` and, into ``DIR``, the checks across them (:func:`check_stores`):

* ``dns_stability.png``: ``u_rms(t) = (2E)^{1/2}`` and ``tau_K(t) = (2Z)^{-1/2}`` over the
  stored window of each run (from its diagnostics), divided by the run's stored values;
* ``dns_pdfs_all.png``: the PDFs of ``omega``, ``S_xx``, ``S_xy`` pooled over all runs;
* ``dns_checks.json``: per run the spectral slope, ``u_rms``, ``tau_K``, their relative
  spread and drift (second half of the window against the first) and ``k_max l_nu``, and
  whether every run has ``k_max l_nu >= 1``; the pooled PDF curves (Fig. dnsFlow(b)).

``DIR/runs/<store>.json`` keeps each run's record (summary, window series, PDF curves), and
the checks are drawn from every record there: ``swimrl-dns-plots C.zarr --checks --out DIR``
adds a run to the earlier ones without their stores.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import torch

from swimrl.flows.dns import diagnostics as dg
from swimrl.flows.dns.grid import SpectralGrid
from swimrl.flows.dns.params import DNSParams
from swimrl.flows.dns.sources import DNSStore
from swimrl.runs.atomic import atomic_write_text

from .plots import pyplot

PDF_CHANNELS = {"omega": 4, "S_xx": 2, "S_xy": 3}
COLOURS = {"omega": "tab:blue", "S_xx": "tab:green", "S_xy": "tab:red"}


def _params(store: DNSStore) -> DNSParams:
    a = store.attrs
    keys = ("n", "length", "nu", "alpha", "hypo_power", "epsilon", "k_f", "forcing_width", "dt")
    return DNSParams(**{k: a[k] for k in keys})


def fit_slope(k: np.ndarray, e: np.ndarray, k_lo: float, k_hi: float) -> float:
    """Least-squares slope of ``log E`` against ``log k`` for ``k_lo <= k <= k_hi``."""
    sel = (k >= k_lo) & (k <= k_hi) & (e > 0)
    return float(np.polyfit(np.log(k[sel]), np.log(e[sel]), 1)[0])


def spectra(store: DNSStore, idx: np.ndarray) -> dict[str, np.ndarray]:
    """Averages over snapshots ``idx`` of ``E(k)``, ``Pi_Z(k)``, ``Pi_E(k)`` and ``D_Z``."""
    p = _params(store)
    g = SpectralGrid(store.n, store.length, "cpu", torch.float64)
    e_sum = pz_sum = pe_sum = None
    dz = 0.0
    for i in idx:
        w = store.omega_hat(int(i), int(i) + 1, torch.complex128)
        k, e = dg.energy_spectrum(g, w)
        _, pe, pz = dg.spectral_fluxes(g, w)
        e_sum = e[0] if e_sum is None else e_sum + e[0]
        pe_sum = pe[0] if pe_sum is None else pe_sum + pe[0]
        pz_sum = pz[0] if pz_sum is None else pz_sum + pz[0]
        dz += float(dg.enstrophy_dissipation_rate(g, p, w)[0])
    m = len(idx)
    return {"k": k.numpy(), "E": (e_sum / m).numpy(), "Pi_E": (pe_sum / m).numpy(),
            "Pi_Z": (pz_sum / m).numpy(), "D_Z": dz / m, "k_max": g.k_max}


def plot_spectrum(spec: dict, params: DNSParams, out: Path, fit: tuple[float, float]) -> float:
    """E(k) with a k^-3 line and the fitted slope over ``fit``; Pi_Z(k)/D_Z. Returns slope."""
    k, e = spec["k"][1:], spec["E"][1:]
    slope = fit_slope(k, e, *fit)
    plt = pyplot()
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    ax.loglog(k, e, "k-", lw=1.5, label=r"$E(k)$")
    k_ref = np.array([fit[0], fit[1] * 2])
    i0 = int(np.argmin(np.abs(k - fit[0])))
    ax.loglog(k_ref, 2 * e[i0] * (k_ref / k[i0]) ** -3.0, "r--", label=r"$k^{-3}$")
    sel = (k >= fit[0]) & (k <= fit[1])
    c = np.exp(np.mean(np.log(e[sel]) - slope * np.log(k[sel])))
    ax.loglog(k[sel], 0.5 * c * k[sel] ** slope, "b:", label=f"fit slope {slope:.2f}")
    ax.axvline(params.k_f, color="grey", lw=0.8)
    ax.axvline(spec["k_max"], color="grey", lw=0.8, ls="--")
    ax.text(params.k_f * 1.05, e.max() * 0.3, r"$k_f$", color="grey")
    ax.text(spec["k_max"] * 0.6, e.max() * 0.3, r"$k_{\max}$", color="grey")
    ax.set_xlabel(r"$k$")
    ax.set_ylabel(r"$E(k)$")
    ax.set_ylim(max(e.min(), e.max() * 1e-14), e.max() * 3)
    ax.legend(frameon=False)
    ax.set_title("energy spectrum")
    ax2.semilogx(spec["k"][1:], spec["Pi_Z"][1:] / spec["D_Z"], "k-", label=r"$\Pi_Z/\eta_\nu$")
    ax2.semilogx(spec["k"][1:], spec["Pi_E"][1:] / params.epsilon, "g-",
                 label=r"$\Pi_E/\epsilon$")
    ax2.axhline(0, color="grey", lw=0.5)
    ax2.axhline(1, color="grey", lw=0.5, ls="--")
    ax2.axvline(params.k_f, color="grey", lw=0.8)
    ax2.set_xlabel(r"$k$")
    ax2.set_title(r"spectral fluxes ($\eta_\nu = 2\nu\langle P\rangle$)")
    ax2.legend(frameon=False)
    fig.tight_layout()
    fig.savefig(out, dpi=130)
    plt.close(fig)
    return slope


def gradient_samples(store: DNSStore, idx: np.ndarray, chunk: int = 8) -> dict[str, np.ndarray]:
    """Node values of ``omega``, ``S_xx``, ``S_xy`` over snapshots ``idx`` (float32, flat)."""
    parts: dict[str, list[np.ndarray]] = {k: [] for k in PDF_CHANNELS}
    for j in range(0, len(idx), chunk):
        for i in idx[j:j + chunk]:
            q = store.channels(int(i), int(i) + 1)[0]
            for name, c in PDF_CHANNELS.items():
                parts[name].append(q[..., c].reshape(-1).numpy())
    return {k: np.concatenate(v) for k, v in parts.items()}


def pdf_curves(samples: dict[str, np.ndarray]) -> dict[str, dict]:
    """Per channel the PDF of ``(x - <x>) / std(x)`` on 121 bins over ``[-12, 12]``
    (``z``, ``pdf``), the sample ``count`` and the standardised moments."""
    out = {}
    for name, x in samples.items():
        t = torch.from_numpy(x)
        z, pdf, _ = dg.standardized_pdf(t, bins=121, half_width=12.0)
        out[name] = {"z": z.tolist(), "pdf": pdf.tolist(), "count": int(x.size),
                     **dg.moments(t)}
    return out


def pool_pdf_curves(curves: list[dict[str, dict]]) -> dict[str, dict]:
    """Curves of :func:`pdf_curves` of several runs pooled, each run in its own units: the
    count-weighted mean of the densities and of the standardised moments."""
    out = {}
    for name in curves[0]:
        parts = [c[name] for c in curves]
        w = np.array([p["count"] for p in parts], dtype=float)
        w = w / w.sum()
        out[name] = {"z": parts[0]["z"],
                     "pdf": (w @ np.array([p["pdf"] for p in parts])).tolist(),
                     "count": int(sum(p["count"] for p in parts)),
                     **{k: float(w @ np.array([p[k] for p in parts]))
                        for k in ("skewness", "flatness")}}
    return out


def draw_pdfs(curves: dict[str, dict], out: Path) -> None:
    """Semi-log PDFs of each channel (over its standard deviation) and the Gaussian."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for name, c in curves.items():
        z, pdf = np.asarray(c["z"]), np.asarray(c["pdf"])
        keep = pdf > 0
        label = {"omega": r"$\omega$", "S_xx": r"$S_{xx}$", "S_xy": r"$S_{xy}$"}[name]
        ax.semilogy(z[keep], pdf[keep], color=COLOURS[name],
                    label=f"{label} (F={c['flatness']:.1f})")
    zz = torch.linspace(-6, 6, 241, dtype=torch.float64)
    ax.semilogy(zz, dg.gaussian_pdf(zz), "k--", label="Gaussian")
    ax.set_xlabel(r"$X/\sigma_X$")
    ax.set_ylabel("PDF")
    ax.set_ylim(1e-7, 1)
    ax.legend(frameon=False, fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=130)
    plt.close(fig)


def plot_pdfs(samples: dict[str, np.ndarray], out: Path) -> dict[str, dict[str, float]]:
    """Semi-log PDFs of ``x / std(x)`` for each channel and the Gaussian (paper Fig. 6b);
    returns the moments."""
    curves = pdf_curves(samples)
    draw_pdfs(curves, out)
    return {k: {m: c[m] for m in ("std", "skewness", "flatness")} for k, c in curves.items()}


def plot_timeseries(path: Path, store: DNSStore, out: Path) -> None:
    """Energy/enstrophy and their rates from the ``diagnostics`` group (checksums checked)."""
    d = store.diagnostics()
    t = d["t"]
    plt = pyplot()
    fig, axs = plt.subplots(1, 2, figsize=(10, 3.6))
    axs[0].plot(t, d["energy"], label=r"$E$")
    axs[0].plot(t, d["enstrophy"] / 10, label=r"$Z/10$")
    axs[1].plot(t, d["energy_friction"], label=r"$F_E$ (hypo-friction)")
    axs[1].plot(t, d["energy_dissipation"], label=r"$D_E$ (viscous)")
    axs[1].plot(t, d["enstrophy_dissipation"] / 10, label=r"$D_Z/10$")
    axs[1].plot(t, d["enstrophy_friction"] / 10, label=r"$F_Z/10$")
    eps = float(store.attrs["epsilon"])
    axs[1].axhline(eps, color="k", ls="--", lw=0.8, label=r"$\epsilon$")
    t0 = store.attrs.get("t_first")
    for ax in axs:
        if t0 is not None:
            ax.axvline(float(t0), color="grey", ls=":", lw=1)
        ax.set_xlabel(r"$t$")
        ax.legend(frameon=False, fontsize=8)
    axs[0].set_title("energy and enstrophy (dotted: start of storing)")
    axs[1].set_title("dissipation rates")
    fig.tight_layout()
    fig.savefig(out, dpi=130)
    plt.close(fig)


def plot_vorticity(store: DNSStore, out: Path, index: int = 0) -> None:
    """Image of ``omega / std(omega)`` at snapshot ``index`` (paper Fig. 6a)."""
    w = store.channels(index, index + 1)[0, ..., 4].numpy()
    s = float(w.std())
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5, 4.4))
    im = ax.imshow(w / s, origin="lower", cmap="RdBu_r", vmin=-3, vmax=3,
                   extent=(0, store.length, 0, store.length))
    fig.colorbar(im, ax=ax, label=r"$\omega/\omega_{\rm rms}$", shrink=0.85)
    ax.set_xlabel(r"$x$")
    ax.set_ylabel(r"$y$")
    ax.set_title(f"vorticity, t = {float(store.times[index]):.2f}")
    fig.tight_layout()
    fig.savefig(out, dpi=130)
    plt.close(fig)


def make_plots(path: str | Path, out_dir: str | Path = "docs/img", n_snapshots: int = 50,
               fit: tuple[float, float] = (6.0, 40.0)) -> dict:
    """All figures for the store at ``path`` into ``out_dir``; returns the summary dict."""
    return _plots_and_samples(path, out_dir, n_snapshots, fit)[0]


def _plots_and_samples(path: str | Path, out_dir: str | Path, n_snapshots: int,
                       fit: tuple[float, float]) -> tuple[dict, dict[str, np.ndarray]]:
    """:func:`make_plots`, also returning the gradient samples its PDFs were drawn from."""
    path, out_dir = Path(path), Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    store = DNSStore(path)
    if store.n_times == 0:
        raise ValueError(f"{path} holds no snapshots yet")
    params = _params(store)
    idx = np.unique(np.linspace(0, store.n_times - 1, min(n_snapshots, store.n_times)).round()
                    .astype(int))
    spec = spectra(store, idx)
    slope = plot_spectrum(spec, params, out_dir / "dns_spectrum.png", fit)
    samples = gradient_samples(store, idx)
    stats = plot_pdfs(samples, out_dir / "dns_pdfs.png")
    plot_timeseries(path, store, out_dir / "dns_timeseries.png")
    plot_vorticity(store, out_dir / "dns_vorticity.png")
    eta = spec["D_Z"]
    size = sum(f.stat().st_size for f in path.rglob("*") if f.is_file())
    return {
        "store": str(path), "n": store.n, "n_times": store.n_times, "dt_store": store.dt_store,
        "u_rms": store.u_rms, "tau_k": store.tau_k, "dt_store_over_tau_k":
            store.dt_store / store.tau_k, "spectrum_slope": slope, "slope_fit_range": list(fit),
        "enstrophy_dissipation": eta, "kmax_l_nu": spec["k_max"] * math.sqrt(params.nu)
            * eta ** (-1 / 6), "moments": stats, "snapshots_used": len(idx),
        "store_bytes": size,
    }, samples


def stored_window_series(path: Path, store: DNSStore) -> dict[str, np.ndarray]:
    """``t / tau_K`` from the first stored snapshot, ``u_rms(t) = (2E)^{1/2}`` and
    ``tau_K(t) = (2Z)^{-1/2}`` (2D: ``<A_ij A_ij> = <omega^2> = 2Z``) over the stored
    window, from the run's diagnostics (checksums checked)."""
    d = store.diagnostics(("t", "energy", "enstrophy"))
    t = d["t"]
    t0 = float(store.attrs.get("t_first", t[0] if len(t) else 0.0))
    keep = t >= t0
    e, z = d["energy"][keep], d["enstrophy"][keep]
    return {"t": (t[keep] - t0) / store.tau_k, "u_rms": np.sqrt(2 * e), "tau_k": (2 * z) ** -0.5}


def _spread(x: np.ndarray) -> dict[str, float]:
    """Relative std and drift (mean of the second half / mean of the first half - 1)."""
    half = len(x) // 2
    return {"rel_std": float(x.std() / x.mean()),
            "drift": float(x[half:].mean() / x[:half].mean() - 1) if half else math.nan}


def run_check(path: Path, n_snapshots: int = 50, fit: tuple[float, float] = (6.0, 40.0)) -> dict:
    """One run's record for the checks across runs (its own figures go to
    ``<store>_plots/``): summary, the stored window's ``u_rms(t)``, ``tau_K(t)`` and the
    standardised PDF curves of its gradients."""
    summary, samples = _plots_and_samples(path, str(path.with_suffix("")) + "_plots",
                                          n_snapshots, fit)
    store = DNSStore(path)
    series = stored_window_series(path, store)
    keys = ("store", "n", "n_times", "u_rms", "tau_k", "spectrum_slope", "kmax_l_nu",
            "store_bytes")
    return {"summary": {**{k: summary[k] for k in keys}, "seed": store.attrs.get("seed"),
                        "stored_tau_k": float(series["t"][-1]) if len(series["t"]) else 0.0,
                        "u_rms_t": _spread(series["u_rms"]), "tau_k_t": _spread(series["tau_k"])},
            "series": {k: v.tolist() for k, v in series.items()},
            "stored": {"u_rms": store.u_rms, "tau_k": store.tau_k},
            "pdfs": pdf_curves(samples)}


def check_stores(paths: list[Path], out_dir: Path, n_snapshots: int = 50,
                 fit: tuple[float, float] = (6.0, 40.0)) -> dict:
    """Each store's record (:func:`run_check`) into ``out_dir/runs/<store name>.json``, then
    the checks across every record there (records of earlier calls included, so runs can be
    added one at a time): the stability of ``u_rms`` and ``tau_K`` through each stored
    window, the PDFs pooled over all runs and the resolution of every run, into ``out_dir``;
    returns (and writes ``dns_checks.json``) the checks."""
    out_dir = Path(out_dir)
    (out_dir / "runs").mkdir(parents=True, exist_ok=True)
    for path in map(Path, paths):
        rec = run_check(path, n_snapshots, fit)
        atomic_write_text(out_dir / "runs" / f"{path.stem}.json", json.dumps(rec))
    records = [json.loads(p.read_text()) for p in sorted((out_dir / "runs").glob("*.json"))]
    plt = pyplot()
    fig, axs = plt.subplots(1, 2, figsize=(10, 3.6))
    for rec in records:
        series, label = rec["series"], f"seed {rec['summary']['seed']}"
        axs[0].plot(series["t"], np.asarray(series["u_rms"]) / rec["stored"]["u_rms"], lw=0.8,
                    label=label)
        axs[1].plot(series["t"], np.asarray(series["tau_k"]) / rec["stored"]["tau_k"], lw=0.8,
                    label=label)
    for ax, name in zip(axs, (r"$u_{\rm rms}(t)/u_{\rm rms}$", r"$\tau_K(t)/\tau_K$"),
                        strict=True):
        ax.axhline(1, color="k", lw=0.6)
        ax.set_xlabel(r"$t/\tau_K$ (from the first stored snapshot)")
        ax.set_ylabel(name)
        ax.legend(frameon=False, fontsize=7)
    fig.suptitle("stability of the stored runs (each divided by its stored value)", fontsize=9)
    fig.tight_layout()
    fig.savefig(out_dir / "dns_stability.png", dpi=130)
    plt.close(fig)
    pooled = pool_pdf_curves([rec["pdfs"] for rec in records])
    draw_pdfs(pooled, out_dir / "dns_pdfs_all.png")
    runs = [rec["summary"] for rec in records]
    u_rms = [r["u_rms"] for r in runs]
    checks = {"runs": runs,
              "pooled_moments": {k: {m: c[m] for m in ("skewness", "flatness")}
                                 for k, c in pooled.items()},
              "pooled_pdfs": {k: {"z": c["z"], "pdf": c["pdf"]} for k, c in pooled.items()},
              "all_resolved": all(r["kmax_l_nu"] >= 1 for r in runs),
              "u_rms_spread_over_runs": float(np.std(u_rms) / np.mean(u_rms)),
              "store_bytes_total": int(sum(r["store_bytes"] for r in runs))}
    atomic_write_text(out_dir / "dns_checks.json", json.dumps(checks, indent=1))
    return checks
