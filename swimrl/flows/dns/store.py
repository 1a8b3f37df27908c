r"""Zarr store of a DNS run: its layout and the resumable writer used by ``swimrl-dns``.

Layout (zarr format 3, consolidated metadata, readable with ``xarray.open_zarr(path)``)::

    omega_hat (time, ky, kx) complex64   Fourier coefficients c_k of the vorticity (below),
                                         retained modes only: ky = -K..K, kx = 0..K
    time (time) float64, ky (ky) int32, kx (kx) int32     coordinates (integer wavenumbers)
    diagnostics/  time series (t, E, Z, rates) every ``diag_every`` steps
    checkpoint/   solver state (complex128, same packing, unnormalised) + RNG state, as
                  omega_hat_<v>, rng_<v>; the attribute checkpoint_version = v points to it

with the coefficients $c_{\boldsymbol k}$ of

$$
\omega(\boldsymbol x) = \sum_{\boldsymbol k} c_{\boldsymbol k}\,
e^{i\boldsymbol k\cdot\boldsymbol x},\qquad c = \mathrm{rfft2}(\omega)/N^2.
$$

Every array ends its codec chain with a crc32c checksum of each chunk (``omega_hat``: no
compression, then the checksum; the others: zarr's default zstd, then the checksum); a damaged
chunk is an :class:`~swimrl.errors.IntegrityError` on reading
(:mod:`swimrl.flows.dns.integrity`; ``swimrl-dns-verify`` checks a whole store).

Channels $(u_x, u_y, S_{xx}, S_{xy}, \omega)$ are reconstructed from ``omega_hat`` by spectral
differentiation (:func:`swimrl.flows.dns.state.flow_channels`); they equal the solver's own
fields up to the float32 rounding of the stored coefficients (~1e-7 relative), at 1/11 of the
size of five float32 node fields. Root attributes hold the parameters, ``dt_store``,
``u_rms``, ``tau_k``, channel names and units, and the run's progress (``status``,
``n_written``); ``n_written`` is the commit marker: data beyond it is discarded on resume.

A checkpoint is written atomically: the new state goes into arrays under a new version
``v`` (the previous ones untouched), then one attribute update (the commit, with
``n_written`` and the progress) switches ``checkpoint_version`` to ``v``; older versions
are deleted only after that. A kill at any moment leaves the previous checkpoint, with the
attributes that match it, or the new one; a store whose progress says there is a solver
state that cannot be read is refused, never restarted from rest.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch
import zarr

from swimrl.errors import ConfigError
from swimrl.flows.dns.grid import dealias_cutoff
from swimrl.flows.dns.integrity import (
    SnapshotCheck,
    compressors,
    has_checksum,
    read,
    read_snapshots,
    write,
)

log = logging.getLogger(__name__)

FORMAT_VERSION = 1
CHANNEL_UNITS = ("L/T", "L/T", "1/T", "1/T", "1/T")
DIAG_FIELDS = ("t", "energy", "enstrophy", "energy_dissipation", "energy_friction",
               "enstrophy_dissipation", "enstrophy_friction")


def pack(omega_hat: torch.Tensor, n: int) -> torch.Tensor:
    """Retained modes of ``omega_hat`` ``(..., N, N//2+1)`` as ``(..., 2K+1, K+1)`` ky up."""
    K = dealias_cutoff(n)
    iy = torch.remainder(torch.arange(-K, K + 1), n).to(omega_hat.device)
    return omega_hat[..., iy, : K + 1]


def unpack(packed: torch.Tensor, n: int, cutoff: int | None = None) -> torch.Tensor:
    r"""Inverse of :func:`pack`: zero-filled ``(..., N, N//2+1)``; ``packed`` holds the modes
    $|m| \le$ ``cutoff`` (default: the 2/3 rule's $K$ of ``n``)."""
    K = dealias_cutoff(n) if cutoff is None else cutoff
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


def store_record(path: str | Path) -> dict[str, Any]:
    """Provenance of the store at ``path`` for a result file: absolute path, ``status``,
    ``n_written`` and ``content_hash``, the SHA-256 of the root attributes (parameters,
    measured scales, progress) and of the committed ``time`` array and first and last
    snapshots (the whole store would take minutes to hash at 512^2); ``checksums``: whether
    its chunks carry crc32c checksums (verified on every read). The arrays read pass their
    checksums and the snapshots :class:`~swimrl.flows.dns.integrity.SnapshotCheck`
    (:class:`~swimrl.errors.IntegrityError` otherwise)."""
    path = Path(path).resolve()
    g = zarr.open_group(str(path), mode="r", use_consolidated=False)
    attrs = dict(g.attrs)
    n = int(attrs.get("n_written", 0))
    h = hashlib.sha256(json.dumps(attrs, sort_keys=True, default=str).encode())
    h.update(read(g["time"], path, "time", slice(0, n)).tobytes())
    if n:
        check = SnapshotCheck(int(attrs["n"]), float(attrs.get("length", 2 * math.pi)),
                              float(attrs.get("u_rms", math.nan)), path)
        for i in (0, n - 1):
            c = read_snapshots(g["omega_hat"], path, i, i + 1)
            check.check(torch.from_numpy(c), i)
            h.update(c[0].tobytes())
    return {"path": str(path), "status": str(attrs.get("status")), "n_written": n,
            "content_hash": "sha256:" + h.hexdigest(),
            "checksums": has_checksum(g["omega_hat"])}


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
                       dimension_names=("time", "ky", "kx"), compressors=compressors(False))
        g.create_array("time", shape=(0,), chunks=(4096,), dtype="float64", fill_value=0,
                       dimension_names=("time",), compressors=compressors())
        ky = g.create_array("ky", shape=(2 * K + 1,), dtype="int32", dimension_names=("ky",),
                            compressors=compressors())
        ky[:] = np.arange(-K, K + 1, dtype=np.int32)
        kx = g.create_array("kx", shape=(K + 1,), dtype="int32", dimension_names=("kx",),
                            compressors=compressors())
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
                           dimension_names=("t",), compressors=compressors())
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
        write(arr, self.path, "omega_hat", i, c.to(torch.complex64).cpu().numpy())
        write(tarr, self.path, "time", i, t)
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
            write(a, self.path, f"diagnostics/{name}", i, float(row[name]))
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
        """Store the solver state (complex128) and RNG under a new version, then commit
        ``progress`` and the version in one attribute update; then drop older versions."""
        version = self.checkpoint_version + 1
        ck = self.group["checkpoint"]
        state = pack(omega_hat.detach(), self.n).to(torch.complex128).cpu().numpy()
        self._write_array(ck, f"omega_hat_{version}", state)
        if rng_state is not None:
            self._write_array(ck, f"rng_{version}", rng_state.cpu().numpy().astype(np.uint8))
        self.commit(checkpoint_version=version, **progress)
        self._drop_checkpoints_except(version)

    @staticmethod
    def _write_array(group: zarr.Group, name: str, data: np.ndarray) -> None:
        """``data`` as the array ``name`` of ``group`` (replacing a leftover of a killed run)."""
        group.create_array(name, shape=data.shape, dtype=data.dtype, overwrite=True,
                           fill_value=0, compressors=compressors())[...] = data

    def _drop_checkpoints_except(self, version: int) -> None:
        """Delete checkpoint arrays of other versions (after the commit of ``version``)."""
        ck = self.group["checkpoint"]
        keep = {f"omega_hat_{version}", f"rng_{version}"}
        old = [k for k in ck.array_keys() if k not in keep]
        for name in old:
            del ck[name]
        if old:
            self._consolidate()

    @property
    def checkpoint_version(self) -> int:
        """Version of the committed checkpoint (-1: none; 0 for a store of the first layout,
        whose arrays are named ``omega_hat`` and ``rng``)."""
        v = self.group.attrs.get("checkpoint_version")
        if v is None:
            return 0 if "omega_hat" in self.group["checkpoint"] else -1
        return int(v)

    def _names(self) -> tuple[str, str]:
        v = self.checkpoint_version
        legacy = self.group.attrs.get("checkpoint_version") is None
        return ("omega_hat", "rng") if legacy else (f"omega_hat_{v}", f"rng_{v}")

    def load_checkpoint(self) -> tuple[torch.Tensor, torch.Tensor | None]:
        """``(omega_hat (N, N//2+1) complex128, rng_state or None)`` from the checkpoint."""
        ck = self.group["checkpoint"]
        w_name, rng_name = self._names()
        step = self.group.attrs.get("step")
        again = "the run cannot be resumed: pass store.overwrite=true to start it again"
        try:
            arr = ck[w_name]
        except (KeyError, OSError) as err:
            raise FileExistsError(f"{self.path}: the checkpoint {w_name} of step {step} cannot "
                                  f"be read ({err}); {again}") from err
        w = unpack(torch.from_numpy(read(arr, self.path, f"checkpoint/{w_name} of step {step}",
                                         advice=again)), self.n)
        rng = None
        if rng_name in ck:
            rng = torch.from_numpy(read(ck[rng_name], self.path,
                                        f"checkpoint/{rng_name} of step {step}", advice=again))
        return w, rng

    def commit(self, **attrs: Any) -> None:
        """Make appended data part of the run: update ``n_written``/``n_diag`` and ``attrs``."""
        self.group.attrs.update({**attrs, "n_written": self._pending_written,
                                 "n_diag": self._pending_diag})
        self._consolidate()

    def _consolidate(self) -> None:
        """Rewrite the consolidated metadata (what readers of the store see)."""
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


