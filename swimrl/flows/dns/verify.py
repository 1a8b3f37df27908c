r"""A whole stored DNS run checked (``swimrl-dns-verify STORE``): :func:`verify_store`.

Checks, one line each (``ok``, ``FAIL``, ``unverified`` or ``skipped``):

* **checksums**: every chunk of every array (``omega_hat``, ``time``, ``ky``, ``kx``,
  ``diagnostics/*``, ``checkpoint/*``) is read and its crc32c checksum checked; arrays written
  without the codec (stores older than the checksums) are ``unverified: no checksums``;
* **time axis**: the committed times are finite, increasing and ``dt_store`` apart
  (relative :data:`TIME_RTOL`);
* **finite** and **rms velocity**: each snapshot's coefficients are finite and its rms
  velocity is within a factor :data:`~swimrl.flows.dns.integrity.RMS_FACTOR` of the store's
  ``u_rms`` (:class:`~swimrl.flows.dns.integrity.SnapshotCheck`);
* **energy / enstrophy vs diagnostics**: $E = \sum w\,|c|^2/(2k^2)$ and
  $Z = \sum w\,|c|^2/2$ of each snapshot against the run's own diagnostics series. The solver
  samples its diagnostics every ``diag_every`` steps and stores a snapshot every
  ``store_every`` steps, so every ``lcm/store_every``-th snapshot (every 25th at $512^2$)
  falls on a diagnostics sample: those must agree to :data:`ENERGY_RTOL` = 1e-4 relative
  (they differ only by the float32 rounding of the stored coefficients, ~1e-7; measured
  $\le$ 1e-8 on a $128^2$ run). Only when no snapshot
  falls on a sample are the series interpolated linearly to the snapshot times, with
  :data:`INTERP_RTOL` = 0.25 (the white-in-time forcing makes $E(t)$ rough: linear
  interpolation over samples $0.7\,\tau_K$ apart misses by up to 8 %, 2 % rms, on that run);
* **scales**: the ``u_rms`` and ``tau_k`` attributes equal the snapshots' own averages
  $\langle\boldsymbol u\cdot\boldsymbol u\rangle^{1/2}$, $\langle 2Z\rangle^{-1/2}$
  (:data:`ENERGY_RTOL`), for stores whose attributes say they
  were measured over exactly the stored snapshots (``s_count = n_written``).

The verdict is ``clean`` when no check failed (``clean, unverified: no checksums`` for an old
store that passes the other checks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import zarr

from swimrl.flows.dns.integrity import CHECKSUM, RMS_FACTOR, SnapshotCheck, has_checksum

#: Relative tolerance of energy/enstrophy at snapshots that fall on diagnostics samples, and
#: of the ``u_rms``/``tau_k`` attributes against the snapshots' averages.
ENERGY_RTOL = 1e-4
#: Relative tolerance when the diagnostics must be interpolated to the snapshot times.
INTERP_RTOL = 0.25
#: Relative tolerance of the spacing of the stored times against ``dt_store``.
TIME_RTOL = 1e-6
#: Snapshots read at a time (rounded to whole chunks).
BATCH = 64
STATUSES = ("ok", "FAIL", "unverified", "skipped")


@dataclass(frozen=True)
class Check:
    """One check of a store: ``status`` one of :data:`STATUSES`, ``detail`` one line."""

    name: str
    status: str
    detail: str

    def line(self) -> str:
        return f"  {self.status:<10} {self.name}: {self.detail}"


@dataclass
class StoreReport:
    """The checks of one store and its verdict."""

    path: Path
    header: str = ""
    checks: list[Check] = field(default_factory=list)

    def add(self, name: str, status: str, detail: str) -> None:
        self.checks.append(Check(name, status, detail))

    @property
    def problems(self) -> list[Check]:
        return [c for c in self.checks if c.status == "FAIL"]

    @property
    def clean(self) -> bool:
        return not self.problems

    @property
    def verdict(self) -> str:
        if self.problems:
            n = len(self.problems)
            return f"{n} problem{'s' if n > 1 else ''} ({', '.join(c.name for c in self.problems)})"
        if any(c.status == "unverified" for c in self.checks):
            return "clean, unverified: no checksums"
        return "clean"

    def lines(self) -> list[str]:
        return [f"{self.path}: {self.header}", *(c.line() for c in self.checks),
                f"  verdict: {self.verdict}"]


def _fmt_indices(idx: list[int], limit: int = 5) -> str:
    shown = ", ".join(str(i) for i in idx[:limit])
    return shown + (f", ... ({len(idx)} in all)" if len(idx) > limit else "")


def _bad_rows(arr: zarr.Array) -> list[tuple[int, int]]:
    """Index ranges (along the first axis, one per chunk row) that fail to decode."""
    bad, step = [], max(1, int(arr.chunks[0])) if arr.ndim else 1
    if arr.ndim == 0:
        try:
            arr[...]
        except ValueError:
            bad.append((0, 0))
        return bad
    for s in range(0, arr.shape[0], step):
        e = min(s + step, arr.shape[0])
        try:
            arr[s:e]
        except ValueError:
            bad.append((s, e))
    return bad


def _array_names(g: zarr.Group) -> list[str]:
    return sorted(name for name, obj in g.members(max_depth=None) if isinstance(obj, zarr.Array))


def _snapshots(g: zarr.Group, n_written: int, check: SnapshotCheck
               ) -> tuple[np.ndarray, np.ndarray, list[int], int]:
    """``E``, ``Z`` of every stored snapshot (NaN where unreadable), the unreadable indices
    and the number of chunks read (reading every chunk of ``omega_hat``)."""
    arr = g["omega_hat"]
    total = arr.shape[0]
    ct = max(1, int(arr.chunks[0]))
    batch = max(ct, BATCH // ct * ct)
    E, Z = np.full(total, np.nan), np.full(total, np.nan)
    bad: list[int] = []
    for s in range(0, total, batch):
        e = min(s + batch, total)
        try:
            blocks = [(s, np.asarray(arr[s:e]))]
        except ValueError:
            blocks = []
            for cs in range(s, e, ct):
                ce = min(cs + ct, e)
                try:
                    blocks.append((cs, np.asarray(arr[cs:ce])))
                except ValueError:
                    bad.extend(range(cs, ce))
        for start, c in blocks:
            E[start:start + len(c)], Z[start:start + len(c)] = check.energy_enstrophy(c)
    return E[:n_written], Z[:n_written], bad, -(-total // ct)


def verify_store(path: str | Path) -> StoreReport:
    """Every check of the module docstring on the store at ``path`` (never raises for a
    damaged store: what cannot be read is a failed check)."""
    path = Path(path)
    rep = StoreReport(path)
    try:
        g = zarr.open_group(str(path), mode="r", use_consolidated=False)
        attrs = dict(g.attrs)
        n, n_written = int(attrs["n"]), int(attrs["n_written"])
        g["omega_hat"]
    except Exception as err:  # noqa: BLE001 - whatever it is, the store cannot be opened
        rep.header = "cannot be opened"
        rep.add("store", "FAIL", f"not a readable swimrl DNS store ({type(err).__name__}: "
                                 f"{str(err).splitlines()[0] if str(err) else ''})")
        return rep
    u_rms = float(attrs.get("u_rms", math.nan))
    rep.header = (f"status {attrs.get('status')}, {n_written} snapshots of {n}^2, "
                  f"u_rms {u_rms:.4g}, tau_k {float(attrs.get('tau_k', math.nan)):.4g}")
    check = SnapshotCheck(n, float(attrs.get("length", 2 * math.pi)), u_rms, path)

    # -- checksums (omega_hat is read below, with the snapshot checks) ----------------------
    names = _array_names(g)
    with_sum = [k for k in names if has_checksum(g[k])]
    without = [k for k in names if k not in with_sum]
    damaged: list[str] = []
    chunks = 0
    for name in names:  # the arrays without checksums too: they must at least decode
        if name == "omega_hat":
            continue
        arr = g[name]
        chunks += arr.nchunks if name in with_sum else 0
        try:
            np.asarray(arr[...])
        except ValueError:
            rows = ", ".join(f"{s}..{e - 1}" for s, e in _bad_rows(arr))
            damaged.append(f"{name} at index {rows}")
    E, Z, bad_snaps, omega_chunks = _snapshots(g, n_written, check)
    chunks += omega_chunks if "omega_hat" in with_sum else 0
    if bad_snaps:
        damaged.insert(0, f"omega_hat at time index {_fmt_indices(bad_snaps)}")
    if damaged:
        how = f"{CHECKSUM} checksum mismatch" if with_sum else "cannot be decoded"
        rep.add("checksums", "FAIL", f"corrupt chunks ({how}): {'; '.join(damaged)}")
    elif not with_sum:
        rep.add("checksums", "unverified", f"unverified: no checksums ({len(without)} arrays "
                                           f"written without {CHECKSUM}, before swimrl stored "
                                           "them)")
    elif without:
        status = "unverified" if "omega_hat" in without else "ok"
        rep.add("checksums", status, f"{chunks} chunks of {len(with_sum)} arrays verified "
                                     f"({CHECKSUM}); unverified: no checksums on "
                                     f"{', '.join(without)}")
    else:
        rep.add("checksums", "ok", f"{chunks} chunks of {len(with_sum)} arrays verified "
                                   f"({CHECKSUM})")

    # -- time axis ---------------------------------------------------------------------------
    try:
        t = np.asarray(g["time"][:n_written])
    except (ValueError, KeyError) as err:
        t = None
        rep.add("time axis", "FAIL", f"cannot be read ({type(err).__name__})")
    if t is not None:
        rep.checks.append(_time_check(t, attrs))

    # -- finite, rms velocity ------------------------------------------------------------------
    readable = np.ones(n_written, dtype=bool)
    readable[[i for i in bad_snaps if i < n_written]] = False
    rms = np.sqrt(2 * E)
    nonfinite = [int(i) for i in np.flatnonzero(readable & ~np.isfinite(rms))]
    skipped = f" ({n_written - int(readable.sum())} unreadable, not checked)" if (
        not readable.all()) else ""
    if nonfinite:
        rep.add("finite", "FAIL", f"snapshot(s) at time index {_fmt_indices(nonfinite)} not "
                                  f"finite (NaN or infinite coefficients){skipped}")
    else:
        rep.add("finite", "ok", f"{int(readable.sum())} snapshots{skipped}")
    ok = readable & np.isfinite(rms)
    b = check.bounds
    if b is None:
        rep.add("rms velocity", "FAIL", f"no finite u_rms attribute ({attrs.get('u_rms')!r})")
    elif ok.any():
        out = [int(i) for i in np.flatnonzero(ok & ((rms < b[0]) | (rms > b[1])))]
        ratio = rms[ok] / u_rms
        span = (f"u_rms(t)/u_rms in [{ratio.min():.3g}, {ratio.max():.3g}] (allowed "
                f"[{1 / RMS_FACTOR:.3g}, {RMS_FACTOR:g}])")
        if out:
            rep.add("rms velocity", "FAIL", f"snapshot(s) at time index {_fmt_indices(out)} "
                                            f"outside [{b[0]:.4g}, {b[1]:.4g}]: {span}")
        else:
            rep.add("rms velocity", "ok", f"{int(ok.sum())} snapshots, {span}")
    else:
        rep.add("rms velocity", "skipped", "no readable finite snapshot")

    # -- energy / enstrophy against the diagnostics, scales ------------------------------------
    rep.checks.extend(_diagnostics_checks(g, attrs, t, E, Z, ok))
    rep.checks.append(_scales_check(attrs, E, Z, ok, n_written))
    return rep


def _time_check(t: np.ndarray, attrs: dict) -> Check:
    if len(t) == 0:
        return Check("time axis", "skipped", "no snapshots")
    if not np.isfinite(t).all():
        return Check("time axis", "FAIL", "non-finite times")
    dt = np.diff(t)
    if (dt <= 0).any():
        return Check("time axis", "FAIL", f"not increasing at index {int(np.argmin(dt > 0)) + 1}")
    dt_store = float(attrs.get("dt_store", math.nan))
    where = f"{len(t)} times, t = {t[0]:.6g} .. {t[-1]:.6g}"
    if len(dt) and math.isfinite(dt_store):
        dev = float(np.max(np.abs(dt / dt_store - 1)))
        if dev > TIME_RTOL:
            return Check("time axis", "FAIL", f"{where}: spacing {dt.min():.6g} .. {dt.max():.6g}"
                                              f" but dt_store = {dt_store:.6g}")
        return Check("time axis", "ok", f"{where}, spacing dt_store = {dt_store:.6g}")
    return Check("time axis", "ok", where)


def _diagnostics_checks(g: zarr.Group, attrs: dict, t: np.ndarray | None, E: np.ndarray,
                        Z: np.ndarray, ok: np.ndarray) -> list[Check]:
    """Energy and enstrophy of the snapshots against the diagnostics (module docstring)."""
    names = {"energy": "energy vs diagnostics", "enstrophy": "enstrophy vs diagnostics"}
    mine = {"energy": E, "enstrophy": Z}
    if t is None or not ok.any():
        return [Check(nm, "skipped", "no readable snapshots or times") for nm in names.values()]
    if "diagnostics" not in g or "t" not in g["diagnostics"]:
        return [Check(nm, "skipped", "no diagnostics stored") for nm in names.values()]
    d = g["diagnostics"]
    nd = int(attrs.get("n_diag", d["t"].shape[0]))
    try:
        td = np.asarray(d["t"][:nd])
    except ValueError:
        return [Check(nm, "FAIL", "diagnostics/t cannot be read (corrupt chunk)")
                for nm in names.values()]
    if len(td) == 0:
        return [Check(nm, "skipped", "no diagnostics samples") for nm in names.values()]
    order = np.argsort(td, kind="stable")
    td = td[order]
    tol_t = 1e-3 * float(attrs.get("dt", 0.0)) or 1e-9 * max(1.0, float(np.abs(td).max()))
    j = np.clip(np.searchsorted(td, t), 1, max(1, len(td) - 1))
    j = np.minimum(j, len(td) - 1)
    near = np.where(np.abs(td[j - 1] - t) < np.abs(td[j] - t), j - 1, j)
    matched = ok & (np.abs(td[near] - t) <= tol_t)
    inside = ok & (t >= td[0]) & (t <= td[-1])
    if matched.any():
        rtol, how = ENERGY_RTOL, f"{int(matched.sum())} snapshots at diagnostics times"
    elif inside.any():
        rtol, how = INTERP_RTOL, f"{int(inside.sum())} snapshots, diagnostics interpolated"
    else:
        return [Check(nm, "skipped", "no diagnostics over the stored times")
                for nm in names.values()]
    out = []
    for key, nm in names.items():
        try:
            series = np.asarray(d[key][:nd])[order]
        except (ValueError, KeyError) as err:
            out.append(Check(nm, "FAIL", f"diagnostics/{key} cannot be read "
                                         f"({type(err).__name__})"))
            continue
        if matched.any():
            a, b = mine[key][matched], series[near[matched]]
        else:
            a, b = mine[key][inside], np.interp(t[inside], td, series)
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(a / b - 1)
        worst = float(np.nanmax(rel)) if np.isfinite(rel).any() else math.inf
        bad = int((~(rel <= rtol)).sum())
        detail = f"{how}, max relative difference {worst:.2g} (tolerance {rtol:g})"
        out.append(Check(nm, "FAIL" if bad else "ok",
                         detail + (f"; {bad} beyond it" if bad else "")))
    return out


def _scales_check(attrs: dict, E: np.ndarray, Z: np.ndarray, ok: np.ndarray,
                  n_written: int) -> Check:
    if int(attrs.get("s_count", -1)) != n_written or n_written == 0:
        return Check("scales", "skipped", "u_rms, tau_k not measured over exactly the stored "
                                          "snapshots (no s_count = n_written)")
    if not ok.all():
        return Check("scales", "skipped", "some snapshots unreadable or not finite")
    mine = {"u_rms": math.sqrt(float(np.mean(2 * E))), "tau_k": float(np.mean(2 * Z)) ** -0.5}
    rel = {k: abs(float(attrs.get(k, math.nan)) / v - 1) for k, v in mine.items()}
    detail = ", ".join(f"{k} {float(attrs.get(k, math.nan)):.6g} vs {mine[k]:.6g} from the "
                       f"snapshots (rel. {rel[k]:.1g})" for k in mine)
    bad = [k for k, r in rel.items() if not r <= ENERGY_RTOL]
    return Check("scales", "FAIL" if bad else "ok", f"{detail}; tolerance {ENERGY_RTOL:g}")
