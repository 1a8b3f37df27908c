r"""Integrity of stored DNS runs: a checksum on every chunk, checked reads, and the physical
checks every decoded snapshot passes.

*Checksums.* Every array of a store written by :class:`~swimrl.flows.dns.store.DNSStoreWriter`
(``omega_hat``, ``time``, ``ky``, ``kx``, ``diagnostics/*``, ``checkpoint/*``) ends its codec
chain with zarr's ``crc32c`` codec (:class:`zarr.codecs.Crc32cCodec`, CRC-32C of each encoded
chunk appended to it; computed by ``google-crc32c``, a dependency of zarr itself). A chunk whose
bytes changed on disk fails to decode; :func:`read` and :func:`read_snapshots` turn that into
one :class:`~swimrl.errors.IntegrityError` line naming the store, the array and the snapshot
(time) index. Stores written before (:func:`has_checksum` false) read as before, unverified.

*Snapshot checks* (:class:`SnapshotCheck`, on the packed coefficients $c_{\boldsymbol k}$ of
a snapshot, $\omega = \sum_{\boldsymbol k} c_{\boldsymbol k}\exp(i\boldsymbol k\cdot\boldsymbol x)$
over the full plane, stored on the half plane $m_x \ge 0$ with the Parseval weight
$w_{\boldsymbol k} = 1$ ($m_x = 0$), $2$ ($m_x > 0$)):

$$
\begin{aligned}
u_\mathrm{rms}(t)^2 &= \langle\boldsymbol u\cdot\boldsymbol u\rangle
= \sum_{\boldsymbol k} w_{\boldsymbol k}\,|c_{\boldsymbol k}|^2/|\boldsymbol k|^2,\qquad
E = \langle\boldsymbol u\cdot\boldsymbol u\rangle/2,\\
Z &= \langle\omega^2\rangle/2 = \sum_{\boldsymbol k} w_{\boldsymbol k}\,|c_{\boldsymbol k}|^2/2,
\end{aligned}
$$

each snapshot must be finite and have $u_\mathrm{rms}(t)/u_\mathrm{rms}$ in $[1/F, F]$,
$F$ = :data:`RMS_FACTOR` $= 5$, $u_\mathrm{rms}$ the store's attribute (the average over its
snapshots). Finite coefficients with a bounded $u_\mathrm{rms}(t)$ give finite decoded
channels ($|c_{\boldsymbol k}| \le |\boldsymbol k|\,F\,u_\mathrm{rms}$), so the decoded fields
need no second pass.

Why 5. The energy of a stored run fluctuates on the friction time $1/\alpha$: measured on a
$128^2$ run with the production physics ($\nu = 1.6\times10^{-3}$, $\delta t = 2\times10^{-3}$,
spin-up 12, 3000 snapshots over 42 time units = 21 friction times),
$u_\mathrm{rms}(t)/u_\mathrm{rms}$ spans $[0.763, 1.286]$, relative standard deviation 9.6 %
(the five $512^2$ runs: 7.8-9.5 %, ``docs/results/dns_checks/``); a factor 3 would hold those
with a margin of 2.3. But a run stored after a spin-up shorter than the friction time is still
growing through its stored window: the test suite's $32^2$ runs (spin-up 0.2 from rest,
$1/\alpha = 2$) reach down to $u_\mathrm{rms}(t)/u_\mathrm{rms} = 0.31$ over 40 snapshots and
0.24 over 100 (seeds 0-2). $F = 5$ accepts those and still refuses what corruption produces: a
NaN, a zeroed or lost chunk (rms 0), a wrong normalisation (a factor $N^2$), a ``u_rms``
attribute off by 10 (a stationary run's snapshots then sit at 0.076-0.13 or 7.6-12.9 times
it). The check costs one weighted sum over the $(2K+1)(K+1)$ stored coefficients: 0.26 ms at
$512^2$ against 21 ms for the decode.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import torch
import zarr
from zarr.codecs import Crc32cCodec, ZstdCodec

from swimrl.errors import IntegrityError
from swimrl.flows.dns.grid import dealias_cutoff

#: Allowed ratio of a snapshot's rms velocity to the store's ``u_rms``, either way.
RMS_FACTOR = 5.0
#: Name of the checksum codec in the array metadata.
CHECKSUM = "crc32c"


def compressors(compress: bool = True) -> tuple:
    """Bytes-to-bytes codecs of a new store array: zarr's default compression (zstd level 0;
    ``compress=False``: none) followed by the crc32c checksum of the encoded chunk."""
    return (ZstdCodec(level=0, checksum=False), Crc32cCodec()) if compress else (Crc32cCodec(),)


def has_checksum(arr: zarr.Array) -> bool:
    """Whether the chunks of ``arr`` carry a crc32c checksum."""
    return any(isinstance(c, Crc32cCodec) for c in arr.compressors)


def verify_hint(store: Path | str) -> str:
    """The command that checks the whole store (named in the error and warning lines)."""
    return f"swimrl-dns-verify {store}"


def _damage(arr: zarr.Array, err: Exception) -> str:
    if has_checksum(arr) and "checksum" in str(err):
        return f"fails its {CHECKSUM} checksum"
    reason = str(err).splitlines()[0] if str(err) else type(err).__name__
    return f"cannot be decoded ({reason})"


def read(arr: zarr.Array, store: Path | str, name: str, key=slice(None),
         advice: str | None = None) -> np.ndarray:
    """``arr[key]`` as a numpy array; :class:`IntegrityError` naming ``store`` and the array
    ``name`` if a chunk fails its checksum (or cannot be decoded), ending with ``advice``
    (default: the verify command)."""
    try:
        return np.asarray(arr[key])
    except ValueError as err:
        advice = advice or f"{verify_hint(store)} checks the whole store"
        raise IntegrityError(f"{store}: {name} {_damage(arr, err)}: the stored data is corrupt; "
                             f"{advice}") from err


def write(arr: zarr.Array, store: Path | str, name: str, key, value) -> None:
    """``arr[key] = value``: a partial write decodes the chunk first, so a damaged chunk is an
    :class:`IntegrityError` here too, never silently rewritten."""
    try:
        arr[key] = value
    except ValueError as err:
        raise IntegrityError(f"{store}: {name} at index {key} {_damage(arr, err)}: the stored "
                             f"data is corrupt; {verify_hint(store)} checks the whole "
                             "store") from err


def read_snapshots(arr: zarr.Array, store: Path | str, i0: int, i1: int,
                   name: str = "omega_hat") -> np.ndarray:
    """Snapshots ``i0..i1-1`` of ``arr`` (time first); on a damaged chunk,
    :class:`IntegrityError` naming ``store``, ``name`` and the first bad time index."""
    try:
        return np.asarray(arr[i0:i1])
    except ValueError as err:
        bad, first_err = i0, err
        for j in range(i0, i1):  # locate it: only on failure
            try:
                arr[j]
            except ValueError as e:
                bad, first_err = j, e
                break
        raise IntegrityError(
            f"{store}: {name} at time index {bad} {_damage(arr, first_err)}: the stored data "
            f"is corrupt; {verify_hint(store)} checks the whole store") from err


class SnapshotCheck:
    """The finite / rms-velocity check of packed snapshots ``(B, 2K+1, K+1)`` of a store
    (module docstring): ``check(c, i0)`` raises :class:`IntegrityError` naming ``store``, the
    first bad snapshot (time index ``i0 + b``), its rms velocity and the allowed range."""

    def __init__(self, n: int, length: float, u_rms: float, store: Path | str,
                 factor: float = RMS_FACTOR):
        K = dealias_cutoff(int(n))
        my = torch.arange(-K, K + 1, dtype=torch.float64)[:, None]
        mx = torch.arange(K + 1, dtype=torch.float64)[None, :]
        k2 = (2 * math.pi / float(length)) ** 2 * (mx**2 + my**2)
        self.weight = torch.where(mx == 0, 1.0, 2.0).expand_as(k2).contiguous()
        self.weight_inv_k2 = torch.where(k2 > 0, self.weight / k2.clamp_min(1e-300), 0.0)
        self.u_rms, self.factor, self.store = float(u_rms), float(factor), store
        self._dev: dict[torch.device, torch.Tensor] = {}

    @property
    def bounds(self) -> tuple[float, float] | None:
        r"""Allowed rms velocity $[u_\mathrm{rms}/F, F\,u_\mathrm{rms}]$; None without a finite
        ``u_rms`` attribute (then only finiteness is checked)."""
        if not math.isfinite(self.u_rms):
            return None
        return self.u_rms / self.factor, self.u_rms * self.factor

    def energy_enstrophy(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r"""$E = \sum w\,|c|^2/(2k^2)$, $Z = \sum w\,|c|^2/2$ per snapshot (float64)."""
        p2 = np.abs(c.astype(np.complex128)) ** 2
        return (0.5 * (p2 * self.weight_inv_k2.numpy()).sum((-2, -1)),
                0.5 * (p2 * self.weight.numpy()).sum((-2, -1)))

    def rms(self, c: torch.Tensor) -> torch.Tensor:
        r"""$u_\mathrm{rms}(t) = (\sum w\,|c|^2/k^2)^{1/2}$ per snapshot (NaN/inf if ``c`` is not
        finite), on the device of ``c``."""
        w = self._dev.get(c.device)
        if w is None:
            w = self._dev[c.device] = self.weight_inv_k2.to(c.device, c.real.dtype)
        return ((c.real**2 + c.imag**2) * w).sum((-2, -1)).sqrt()

    def problem(self, rms: float) -> str | None:
        """What is wrong with a snapshot of rms velocity ``rms`` (None: nothing)."""
        if not math.isfinite(rms):
            return "is not finite (NaN or infinite coefficients)"
        b = self.bounds
        if b is not None and not b[0] <= rms <= b[1]:
            return (f"has rms velocity {rms:.4g}, outside the allowed [{b[0]:.4g}, {b[1]:.4g}] "
                    f"(within a factor {self.factor:g} of the store's u_rms={self.u_rms:.4g})")
        return None

    def check(self, c: torch.Tensor, i0: int) -> None:
        """:class:`IntegrityError` unless every snapshot of ``c`` passes."""
        rms = self.rms(c).double().cpu().tolist()
        for b, r in enumerate(rms):
            what = self.problem(r)
            if what is not None:
                raise IntegrityError(
                    f"{self.store}: snapshot at time index {i0 + b} {what}: the snapshot or the "
                    f"store's attributes are corrupt; {verify_hint(self.store)} checks the "
                    "whole store")
