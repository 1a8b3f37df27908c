"""Zarr store of a DNS run: its layout and the resumable writer used by ``swimrl-dns``.

Layout (zarr format 3, consolidated metadata, readable with ``xarray.open_zarr(path)``)::

    omega_hat (time, ky, kx) complex64   Fourier coefficients c_k of the vorticity,
                                         omega(x) = sum_k c_k exp(i k.x), c = rfft2(omega)/N^2,
                                         retained modes only: ky = -K..K, kx = 0..K
    time (time) float64, ky (ky) int32, kx (kx) int32     coordinates (integer wavenumbers)
    diagnostics/  time series (t, E, Z, rates) every ``diag_every`` steps
    checkpoint/   solver state (complex128, same packing, unnormalised) + RNG state

Channels ``(u_x, u_y, S_xx, S_xy, omega)`` are reconstructed from ``omega_hat`` by spectral
differentiation (:func:`swimrl.flows.dns.state.flow_channels`); they equal the solver's own
fields up to the float32 rounding of the stored coefficients (~1e-7 relative), at 1/11 of the
size of five float32 node fields. Root attributes hold the parameters, ``dt_store``,
``u_rms``, ``tau_k``, channel names and units, and the run's progress (``status``,
``n_written``); ``n_written`` is the commit marker: data beyond it is discarded on resume.
"""

from __future__ import annotations

import math
import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch
import zarr

from swimrl.flows.dns.grid import dealias_cutoff

FORMAT_VERSION = 1
CHANNEL_UNITS = ("L/T", "L/T", "1/T", "1/T", "1/T")
DIAG_FIELDS = ("t", "energy", "enstrophy", "energy_dissipation", "energy_friction",
               "enstrophy_dissipation", "enstrophy_friction")


def pack(omega_hat: torch.Tensor, n: int) -> torch.Tensor:
    """Retained modes of ``omega_hat`` ``(..., N, N//2+1)`` as ``(..., 2K+1, K+1)`` ky up."""
    K = dealias_cutoff(n)
    iy = torch.remainder(torch.arange(-K, K + 1), n).to(omega_hat.device)
    return omega_hat[..., iy, : K + 1]