def check_run_store(path: str | Path, attrs: dict[str, Any], compare_keys: tuple[str, ...],
                    overwrite: bool = False, extend_to: int | None = None) -> str:
    """What :func:`open_run_store` will do with ``path``, without touching it: ``"create"``,
    ``"replace"`` or ``"resume"``; raises for a store it refuses (see there)."""
    path = Path(path)
    status = store_status(path)
    if status == "unknown":
        raise FileExistsError(f"{path} exists and is not a swimrl DNS store; it is never deleted:"
                              " remove it by hand or choose another path")
    if status is None:
        return "create"
    if overwrite:
        return "replace"
    stored = dict(zarr.open_group(str(path), mode="r", use_consolidated=False).attrs)
    if status == "complete":
        n_have = int(stored.get("n_written", 0))
        if extend_to is None:
            raise FileExistsError(f"{path} holds a finished DNS store; set store.overwrite=true "
                                  "to replace it, store.extend=true with store.n_times > "
                                  f"{n_have} to append to it, or choose another path")
        if int(extend_to) <= n_have:
            raise ConfigError(f"store.n_times={extend_to} is invalid: allowed > {n_have} (the "
                              f"snapshots already in {path}) with store.extend=true")
    for k in compare_keys:
        if not _same(stored.get(k), attrs.get(k)):
            if int(stored.get("step", 0)) == 0 and "checkpoint_version" not in stored:
                return "replace"  # a run that failed before its first checkpoint: nothing lost
            raise FileExistsError(
                f"cannot resume {path}: {k}={stored.get(k)!r} in the store but "
                f"{attrs.get(k)!r} requested; set store.overwrite=true to start it again, or "
                "choose another store.path")
    return "resume"


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
      ``compare_keys``, or recreate if ``overwrite`` or if the store holds no checkpoint yet
      (a run that failed at once); else :class:`FileExistsError` naming the first differing
      key and ``store.overwrite=true``.
    """
    path = Path(path)
    action = check_run_store(path, attrs, compare_keys, overwrite, extend_to)
    if action == "replace":
        log.info("replacing %s", path)
        shutil.rmtree(path)
    if action != "resume":
        return DNSStoreWriter.create(path, attrs, chunk_times), False
    writer = DNSStoreWriter(path)
    writer.rollback()
    return writer, True


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float | int) and isinstance(b, float | int):
        return math.isclose(float(a), float(b), rel_tol=1e-12, abs_tol=0.0)
    return a == b