def unpack(packed: torch.Tensor, n: int) -> torch.Tensor:
    """Inverse of :func:`pack`: zero-filled ``(..., N, N//2+1)``."""
    K = dealias_cutoff(n)
    iy = torch.remainder(torch.arange(-K, K + 1), n).to(packed.device)
    out = torch.zeros((*packed.shape[:-2], n, n // 2 + 1), dtype=packed.dtype, device=packed.device)
    out[..., iy, : K + 1] = packed
    return out


def store_status(path: str | Path) -> str | None:
    """``status`` attribute of the store at ``path`` (``None`` if there is none)."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        g = zarr.open_group(str(path), mode="r", use_consolidated=False)
    except Exception:  # noqa: BLE001 - not a zarr group: report as foreign
        return "unknown"
    if "format_version" not in g.attrs:
        return "unknown"
    return str(g.attrs.get("status", "unknown"))


class DNSStoreWriter:
    """Appends snapshots/diagnostics and checkpoints of one realisation to a zarr group."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.group = zarr.open_group(str(self.path), mode="r+", use_consolidated=False)
        self.n = int(self.group.attrs["n"])
        self._pending_written = int(self.group.attrs.get("n_written", 0))
        self._pending_diag = int(self.group.attrs.get("n_diag", 0))

    # -- creation -------------------------------------------------------------------------
    @classmethod
    def create(
        cls, path: str | Path, attrs: dict[str, Any], chunk_times: int = 1
    ) -> DNSStoreWriter:
        """New store at ``path`` (must not exist) with root ``attrs`` (must contain ``n``)."""
        path = Path(path)
        n = int(attrs["n"])
        K = dealias_cutoff(n)
        g = zarr.open_group(str(path), mode="w-")
        g.create_array("omega_hat", shape=(0, 2 * K + 1, K + 1),
                       chunks=(chunk_times, 2 * K + 1, K + 1), dtype="complex64", fill_value=0,
                       dimension_names=("time", "ky", "kx"), compressors=None)
        g.create_array("time", shape=(0,), chunks=(4096,), dtype="float64", fill_value=0,
                       dimension_names=("time",))
        ky = g.create_array("ky", shape=(2 * K + 1,), dtype="int32", dimension_names=("ky",))
        ky[:] = np.arange(-K, K + 1, dtype=np.int32)
        kx = g.create_array("kx", shape=(K + 1,), dtype="int32", dimension_names=("kx",))
        kx[:] = np.arange(0, K + 1, dtype=np.int32)
        g["omega_hat"].attrs.update({
            "long_name": "vorticity Fourier coefficients c_k, omega = sum_k c_k exp(i k.x)",
            "normalisation": "rfft2(omega) / N^2 (hermitian half plane kx >= 0)",
            "units": "1/T",
        })
        g["time"].attrs.update({"long_name": "simulation time", "units": "T"})
        g["ky"].attrs.update({"long_name": "wavenumber index m_y, k_y = 2 pi m_y / L"})
        g["kx"].attrs.update({"long_name": "wavenumber index m_x, k_x = 2 pi m_x / L"})
        d = g.require_group("diagnostics")
        for name in DIAG_FIELDS:
            d.create_array(name, shape=(0,), chunks=(4096,), dtype="float64", fill_value=0,
                           dimension_names=("t",))
        g.require_group("checkpoint")
        g.attrs.update({**attrs, "format_version": FORMAT_VERSION, "status": "created",
                        "n_written": 0, "n_diag": 0})
        writer = cls(path)
        writer.commit()
        return writer

    # -- appending ------------------------------------------------------------------------
    def append_snapshot(self, omega_hat: torch.Tensor, t: float) -> int:
        """Write ``omega_hat`` ``(N, N//2+1)`` (unnormalised) as snapshot ``n_written``.

        Data only: it becomes part of the run at the next :meth:`commit` with ``n_written``.
        Returns the index written.
        """
        arr, tarr = self.group["omega_hat"], self.group["time"]
        i = self._pending_written
        c = pack(omega_hat.detach(), self.n).to(torch.complex128) / float(self.n) ** 2
        if arr.shape[0] < i + 1:
            arr.resize((i + 1, *arr.shape[1:]))
            tarr.resize((i + 1,))
        arr[i] = c.to(torch.complex64).cpu().numpy()
        tarr[i] = t
        self._pending_written = i + 1
        return i

    def append_diagnostics(self, row: dict[str, float]) -> None:
        """Append one diagnostics sample (keys :data:`DIAG_FIELDS`)."""
        d = self.group["diagnostics"]
        i = self._pending_diag
        for name in DIAG_FIELDS:
            a = d[name]
            if a.shape[0] < i + 1:
                a.resize((i + 1,))
            a[i] = float(row[name])
        self._pending_diag = i + 1

    @property
    def n_written(self) -> int:
        """Committed number of snapshots."""
        return int(self.group.attrs["n_written"])

    @property
    def attrs(self) -> dict[str, Any]:
        """Root attributes (committed)."""
        return dict(self.group.attrs)

    # -- commit / checkpoint --------------------------------------------------------------
    def save_checkpoint(self, omega_hat: torch.Tensor, rng_state: torch.Tensor | None,
                        **progress: Any) -> None:
        """Store the solver state (complex128) and RNG, then commit ``progress`` attrs."""
        ck = self.group["checkpoint"]
        state = pack(omega_hat.detach(), self.n).to(torch.complex128).cpu().numpy()
        ck.create_array("omega_hat", shape=state.shape, dtype="complex128", overwrite=True,
                        fill_value=0)[...] = state
        if rng_state is not None:
            rs = rng_state.cpu().numpy().astype(np.uint8)
            ck.create_array("rng", shape=rs.shape, dtype="uint8", overwrite=True,
                            fill_value=0)[...] = rs
        self.commit(**progress)

    def load_checkpoint(self) -> tuple[torch.Tensor, torch.Tensor | None]:
        """``(omega_hat (N, N//2+1) complex128, rng_state or None)`` from the checkpoint."""
        ck = self.group["checkpoint"]
        w = unpack(torch.from_numpy(np.asarray(ck["omega_hat"][...])), self.n)
        rng = torch.from_numpy(np.asarray(ck["rng"][...])) if "rng" in ck else None
        return w, rng

    def has_checkpoint(self) -> bool:
        """Whether a solver state has been checkpointed."""
        return "omega_hat" in self.group["checkpoint"]

    def commit(self, **attrs: Any) -> None:
        """Make appended data part of the run: update ``n_written``/``n_diag`` and ``attrs``."""
        self.group.attrs.update({**attrs, "n_written": self._pending_written,
                                 "n_diag": self._pending_diag})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            zarr.consolidate_metadata(str(self.path))

    def rollback(self) -> None:
        """Discard uncommitted appends (truncate arrays to the committed lengths)."""
        n, nd = int(self.group.attrs["n_written"]), int(self.group.attrs["n_diag"])
        arr = self.group["omega_hat"]
        arr.resize((n, *arr.shape[1:]))
        self.group["time"].resize((n,))
        for name in DIAG_FIELDS:
            self.group["diagnostics"][name].resize((nd,))
        self._pending_written, self._pending_diag = n, nd


def open_run_store(path: str | Path, attrs: dict[str, Any], compare_keys: tuple[str, ...],
                   overwrite: bool = False, chunk_times: int = 1,
                   extend_to: int | None = None) -> tuple[DNSStoreWriter, bool]:
    """Create or resume the store at ``path``; returns ``(writer, resumed)``.

    * no store: create it;
    * finished store (``status == "complete"``): :class:`FileExistsError` unless ``overwrite``
      (then it is deleted and recreated) or ``extend_to`` exceeds its number of snapshots
      (then it is resumed from its final checkpoint and more snapshots are appended: the
      continuation of the same realisation, bit-for-bit what a longer run would have stored);
    * anything else at ``path`` that is not a swimrl DNS store: :class:`FileExistsError`, even
      with ``overwrite`` (it is never deleted);
    * unfinished store: resume if ``attrs[k]`` equals the stored value for every ``k`` in
      ``compare_keys`` (else :class:`ValueError` naming the first differing key), or recreate
      if ``overwrite``.
    """
    path = Path(path)
    status = store_status(path)
    if status == "unknown":
        raise FileExistsError(f"{path} exists and is not a swimrl DNS store; it is never deleted:"
                              " remove it by hand or choose another path")
    if status is not None and overwrite:
        shutil.rmtree(path)
        status = None
    if status is None:
        return DNSStoreWriter.create(path, attrs, chunk_times), False
    writer = DNSStoreWriter(path)
    if status == "complete":
        n_have = int(writer.attrs.get("n_written", 0))
        if extend_to is None:
            raise FileExistsError(f"{path} holds a finished DNS store; set overwrite=true to "
                                  "replace it, store.extend=true with store.n_times > "
                                  f"{n_have} to append to it, or choose another path")
        if int(extend_to) <= n_have:
            raise ValueError(f"store.extend=true needs store.n_times > {n_have} (the snapshots "
                             f"already in {path}), got {extend_to}")
    stored = writer.attrs
    for k in compare_keys:
        if not _same(stored.get(k), attrs.get(k)):
            raise ValueError(f"cannot resume {path}: {k}={stored.get(k)!r} in the store but "
                             f"{attrs.get(k)!r} requested; set overwrite=true or use another path")
    writer.rollback()
    return writer, True


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float | int) and isinstance(b, float | int):
        return math.isclose(float(a), float(b), rel_tol=1e-12, abs_tol=0.0)
    return a == b
