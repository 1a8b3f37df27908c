"""docs/reproduction.md's verdict table against the committed records it cites.

Every row of the verdict tables (``| # | the paper | swimrl (± error; sample) | verdict |``)
has an entry in :data:`ROWS`, and every entry a row; a row of the page without one fails, so
does an entry whose row is gone. An entry says what the row's ``Record:`` clause is:

* ``json``: the row cites committed records under ``docs/results/`` (a JSON or CSV file, a
  directory, or a Markdown table or README, which stands for the JSON and CSV files of its
  directory; a table under ``docs/figures/`` stands for the record it is written from,
  :data:`FIGURE_TABLES`). Every cited file must exist, and each :class:`Check` recomputes a
  quoted number from those records only (reading a file outside the cited ones fails), rounded
  as the page rounds it, and compares the text;
* ``none``, ``figure only``, ``no committed record``: the page says so, and there are no
  checks;
* ``npz``, ``test``, ``doc``: the record is not JSON or CSV (a ``.npz`` array file, a unit
  test, a docs page); the cited file must exist (the test: with the named test function).

Numbers the page quotes without a record behind them (the paper's values, parameters of a
measurement, readings of a curve, values of a record that is not JSON or CSV) are listed per
row in ``unrecorded`` with the reason, and each must appear in its row. Then no decimal
number, percentage or ``N SEM`` of a row's measurement (its third cell before ``Record:``)
may be left that is neither checked nor listed: a number added to the page without a record
check fails until it gets one or is listed with its reason. Ku values, sizes written as
``NeK`` (``8e7``, the page's one notation for powers of ten) or ``15.36M`` and code spans
are not counted (:data:`NOT_COUNTED`).

The verdict cells (fourth column) are not scanned for coverage; a :class:`Check` may still
quote them (``where="verdict"``). Reads JSON and CSV only; well under a second.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
RESULTS = DOCS / "results"
PAGE = DOCS / "reproduction.md"
HEADER = "| # | the paper | swimrl (± error; sample) | verdict |"
MINUS = "\u2212"

#: The tables under docs/figures/ that rows cite, and the record each is written from.
FIGURE_TABLES = {
    "figures/ablation_signals.md": "results/figures/ablation.json",
    "figures/dnsFlow_transfer.md": "results/dns_transfer",
    "figures/dnsFlow_replay.md": "results/dns_figures/record.npz",
}

KUS = ("ku0.1", "ku1", "ku10", "ku1e7")
KU_VALUE = r"(?:0\.1|1e7|10|1)(?![\d.e])"
#: Not counted as quoted numbers: Ku values, 1e8-style and 15.36M-style sizes, code spans (file
#: and run names).
NOT_COUNTED = [
    re.compile(r"`[^`]*`"),
    re.compile(rf"Ku\s*(?:=|≤|≥|<|>)\s*{KU_VALUE}(?:(?:\s*,\s*|\s+and\s+|\s*-\s*){KU_VALUE})*"),
    re.compile(r"\d+(?:\.\d+)?e[−-]?\d+"),
    re.compile(r"\d+(?:\.\d+)?M\b"),
]
#: What counts as a quoted number: a decimal, a percentage, a multiple of the SEM.
NUMBER = re.compile(r"[+−-]?\d+(?:\.\d+)?\s?(?:%|SEM\b)|[+−-]?\d+\.\d+")
LINK = re.compile(r"\[[^\]]*\]\(([^)\s#]+)(?:#[^)]*)?\)")


# -- the page ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Row:
    section: str
    number: int
    paper: str
    ours: str
    verdict: str

    @property
    def measure(self) -> str:
        """The third cell before its ``Record:`` clause."""
        return self.ours.split("Record:", 1)[0]

    @property
    def record(self) -> str:
        parts = self.ours.split("Record:", 1)
        return parts[1].strip() if len(parts) == 2 else ""


@cache
def verdict_rows() -> dict[int, Row]:
    rows: dict[int, Row] = {}
    in_table, section = False, ""
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        if line.startswith("## "):
            section = line[3:].strip()
        if line.strip() == HEADER:
            in_table = True
            continue
        if not in_table or line.startswith("|---"):
            continue
        if not line.startswith("|"):
            in_table = False
            continue
        cells = [c.strip() for c in line.strip().strip("|").split(" | ")]
        assert len(cells) == 4, f"a verdict row without 4 cells: {line[:120]}"
        number = int(cells[0])
        assert number not in rows, f"row {number} twice"
        rows[number] = Row(section, number, *cells[1:])
    return rows


def cited_targets(row: Row) -> list[Path]:
    """The files and directories the row's Record clause links to (relative to docs/)."""
    return [DOCS / t for t in LINK.findall(row.record)]


def record_roots(row: Row) -> list[Path]:
    """What the row's records are: cited JSON/CSV files and directories under docs/results;
    a cited Markdown file or README there stands for its directory; a cited table under
    docs/figures for the record it is written from."""
    roots = []
    for target in cited_targets(row):
        rel = target.relative_to(DOCS).as_posix()
        if rel in FIGURE_TABLES:
            target = DOCS / FIGURE_TABLES[rel]
        if RESULTS not in target.parents:
            continue
        if target.is_dir() or target.suffix in (".json", ".csv", ".npz"):
            roots.append(target)
        else:
            roots.append(target.parent)
    return roots


# -- reading records (tracked: a check may read only its row's records) -------------------------
_READ: list[Path] = []


@cache
def _json(path: Path):
    return json.loads(path.read_text(encoding="utf-8"))


@cache
def _csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def rec(rel: str):
    """The JSON record ``docs/results/<rel>`` (the read is tracked)."""
    path = RESULTS / rel
    _READ.append(path)
    return _json(path)


def curve(rel: str, column: str = "eval/R_hat") -> tuple[np.ndarray, np.ndarray]:
    """``(frames, column)`` of the rows of ``docs/results/<rel>`` (a curves.csv) where
    ``column`` is set (the read is tracked)."""
    path = RESULTS / rel
    _READ.append(path)
    rows = [r for r in _csv(path) if r.get(column)]
    return (np.array([float(r["frames"]) for r in rows]),
            np.array([float(r[column]) for r in rows]))


def cmp_rows(rel: str) -> dict[str, dict]:
    """The rows of a comparison.json by label: ``sto``, ``naive``, ``policy0``, ``policy1``,
    ... (policy rows in order) and every row under its own label."""
    out: dict[str, dict] = {}
    k = 0
    for r in rec(rel)["rows"]:
        out[r["label"]] = r
        if r["label"] == "sto":
            out["sto"] = r
        elif r["label"].startswith("naive"):
            out["naive"] = r
        elif r["label"].startswith("policy("):
            out[f"policy{k}"] = r
            k += 1
    return out


def protocol(ku: str) -> dict[str, dict]:
    return cmp_rows(f"paper_protocol/{ku}/comparison.json")


def seeds(rows: dict[str, dict]) -> list[dict]:
    return [rows[f"policy{k}"] for k in range(3)]


def paired(a, b) -> tuple[float, float]:
    """``<a>/<b>`` over paired flows and its delta-method SEM (swimrl.evaluation.statistics)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    r = float(a.mean() / b.mean())
    return r, float((a - r * b).std(ddof=1) / math.sqrt(a.size) / b.mean())


# -- formatting as the page writes numbers --------------------------------------------------------
def num(v: float, d: int = 3, sign: bool = False) -> str:
    s = f"{v:+.{d}f}" if sign else f"{v:.{d}f}"
    return s.replace("-", MINUS)


def pm(v: float, e: float, d: int = 3) -> str:
    return f"{num(v, d)} ± {num(e, d)}"


def nums(values, d: int = 3, sep: str = ", ") -> str:
    return sep.join(num(v, d) for v in values)


def span(values, d: int = 3) -> str:
    return f"{num(min(values), d)}-{num(max(values), d)}"


def pct(v: float, d: int = 0, sign: bool = False) -> str:
    return f"{num(100 * v, d, sign)} %"


def sci(v: float, d: int = 0) -> str:
    """``3e-3``, ``1e8``, ``4.1e7``: the page's short scientific form."""
    mantissa, exponent = f"{v:.{d}e}".split("e")
    return f"{mantissa}e{int(exponent)}"


# -- the rows ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Check:
    """``quote`` appears in the row (``where``: ``ours`` or ``verdict``) and ``compute()``,
    from the row's records, gives the same text."""

    quote: str
    compute: Callable[[], str]
    where: str = "ours"


@dataclass(frozen=True)
class Spec:
    record: str  # json | none | figure only | no committed record | npz | test | doc
    checks: tuple[Check, ...] = ()
    unrecorded: dict[str, str] = field(default_factory=dict)


def C(quote: str, compute: Callable[[], str], where: str = "ours") -> Check:
    return Check(quote, compute, where)


PAPER = "the paper's value"
SETUP = "a parameter of the measurement, not a result"


def _sto_means() -> str:
    return ", ".join(pm(protocol(k)["sto"]["R_hat_mean"], protocol(k)["sto"]["R_hat_sem"])
                     for k in KUS)


def _naive_means() -> str:
    return ", ".join(pm(protocol(k)["naive"]["R_hat_mean"], protocol(k)["naive"]["R_hat_sem"])
                     for k in KUS)


def _ratios(ku: str, sem_digits: int | None) -> str:
    s = seeds(protocol(ku))
    text = nums([r["ratio_to_first"] for r in s], sep=" / ") + " × STO"
    if sem_digits is not None:
        text += f" (± {num(max(r['ratio_sem'] for r in s), sem_digits)}"
    return text


def _best_baseline(ku: str) -> float:
    p = protocol(ku)
    best = max(p["naive"]["R_hat_mean"], p["sto"]["R_hat_mean"])
    return float(np.mean([r["R_hat_mean"] / best for r in seeds(p)]))


def _smart_naive_1e7() -> str:
    p = protocol("ku1e7")
    return " / ".join(pm(*paired(r["per_flow"], p["naive"]["per_flow"])) for r in seeds(p))


def _single_flow() -> str:
    ev = rec("figures/smartPerformance.json")["evaluations"]
    label = {"ku0.1": "Ku = 0.1", "ku1": "Ku = 1", "ku10": "Ku = 10", "ku1e7": "Ku = 1e7"}
    return ", ".join(
        " / ".join(num(ev[k]["derived"]["mean"][n]) for n in ("smart", "STO", "naive"))
        + f" ({label[k]})" for k in KUS)


def _per_seed(fig: str, key: str) -> list[float]:
    d = rec(f"figures/{fig}.json")["derived"]["per_seed"]
    return [d[s][key] for s in "012"]


def _ku_inf_policy() -> str:
    smart = rec("figures/kuInf.json")["evaluations"]["ku1e7_seed0"]["actors"]["smart"]
    return f"`{smart.removeprefix('docs/results/')}`"


def _shipped_ku1e7_seed() -> str:
    shipped = rec("figures/smartPerformance.json")["evaluations"]["ku1e7"]["files"][
        "pretrained/ku1e7"]
    ev = rec("figures/kuInf.json")["evaluations"]
    match = [s for s in "012" for path, sha in ev[f"ku1e7_seed{s}"]["files"].items()
             if sha == shipped and path.endswith(f"ku1e7_seed{s}/policy.pt")]
    assert len(match) == 1, match
    return f"which is the protocol's seed {match[0]}"


def _ku_inf_sizes() -> str:
    r = rec("figures/kuInf.json")
    e = r["evaluations"]["ku1e7_seed0"]
    n = e["counts"]["decisions"]
    assert n == e["setup"]["n_flows"] * e["setup"]["n_swimmers"] * r["params"]["n_decisions"]
    return (f"{e['setup']['n_flows']} frozen flows × {e['setup']['n_swimmers']} swimmers, "
            f"{sci(n)} decisions")


def _map_corr(ku: str, maps=("n_theta", "omega")) -> list[float]:
    m = rec("figures/ku_pattern.json")["derived"][ku]["map_correlation"]
    return [v for name in maps for v in m[name].values()]


def _snn_tail() -> str:
    ev = rec("figures/kuInf.json")["evaluations"]
    tails = {round(ev[f"ku1e7_seed{s}"]["derived"]["snn"][k] / 1e5)
             for s in "012" for k in ("n_low", "n_high")}
    assert len(tails) == 1, tails
    return f"{tails.pop()}e5 decisions in the tail"


def _corr_range(ku: str) -> float:
    c = [rec("figures/ku_pattern.json")["derived"][ku]["per_seed"][s]["corr_Lambda_ntheta_Snp"]
         for s in "012"]
    return max(c) - min(c)


def _held_out(sig: str) -> list[dict]:
    return [cmp_rows(f"ablation_1e8/held_out/{sig}_seed{s}/comparison.json")["policy0"]
            for s in "012"]


def _held_out_naive(sig: str) -> list[float]:
    out = []
    for s in "012":
        r = cmp_rows(f"ablation_1e8/held_out/{sig}_seed{s}/comparison.json")
        out.append(r["policy0"]["R_hat_mean"] / r["naive"]["R_hat_mean"])
    return out


def _signal_set(signals: list[str]) -> dict:
    sets = rec("figures/ablation.json")["derived"]["signal_sets"]
    (s,) = [s for s in sets if s["signals"] == signals]
    return s


def mean_std(values, d: int = 3) -> str:
    """``mean ± std`` (ddof = 1) over seeds."""
    return pm(float(np.mean(values)), float(np.std(values, ddof=1)), d)


def _early(sig: str, d: int = 2) -> str:
    """Mean ± std over seeds of smart / STO of the 15.36M-frame runs of ``sig``."""
    return mean_std([cmp_rows(f"ablation/{sig}_seed{s}/comparison.json")["policy0"]
                     ["ratio_to_first"] for s in "012"], d)


def _below_sto_sems(sig: str) -> list[float]:
    return [(1 - r["ratio_to_first"]) / r["ratio_sem"] for r in _held_out(sig)]


def _minimal(ku: str, ratio: str) -> dict:
    return rec("figures/ablation.json")["derived"]["minimal"][ku]["ratio"][ratio]


def _minimal_sems(ku: str) -> float:
    r = _minimal(ku, "minimal/smart")
    return (1 - r["value"]) / r["sem"]


def _fit(ku: str) -> dict:
    return rec(f"minimal_fits/{ku}/fit.json")


def _coeff_change(c: str) -> str:
    a, b = _fit("ku10"), _fit("ku1e7")
    change = b["coefficients"][c] / a["coefficients"][c] - 1
    sems = abs(b["coefficients"][c] - a["coefficients"][c]) / math.hypot(
        a["flow_sem"][c], b["flow_sem"][c])
    return f"{c} {pct(change)}, {sems:.0f} SEM"


def _dns() -> dict[str, list[list[float]]]:
    """Per strategy label, the per-flow R_hat of each held-out realisation (seed2-5)."""
    out: dict[str, list[list[float]]] = {}
    for s in (2, 3, 4, 5):
        for r in rec(f"dns_transfer/seed{s}/comparison.json")["rows"]:
            out.setdefault(r["label"], []).append(r["per_flow"])
    return out


def _dns_ratio(label: str) -> tuple[float, float, list[float]]:
    """The row ``label``'s paired ratio to STO over all 16 flows ± SEM, and its ratio on each
    realisation (of the means over its 4 flows)."""
    d = _dns()
    r, e = paired(np.concatenate(d[label]), np.concatenate(d["sto"]))
    per = [np.mean(a) / np.mean(b) for a, b in zip(d[label], d["sto"], strict=True)]
    return r, e, per


def policy(name: str) -> str:
    return f"policy({name})"


DNS_RUNS = tuple(policy(p) for p in ("pretrained/dns", "docs/results/dns_train/seed1/policy.pt",
                                     "docs/results/dns_train/seed2/policy.pt"))


def _ku10_over_dns() -> tuple[list[float], list[float]]:
    """The transferred Ku = 10 policy / each DNS-trained run (all flows), and per realisation
    the mean over runs."""
    d = _dns()
    ku10 = d[policy("pretrained/ku10")]
    pooled = [np.mean(np.concatenate(ku10)) / np.mean(np.concatenate(d[r])) for r in DNS_RUNS]
    per = [np.mean([np.mean(ku10[i]) / np.mean(d[r][i]) for r in DNS_RUNS])
           for i in range(len(ku10))]
    return pooled, per


def _reading(name: str) -> dict[str, dict]:
    return cmp_rows(f"ku1e7_readings/{name}/comparison.json")


def _box(label: str, key: str) -> str:
    a, b = _reading("default")[key], _reading("box_L20")[key]
    return (f"{label} {pm(a['R_hat_mean'], a['R_hat_sem'])} → "
            f"{pm(b['R_hat_mean'], b['R_hat_sem'])}")


def _runs_config() -> list[dict]:
    return [rec(f"paper_runs/{k}_seed{s}/metrics.json")["config"] for k in KUS for s in "012"]


def _one(values) -> object:
    values = set(values)
    assert len(values) == 1, values
    return values.pop()


def _min_std() -> str:
    by_ku = {k: _one(rec(f"paper_runs/{k}_seed{s}/metrics.json")["config"]["model"]["min_std"]
                     for s in "012") for k in KUS}
    assert by_ku["ku0.1"] == by_ku["ku1"] == by_ku["ku10"]
    return f"σ ≥ {by_ku['ku10']:g} (Ku ≤ 10) or ≥ {by_ku['ku1e7']:g} (1e7)"


def _curve_last(ku: str) -> list[float]:
    return [curve(f"paper_runs/{ku}_seed{s}/curves.csv")[1][-1] for s in "012"]


def _second_half(ku: str) -> list[float]:
    out = []
    for s in "012":
        f, y = curve(f"paper_runs/{ku}_seed{s}/curves.csv")
        out.append(y[-1] - y[int(np.argmin(abs(f - f[-1] / 2)))])
    return out


def _seed_spread() -> tuple[float, float]:
    spreads = []
    for k in ("ku0.1", "ku1", "ku10"):
        m = [r["R_hat_mean"] for r in seeds(protocol(k))]
        spreads.append((max(m) - min(m), (max(m) - min(m)) / min(m)))
    return max(s[0] for s in spreads), max(s[1] for s in spreads)


def _noise() -> dict:
    return rec("figures/robustness-noise.json")


def _noise_change() -> str:
    """Smart's change from D_r = 0, ``<a - b> / <b>`` over the paired flows, ± the SEM of the
    per-flow differences over ``<b>`` (the page's convention for this row and its table)."""
    ev = _noise()["evaluations"]
    b = np.asarray(ev["rot_diffusion=0"]["per_flow"]["smart"])
    out = []
    for x in ("0.0001", "0.001", "0.005", "0.01", "0.1"):
        d = np.asarray(ev[f"rot_diffusion={x}"]["per_flow"]["smart"]) - b
        change, sem = d.mean() / b.mean(), d.std(ddof=1) / math.sqrt(d.size) / b.mean()
        out.append(f"{num(100 * change, 1, sign=True)} ± {num(100 * sem, 1)} %")
    return ", ".join(out)


def _robust(sweep: str) -> dict:
    return rec("figures/robustness.json")["derived"][sweep]


def _robust_ev(key: str) -> dict:
    return rec("figures/robustness.json")["evaluations"][key]["per_flow"]


def _robust_paired(a: str, b: str) -> str:
    return " / ".join(pm(*paired(_robust_ev(f"update_interval={x}")[a],
                                 _robust_ev(f"update_interval={x}")[b])) for x in ("1", "2"))


def _diffusive() -> str:
    d = _robust("duration")
    at200 = d["mean"]["naive"][d["x"].index(200.0)]
    return nums([at200 * math.sqrt(200.0 / t) for t in d["x"]])


# -- docs/results/referee_items: the naive scan, v_s = 0.1-4, the box at Ku = 10, (Δθ)² ---------
RI = "referee_items"


def _lam(v: float) -> str:
    """A shape factor as the page writes it: ``0.98``, ``−0.98``, ``0``."""
    return f"{v:g}".replace("-", MINUS)


def _scan(ku: str) -> dict[float, dict]:
    """The naive scan's rows at ``ku`` by Λ (``naive(+0.98)`` → 0.98)."""
    rows = rec(f"{RI}/naive_scan/{ku}/comparison.json")["rows"]
    return {float(r["label"].removeprefix("naive(").removesuffix(")")): r for r in rows}


def _scan_pm(ku: str, lam: float) -> str:
    r = _scan(ku)[lam]
    return pm(r["R_hat_mean"], r["R_hat_sem"])


def _scan_best(ku: str) -> float:
    rows = _scan(ku)
    return max(rows, key=lambda k: rows[k]["R_hat_mean"])


def _diff(a, b) -> tuple[float, float]:
    """The mean paired per-flow difference ``a - b`` ± its SEM."""
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    return float(d.mean()), float(d.std(ddof=1) / math.sqrt(d.size))


def _scan_diff(ku: str, a: float, b: float) -> tuple[float, float]:
    rows = _scan(ku)
    return _diff(rows[a]["per_flow"], rows[b]["per_flow"])


def _scan_tied(ku: str) -> list[float]:
    """The Λ whose paired difference to the best is within 2 SEM (the best included)."""
    best = _scan_best(ku)
    return sorted(lam for lam in _scan(ku)
                  if abs(_scan_diff(ku, lam, best)[0]) <= 2 * _scan_diff(ku, lam, best)[1])


def _scan_rising(ku: str) -> bool:
    rows = _scan(ku)
    means = [rows[k]["R_hat_mean"] for k in sorted(rows)]
    return bool(np.all(np.diff(means) > 0))


def _scan_top() -> str:
    """Ku = 10 and 1e7: the rise, the best and its lead over the next shape."""
    kus = ("ku10", "ku1e7")
    assert all(_scan_rising(k) for k in kus)
    (best,) = {_scan_best(k) for k in kus}
    (nxt,) = {sorted(_scan(k), key=lambda v: _scan(k)[v]["R_hat_mean"])[-2] for k in kus}
    d10, d7 = _scan_diff("ku10", best, nxt), _scan_diff("ku1e7", best, nxt)
    return (f"R̂ rises monotonically with Λ and is best at Λ = {_lam(best)} "
            f"({_scan_pm('ku10', best)} and {_scan_pm('ku1e7', best)}), ahead of "
            f"Λ = {_lam(nxt)} by {pm(*d10)} and {pm(*d7, 2)}")


def _scan_ku1() -> str:
    best, tied = _scan_best("ku1"), _scan_tied("ku1")
    (other,) = [v for v in tied if v != best]
    below = [v for v in _scan("ku1") if v not in tied]
    assert min(tied) > max(below)
    return (f"Λ = {_lam(best)} highest ({_scan_pm('ku1', best)}), Λ = {_lam(other)} not "
            f"resolved from it ({pm(*_scan_diff('ku1', other, best))}), Λ ≤ {_lam(max(below))} "
            f"more than 2 SEM below")


def _scan_ku01() -> str:
    rows = _scan("ku0.1")
    worst = min(rows, key=lambda k: rows[k]["R_hat_mean"])
    d = _scan_diff("ku0.1", -worst, worst)
    assert abs(d[0]) <= 2 * d[1], d
    best = _scan_best("ku0.1")
    r, e = paired(rows[best]["per_flow"], rows[worst]["per_flow"])
    tied = _scan_tied("ku0.1")
    assert [v for v in sorted(rows) if tied[0] <= v <= tied[-1]] == tied, tied
    return (f"Λ = {_lam(worst)} is the worst constant shape, tied with Λ = {_lam(-worst)} "
            f"({_scan_pm('ku0.1', worst)} and {_scan_pm('ku0.1', -worst)}); the round "
            f"Λ = {_lam(best)} is best ({_scan_pm('ku0.1', best)}): {pm(r, e)} × "
            f"Λ = {_lam(worst)}, "
            f"{pm(*_diff(rows[best]['per_flow'], rows[worst]['per_flow']))} above it; "
            f"Λ = {_lam(tied[0])} to {_lam(tied[-1])} within 2 SEM of it")


def _scan_symmetric() -> str:
    """Ku = 0.1: the largest |R̂(Λ) − R̂(−Λ)| in SEM of the paired difference."""
    worst = max(abs(_scan_diff("ku0.1", v, -v)[0]) / _scan_diff("ku0.1", v, -v)[1]
                for v in _scan("ku0.1") if v > 0)
    return f"symmetric in Λ (R̂(Λ) − R̂(−Λ) within {worst:.1f} SEM)"


def _orient(run: str) -> dict:
    return rec(f"{RI}/orientation_diffusion.json")["records"][run]


def _lag(run: str, tau: float) -> dict:
    (lag,) = [g for g in _orient(run)["lags"] if g["tau_over_tau_K"] == tau]
    return lag


KU01_RUNS = ("ku0.1_naive0.98", "ku0.1_naive0", "ku0.1_sto")
KU1_RUNS = ("ku1_naive0.98", "ku1_naive0", "ku1_sto")
TAUS = (5.0, 10.0, 20.0, 50.0)


def _orient_ratio(run: str, key: str = "ratio_int_omega_to_paper", taus=TAUS) -> list[float]:
    return [_lag(run, t)[key][0] for t in taus]


def _orient_setup() -> str:
    return ("τ_f = {:g} τ_K; {} flows × {} recorded swimmers per run, every decision "
            "(T_u = {:g} τ_K)").format(*_one(
                (_orient(r)["tau_f_over_tau_K"], _orient(r)["flows"],
                 _orient(r)["swimmers_per_flow"], _orient(r)["T_u_over_tau_K"])
                for r in KU01_RUNS))


def _orient_naive098() -> str:
    run = "ku0.1_naive0.98"
    assert _orient(run)["Lambda_mean"] == pytest.approx(0.98)
    return ", ".join(pm(*_lag(run, t)["ratio_int_omega_to_paper"], 2) for t in TAUS) + \
        " at τ = " + ", ".join(f"{t:g}" for t in TAUS) + " τ_K"


def _orient_slopes() -> str:
    s = [_lag(r, t)["slope_msd_int_omega_to_next"] for r in KU01_RUNS for t in TAUS[:-1]]
    return f"log-log slope {span(s, 2)}"


def _swim(vs: str) -> dict[str, dict]:
    return cmp_rows(f"{RI}/swim_speed/vs{vs}/comparison.json")


SWIM_NEW = ("0.1", "0.25", "2", "4")


def _swim_speed_of(vs: str) -> str:
    return f"{rec(f'{RI}/swim_speed/vs{vs}/comparison.json')['config']['swimmer']['swim_speed']:g}"


def _swim_ratio(vs: str, b: str = "sto") -> tuple[float, float]:
    rows = _swim(vs)
    return paired(rows["policy0"]["per_flow"], rows[b]["per_flow"])


def _swim_same_flows() -> str:
    rows, ev = _swim("0.707"), _robust_ev("swim_speed=0.707")
    same = all(rows[k]["per_flow"] == ev[n] for k, n in
               (("policy0", "smart"), ("sto", "STO"), ("naive", "naive")))
    return ("its v_s = 0.707 run gives robustness.json's per-flow R̂ exactly" if same
            else "its v_s = 0.707 run differs from robustness.json")


SWIM_KEYS = (("smart", "policy0"), ("STO", "sto"), ("naive", "naive"))


def _swim_means(name: str) -> dict[float, float]:
    """R̂ of ``name`` (smart, STO, naive) at every v_s: robustness.json's three and the
    referee_items sweep's four."""
    key = dict(SWIM_KEYS)[name]
    d = _robust("swim_speed")
    out = dict(zip(d["x"], d["mean"][name], strict=True))
    out.update({float(_swim_speed_of(v)): _swim(v)[key]["R_hat_mean"] for v in SWIM_NEW})
    return out


def _swim_lowest() -> str:
    lows = {min(_swim_means(n).items(), key=lambda kv: kv[1])[0] for n, _ in SWIM_KEYS}
    assert len(_swim_means("smart")) == 7
    return f"every strategy's R̂ lowest at v_s = {_one(lows):g}"


def _swim_new(name: str) -> str:
    key = dict(SWIM_KEYS)[name]
    return f"{name} " + nums([_swim(v)[key]["R_hat_mean"] for v in SWIM_NEW])


def _swim_at(vs: str, names=("smart", "STO", "naive"), d: int = 3, sem: bool = True) -> str:
    rows = _swim(vs)
    return ", ".join(
        f"{n} " + (pm(rows[dict(SWIM_KEYS)[n]]["R_hat_mean"], rows[dict(SWIM_KEYS)[n]]["R_hat_sem"],
                      d) if sem else num(rows[dict(SWIM_KEYS)[n]]["R_hat_mean"], d))
        for n in names)


def _swim_slow() -> str:
    rows = _swim("0.1")
    assert all(rows[k]["R_hat_mean"] > 1 for _, k in SWIM_KEYS)
    return (f"at v_s = {_swim_speed_of('0.1')} every R̂ exceeds 1 ({_swim_at('0.1')}), from "
            + nums([_swim("0.25")[k]["R_hat_mean"] for _, k in SWIM_KEYS])
            + f" at {_swim_speed_of('0.25')}")


def _swim_distance() -> str:
    """R̂ v_s (the net distance per time, in u_rms) at v_s = 0.25 and 0.1."""
    def dist(vs: str, key: str) -> float:
        return _swim(vs)[key]["R_hat_mean"] * float(_swim_speed_of(vs))
    return ", ".join(f"{n} {num(dist('0.25', k))} → {num(dist('0.1', k))}"
                     for n, k in (("naive", "naive"), ("smart", "policy0")))


def _swim_fast() -> str:
    def means(vs: str) -> list[float]:
        return [_swim(vs)[k]["R_hat_mean"] for _, k in SWIM_KEYS]
    assert all(a > b for a, b in zip(means("4"), means("2"), strict=True))
    return (f"at v_s = {_swim_speed_of('4')} R̂ = {span(means('4'))} (all three; "
            f"{span(means('2'))} at {_swim_speed_of('2')})")


def _swim_margins() -> str:
    def margin(vs: str) -> str:
        r, e = _swim_ratio(vs)
        return (f"{num(100 * (r - 1), 1, sign=True)} ± {num(100 * e, 1)} % "
                f"(v_s = {_swim_speed_of(vs)})")
    return f"{margin('0.1')} and {margin('4')}"


def _ri_box(name: str) -> dict[str, dict]:
    return cmp_rows(f"{RI}/box/{name}/comparison.json")


def _box_change(name: str, key: str) -> str:
    """R̂ of box ``name`` against the default box (100 × 200), unpaired: ``b/a − 1`` ± the
    SEMs in quadrature over ``a``, in %."""
    a, b = _ri_box("default_100x200")[key], _ri_box(name)[key]
    change = b["R_hat_mean"] / a["R_hat_mean"] - 1
    sem = math.hypot(a["R_hat_sem"], b["R_hat_sem"]) / a["R_hat_mean"]
    return f"{num(100 * change, 1, sign=True)} ± {num(100 * sem, 1)} %"


def _box_flow(name: str) -> dict:
    return rec(f"{RI}/box/{name}/comparison.json")["config"]["flow"]


def _box_size(name: str) -> str:
    """The box's side in ℓ_f (grid points × spacing)."""
    return f"{_box_flow(name)['n_grid'] * _box_flow(name)['spacing']:g}"


def _box_ratio(name: str) -> str:
    rows = _ri_box(name)
    return pm(*paired(rows["policy0"]["per_flow"], rows["sto"]["per_flow"]))


BOXES = ("default_100x200", "L20_100x200", "L100_coarse_100x200")

# -- row 18: (n_theta, S_np) at Ku = 0.1 ------------------------------------------------------
def _nth_rows(name: str) -> list[dict]:
    rows = rec(f"referee_items/nth_snp_ku0.1/{name}/comparison.json")["rows"]
    return [r for r in rows if r["label"].startswith("policy(")]


def _nth_same_flows() -> str:
    a, b = (cmp_rows(f"referee_items/nth_snp_ku0.1/{n}/comparison.json")["sto"]["per_flow"]
            for n in ("compare_nth_snp", "compare_all"))
    return ("the two records' STO rows are identical flow by flow" if a == b
            else "the two records' STO rows differ")


def _nth_over_full() -> str:
    """The three two-signal seeds' per-flow mean over the full-state seeds', paired per flow
    (ratio of means, delta-method SEM)."""
    x, y = (np.mean([r["per_flow"] for r in _nth_rows(n)], axis=0)
            for n in ("compare_nth_snp", "compare_all"))
    return pm(*paired(x, y))


def _sign_agreement(prefix: str) -> str:
    recs = rec("referee_items/signal_search.json")["records"]
    return nums([100 * recs[f"{prefix}_seed{k}"]["sign_agreement_STO"] for k in range(3)], 1,
                " / ") + " %"



# -- row 20: the signal-subset search --------------------------------------------------------
def _search(ku: str) -> dict:
    return rec("referee_items/signal_search.json")["by_ku"][ku]


def _search_sizes() -> str:
    recs = [r for label, r in rec("referee_items/signal_search.json")["records"].items()
            if label.startswith("ku")]  # the protocol's runs (ku<KU>_seed<S>)
    sizes = {(r["n_flows"], r["swimmers_per_flow"]) for r in recs}
    assert len(sizes) == 1 and len(recs) == 12
    (f, n), = sizes
    return f"{f} flows × {n} swimmers each"


def _search_best() -> str:
    ok = all(b == "n_theta,S_np,omega" for k in KUS for b in _search(k)["best_per_seed"]["3"])
    return ("The best triple is `(n_θ, S_np, ω)` for every seed at every Ku" if ok
            else "not the same best triple for every seed")


ROWS: dict[int, Spec] = {
    1: Spec("figure only"),
    2: Spec("none"),
    3: Spec("json", (
        C("R̂ rises monotonically with Λ and is best at Λ = 0.98 (0.334 ± 0.004 and "
          "0.667 ± 0.053), ahead of Λ = 0.75 by 0.043 ± 0.004 and 0.22 ± 0.04", _scan_top),
        C("Λ = 0.98 highest (0.237 ± 0.002), Λ = 0.75 not resolved from it (−0.003 ± 0.003), "
          "Λ ≤ 0.5 more than 2 SEM below", _scan_ku1),
        C("Λ = 0.98 is the worst constant shape, tied with Λ = −0.98 (0.354 ± 0.004 and "
          "0.355 ± 0.004); the round Λ = 0 is best (0.399 ± 0.005): 1.127 ± 0.013 × Λ = 0.98, "
          "0.045 ± 0.004 above it; Λ = −0.5 to 0.25 within 2 SEM of it", _scan_ku01),
        C("symmetric in Λ (R̂(Λ) − R̂(−Λ) within 0.8 SEM)", _scan_symmetric),
        C("20 flows × 200 swimmers per Ku", lambda: "{} flows × {} swimmers per Ku".format(*_one(
            (rec(f"{RI}/naive_scan/{k}/comparison.json")["n_flows"],
             rec(f"{RI}/naive_scan/{k}/comparison.json")["n_swimmers"]) for k in KUS))),
        C("9 constant Λ from −0.98 to 0.98", lambda: "{} constant Λ from {} to {}".format(*_one(
            (len(_scan(k)), _lam(min(_scan(k))), _lam(max(_scan(k)))) for k in KUS))))),
    4: Spec("json", (
        C("by 0.046 ± 0.006 (Ku = 1e7) and 0.065 ± 0.014 (Ku = 10)", lambda: (
            f"by {_oe_diff('ku1e7', '5')} (Ku = 1e7) and {_oe_diff('ku10', '5')} (Ku = 10)")),
        C("by 0.874 ± 0.034 at 100 τ_K", lambda: "by " + _oe_diff("ku1e7", "100").lstrip("−-")
          + " at 100 τ_K"),
        C("0.462 of the", lambda: f"{num(_oe('ku1e7')['confined_fraction']['-0.98'])} of the"),
        C("against 0.003 for", lambda: "against "
          + num(_oe("ku1e7")["confined_fraction"]["+0.98"]) + " for"),
        C("0.135 against 0.033", lambda: " against ".join(
            num(_oe("ku10")["confined_fraction"][k]) for k in ("-0.98", "+0.98"))),
        C("0.306 against 0.426", lambda: f"{num(_oe('ku1e7')['vortex_fraction']['-0.98']['mean'])}"
          f" against {num(_oe('ku1e7')['vortex_fraction_eulerian'])}"),
        C("0.476 against 0.365", lambda: " against ".join(
            num(_oe("ku10")["vortex_fraction"][k]["mean"]) for k in ("-0.98", "+0.98"))),
    ), unrecorded={"Λ = −0.98": SETUP, "Λ = 0.98": SETUP, "R̂ < 0.1": SETUP}),
    5: Spec("test"),
    6: Spec("json", (C("0.945 ± 0.001, 0.633 ± 0.002, 0.528 ± 0.002, 0.477 ± 0.011",
                       _sto_means),)),
    7: Spec("json", (
        C("0.352 ± 0.001, 0.239 ± 0.001, 0.337 ± 0.002, 0.625 ± 0.020", _naive_means),
        C("1.31 ± 0.04 × STO", lambda: pm(protocol("ku1e7")["naive"]["ratio_to_first"],
                                          protocol("ku1e7")["naive"]["ratio_sem"], 2)
          + " × STO"))),
    8: Spec("json", (C("0.993 / 0.996 / 0.995 × STO (± 0.0003", lambda: _ratios("ku0.1", 4)),)),
    9: Spec("json", (C("1.070 / 1.065 / 1.060 × STO (± 0.0016", lambda: _ratios("ku1", 4)),)),
    10: Spec("json", (C("1.291 / 1.285 / 1.312 × STO (± 0.005", lambda: _ratios("ku10", 3)),)),
    11: Spec("json", (
        C("1.539 ± 0.026 / 1.417 ± 0.021 / 1.544 ± 0.025 × STO",
          lambda: " / ".join(pm(r["ratio_to_first"], r["ratio_sem"])
                             for r in seeds(protocol("ku1e7"))) + " × STO"),
        C("mean 1.50", lambda: "mean " + num(np.mean(
            [r["ratio_to_first"] for r in seeds(protocol("ku1e7"))]), 2)))),
    12: Spec("json", (C("1.174 ± 0.035 / 1.081 ± 0.032 / 1.179 ± 0.033", _smart_naive_1e7),)),
    13: Spec("json", (C("0.995, 1.065, 1.296, 1.145",
                        lambda: nums([_best_baseline(k) for k in KUS])),)),
    14: Spec("json", (C("1.296 (Ku = 10) and 1.145 (1e7), against 0.995 and 1.065",
                        lambda: f"{num(_best_baseline('ku10'))} (Ku = 10) and "
                                f"{num(_best_baseline('ku1e7'))} (1e7), against "
                                f"{num(_best_baseline('ku0.1'))} and "
                                f"{num(_best_baseline('ku1'))}"),)),
    15: Spec("json", (C("0.946 / 0.951 / 0.373 (Ku = 0.1), 0.680 / 0.635 / 0.242 (Ku = 1), "
                        "0.697 / 0.514 / 0.326 (Ku = 10), 0.611 / 0.387 / 0.349 (Ku = 1e7)",
                        _single_flow),)),
    16: Spec("figure only"),
    17: Spec("json", (C("−0.68 / −0.65 / −0.64",
                        lambda: nums(_per_seed("ku0.1", "corr_Lambda_ntheta_Snp"), 2, " / ")),
                      C("82.9 / 81.1 / 80.2 %",
                        lambda: nums([100 * v for v in _per_seed("ku0.1", "sign_agreement_STO")],
                                     1, " / ") + " %"))),
    18: Spec("json", (
        C("R̂ = 0.993 / 0.993 / 0.993 × STO", lambda: "R̂ = " + nums(
            [r["ratio_to_first"] for r in _nth_rows("compare_nth_snp")], 3, " / ") + " × STO"),
        C("against 0.993 / 0.997 / 0.997 for the full state", lambda: "against " + nums(
            [r["ratio_to_first"] for r in _nth_rows("compare_all")], 3, " / ")
          + " for the full state"),
        C("(seeds 0 / 1 / 2, paired, ± ≤ 0.001)", lambda: "(seeds 0 / 1 / 2, paired, ± ≤ "
          + num(max(r["ratio_sem"] for k in ("compare_nth_snp", "compare_all")
                    for r in _nth_rows(k)), 3) + ")"),
        C("0.998 ± 0.001", _nth_over_full),
        C("the two records' STO rows are identical flow by flow", _nth_same_flows),
        C("83.9 / 81.5 / 84.5 %", lambda: _sign_agreement("nth_snp_ku0.1")),
        C("82.9 / 81.2 / 80.3 %", lambda: _sign_agreement("ku0.1"))),
        unrecorded={"8 flows × 100 swimmers": SETUP}),
    19: Spec("json", (
        C("τ_f = 0.2 τ_K; 20 flows × 20 recorded swimmers per run, every decision "
          "(T_u = 0.1 τ_K)", _orient_setup),
        C("0.97 ± 0.01, 0.99 ± 0.02, 1.02 ± 0.02, 1.07 ± 0.04 at τ = 5, 10, 20, 50 τ_K",
          _orient_naive098),
        C("Λ = 0: 0.955-0.990; STO: 0.988-1.067", lambda: "Λ = 0: {}; STO: {}".format(
            span(_orient_ratio("ku0.1_naive0")), span(_orient_ratio("ku0.1_sto")))),
        C("naive Λ = 0.98", lambda: "naive Λ = "
          + _lam(round(_orient("ku0.1_naive0.98")["Lambda_mean"], 2))),
        C("log-log slope 0.97-1.05", _orient_slopes),
        C("0.198-0.208 τ_K", lambda: span(
            [_orient(r)["corr_time_omega_over_tau_K"] for r in KU01_RUNS]) + " τ_K"),
        C("0.23-0.24 × the formula at Λ = 0", lambda: span(
            _orient_ratio("ku0.1_naive0", "ratio_theta_to_paper"), 2) + " × the formula at Λ = "
          + _lam(round(_orient("ku0.1_naive0")["Lambda_mean"], 2))),
        C("0.32-0.36 × at Λ = 0.98", lambda: span(
            _orient_ratio("ku0.1_naive0.98", "ratio_theta_to_paper"), 2) + " × at Λ = "
          + _lam(round(_orient("ku0.1_naive0.98")["Lambda_mean"], 2))),
        C("against 2⟨θ̇²⟩τ_f τ: 0.93-0.97 and 0.89-1.00", lambda: "against 2⟨θ̇²⟩τ_f τ: "
          + " and ".join(span(_orient_ratio(r, "ratio_theta_to_model_rate"), 2)
                         for r in ("ku0.1_naive0", "ku0.1_naive0.98"))),
        C("⟨Δθ²⟩ → 0.26 rad², log-log slope 0.02 from 20 to 50 τ_K",
          lambda: "⟨Δθ²⟩ → {} rad², log-log slope {} from 20 to 50 τ_K".format(
              num(_lag("ku0.1_sto", 50.0)["msd_theta"][0], 2),
              num(_lag("ku0.1_sto", 20.0)["slope_msd_theta_to_next"], 2))),
        C("0.494-0.555 × the formula at τ = 10-50 τ_K", lambda: span(
            [v for r in KU1_RUNS for v in _orient_ratio(r, taus=TAUS[1:])])
          + " × the formula at τ = 10-50 τ_K"),
        C("1.08-1.15 τ_K", lambda: span(
            [_orient(r)["corr_time_omega_over_tau_K"] for r in KU1_RUNS], 2) + " τ_K"))),
    20: Spec("json", (
        C("8 flows × 100 swimmers each", _search_sizes),
        C("0.95 / 0.87 / 0.76 / 0.77 at Ku = 0.1 / 1 / 10 / 1e7", lambda: " / ".join(
            num(_search(k)["R2_mean"]["n_theta,S_np,omega"], 2) for k in KUS)
          + " at Ku = 0.1 / 1 / 10 / 1e7"),
        C("The best triple is `(n_θ, S_np, ω)` for every seed at every Ku", _search_best),
        C("(0.55 ± 0.02, 0.59 ± 0.03, mean ± std over seeds)", lambda: "({}, {}, mean ± std "
          "over seeds)".format(*(pm(_search(k)["R2_mean"]["n_r,S_np,omega"],
                                    _search(k)["R2_std"]["n_r,S_np,omega"], 2)
                                 for k in ("ku10", "ku1e7")))),
        C("second at Ku = 10 and 1e7", lambda: "second at Ku = " + " and ".join(
            k for k, ku in (("10", "ku10"), ("1e7", "ku1e7"))
            if _search(ku)["ranked"]["3"][1] == "n_r,S_np,omega")),
        C("explains 0.91-0.93 at Ku ≥ 1", lambda: "explains " + span(
            [_search(k)["R2_mean"]["n_r,n_theta,S_np,omega"] for k in KUS[1:]], 2)
          + " at Ku ≥ 1")),
        unrecorded={"all 10 triples": SETUP, "fitted on 4 flows and scored on 4 others": SETUP}),
    21: Spec("json", (
        C("`paper_runs/ku1e7_seed0/policy.pt`", _ku_inf_policy),
        C("which is the protocol's seed 2", _shipped_ku1e7_seed),
        C("40 frozen flows × 1000 swimmers, 8e7 decisions", _ku_inf_sizes)),
        unrecorded={"8000 decisions": "the plotting code (swimrl/paper/mechanism.py)",
                    "every 20th decision of 20 swimmers per flow":
                        "the recorder's sampling (swimrl/paper/decision_stats.py)"}),
    22: Spec("json", (C("0.91-0.97", lambda: span(_map_corr("ku1e7"), 2)),)),
    23: Spec("json"),
    24: Spec("json", (
        C("41 % / 31 % / 41 %",
          lambda: " / ".join(pct(v) for v in _per_seed("kuInf", "p_pos_given_low"))),
        C("8e5 decisions in the tail", _snn_tail),
        C("mean 38 ± 6 %", lambda: "mean " + mean_std(
            [100 * p for p in _per_seed("kuInf", "p_pos_given_low")], 0) + " %"))),
    25: Spec("json", (
        C("33 % / 35 % / 30 %",
          lambda: " / ".join(pct(v) for v in _per_seed("kuInf", "p_neg_given_high"))),
        C("among the 1 % highest", lambda: "among the " + pct(_one(
            rec("figures/kuInf.json")["evaluations"][f"ku1e7_seed{s}"]["derived"]["snn"]["q"]
            for s in "012")) + " highest"))),
    26: Spec("json", (
        C("−0.66, −0.56, −0.45, −0.44", lambda: nums(
            [rec("figures/ku_pattern.json")["derived"][k]["per_seed"]
             ["corr_Lambda_ntheta_Snp_mean"] for k in KUS], 2)),
        C("range over seeds ≤ 0.04, 0.08 at 1e7",
          lambda: f"range over seeds ≤ {num(max(_corr_range(k) for k in KUS[:3]), 2)}, "
                  f"{num(_corr_range('ku1e7'), 2)} at 1e7"))),
    27: Spec("json", (C("0.95-0.99", lambda: span(
        [v for k in KUS for v in _map_corr(k, ("omega",))], 2)),)),
    28: Spec("json", (C("1.291 / 1.285 / 1.312 × STO (± 0.005", lambda: _ratios("ku10", 3)),)),
    29: Spec("json", (
        C("1.211 ± 0.006 / 1.221 ± 0.005 / 1.173 ± 0.005",
          lambda: " / ".join(pm(r["ratio_to_first"], r["ratio_sem"])
                             for r in _held_out("nr_nth_snp_w"))),
        C("against 1.285-1.312 for all signals", lambda: "against " + span(_signal_set(
            ["n_r", "n_theta", "S_nn", "S_np", "omega"])["ratios"]) + " for all signals"),
        C("1.10 ± 0.08 against 1.15 ± 0.01",
          lambda: f"{_early('nr_nth_snp_w')} against {_early('all')}"))),
    30: Spec("json", (C("1.003 / 0.975 / 1.008 (± 0.003)", lambda: nums(
        [r["ratio_to_first"] for r in _held_out("nr_nth_snp")], sep=" / ")
        + f" (± {num(max(r['ratio_sem'] for r in _held_out('nr_nth_snp')))})"),)),
    31: Spec("json", (
        C("0.982 ± 0.003 / 0.936 ± 0.003 / 0.990 ± 0.004",
          lambda: " / ".join(pm(r["ratio_to_first"], r["ratio_sem"])
                             for r in _held_out("nth_snp"))),
        C("mean 0.969, std 0.029", lambda: "mean {}, std {}".format(*mean_std(
            [r["ratio_to_first"] for r in _held_out("nth_snp")]).split(" ± "))),
        C("seed 0 is 2 % below the three-signal seed 0",
          lambda: "seed 0 is " + pct(1 - _held_out("nth_snp")[0]["ratio_to_first"]
                                     / _held_out("nr_nth_snp")[0]["ratio_to_first"])
          + " below the three-signal seed 0"))),
    32: Spec("json", (
        C("below STO on 3 of 3 seeds (2.7-21 SEM)",
          lambda: f"below STO on {sum(s > 0 for s in _below_sto_sems('nth_snp'))} of 3 seeds "
                  f"({min(_below_sto_sems('nth_snp')):.1f}-"
                  f"{max(_below_sto_sems('nth_snp')):.0f} SEM)"),
        C("(1.003 ± 0.003, 1.008 ± 0.003), seed 1 below (0.975 ± 0.003)",
          lambda: "({}, {}), seed 1 below ({})".format(*(
              pm(_held_out("nr_nth_snp")[s]["ratio_to_first"],
                 _held_out("nr_nth_snp")[s]["ratio_sem"]) for s in (0, 2, 1)))))),
    33: Spec("json", (
        C("0.731 / 0.762 / 0.729 ± 0.004", lambda: nums(
            [r["ratio_to_first"] for r in _held_out("nr_nth_snn_w")], sep=" / ")
            + " ± " + num(_one(round(r["ratio_sem"], 3) for r in _held_out("nr_nth_snn_w")))),
        C("1.16 / 1.21 / 1.15 × naive",
          lambda: nums(_held_out_naive("nr_nth_snn_w"), 2, " / ") + " × naive"),
        C("0.741 ± 0.019", lambda: pm(_signal_set(["n_r", "n_theta", "S_nn", "omega"])["mean"],
                                      _signal_set(["n_r", "n_theta", "S_nn", "omega"])["std"])),
        C("0.664 ± 0.033", lambda: _early("nr_nth_snn_w", 3)))),
    34: Spec("json", (
        C("1.000 ± 0.001 (Ku = 0.1), 0.969 ± 0.003 (1), 0.931 ± 0.006 (10), "
          "0.954 ± 0.016 (1e7)",
          lambda: ", ".join(pm(_minimal(k, "minimal/smart")["value"],
                               _minimal(k, "minimal/smart")["sem"]) + f" ({lab})"
                            for k, lab in zip(KUS, ("Ku = 0.1", "1", "10", "1e7"),
                                              strict=True))),
        C("minimal / STO 0.996, 1.043, 1.222, 1.358", lambda: "minimal / STO " + nums(
            [_minimal(k, "minimal/STO")["value"] for k in KUS])),
        C("20 flows × 500", lambda: "{n_flows} flows × {n_swimmers}".format(
            **rec("figures/ablation.json")["sizes"]["sweep"])),
        C("12 and 11.5 SEM at Ku = 1 and 10, 2.9 SEM at 1e7",
          lambda: f"{_minimal_sems('ku1'):.0f} and {_minimal_sems('ku10'):.1f} SEM at Ku = 1 "
                  f"and 10, {_minimal_sems('ku1e7'):.1f} SEM at 1e7", where="verdict"))),
    35: Spec("json", (
        C("4.34 ± 0.05, 2.80 ± 0.03, 2.80 ± 0.07, 1.73 ± 0.12", lambda: ", ".join(
            pm(_fit(k)["coefficients"]["c1"], _fit(k)["flow_sem"]["c1"], 2) for k in KUS)),
        C("8 flows × 100", lambda: "{} flows × {}".format(*_one(
            (_fit(k)["config"]["eval"]["n_flows"], _fit(k)["config"]["eval"]["n_swimmers"])
            for k in KUS))))),
    36: Spec("json", (
        C("c2 0.46 → 2.19, c3 0.26 → 0.75, c4 0.05 → 0.42", lambda: ", ".join(
            f"{c} {num(_fit('ku0.1')['coefficients'][c], 2)} → "
            f"{num(_fit('ku10')['coefficients'][c], 2)}" for c in ("c2", "c3", "c4"))),
        C("c2 −23 %, 5 SEM; c3 −10 %, 2 SEM; c4 −25 %, 3 SEM",
          lambda: "; ".join(_coeff_change(c) for c in ("c2", "c3", "c4"))))),
    37: Spec("npz"),
    38: Spec("json", (C("flatness 3.80 / 3.31 / 3.29", lambda: "flatness " + nums(
        [rec("dns_checks/dns_checks.json")["pooled_moments"][k]["flatness"]
         for k in ("omega", "S_xx", "S_xy")], 2, " / ")),)),
    39: Spec("json", (
        C("1.215 ± 0.008 × STO (std over 4 realisations 0.019)",
          lambda: (lambda r, e, per: f"{pm(r, e)} × STO (std over {len(per)} realisations "
                                     f"{num(np.std(per, ddof=1))})")(
              *_dns_ratio(policy("pretrained/ku10")))),
        C("0.983, 1.133, 1.204", lambda: nums(
            [_dns_ratio(policy(f"pretrained/{k}"))[0] for k in ("ku0.1", "ku1", "ku1e7")])),
        C("seed means 0.953 / 1.113 / 1.199 / 1.183", lambda: "seed means " + " / ".join(
            f"{_dns_seeds()['by_ku'][k]['policy']['mean']:.3f}"
            for k in ("ku0.1", "ku1", "ku10", "ku1e7"))),
        C("1.011 ± 0.004, 1.021 ± 0.008, 1.009 ± 0.005", lambda: ", ".join(
            pm(v["ratio"], v["sem"]) for v in _dns_seeds()["ku10_over_ku1e7"].values())),
        C("1e7 below 10 on every realisation", lambda: "1e7 below 10 on every realisation"
          if all(a < b for a, b in zip(_dns_ratio(policy("pretrained/ku1e7"))[2],
                                       _dns_ratio(policy("pretrained/ku10"))[2], strict=True))
          else "not on every realisation"))),
    40: Spec("json", (
        C("1.134 / 1.124 / 1.148 × STO", lambda: nums(
            [_dns_ratio(r)[0] for r in DNS_RUNS], sep=" / ") + " × STO"),
        C("1.070 ± 0.011 × them", lambda: pm(np.mean(_ku10_over_dns()[0]),
                                              np.std(_ku10_over_dns()[0], ddof=1)) + " × them"),
        C("1.061-1.076 per realisation", lambda: span(_ku10_over_dns()[1])
          + " per realisation")),
        unrecorded={"+0.02 step of seed 2": "a step read off dns_train/seed2/curves.csv"}),
    41: Spec("json", (
        C("minimal (Ku = 10 fit) 1.136 ± 0.007 × STO against 1.215 ± 0.008",
          lambda: f"minimal (Ku = 10 fit) {pm(*_dns_ratio('minimal(ku10)')[:2])} × STO "
                  f"against {pm(*_dns_ratio(policy('pretrained/ku10'))[:2])}"),
        C("94 %", lambda: pct(_dns_ratio("minimal(ku10)")[0]
                              / _dns_ratio(policy("pretrained/ku10"))[0])),
        C("gap 0.068-0.090 on each realisation", lambda: "gap " + span(
            [a - b for a, b in zip(_dns_ratio(policy("pretrained/ku10"))[2],
                                   _dns_ratio("minimal(ku10)")[2], strict=True)])
          + " on each realisation"),
        C("1.002, 1.065, 1.148", lambda: nums(
            [_dns_ratio(f"minimal({k})")[0] for k in ("ku0.1", "ku1", "ku1e7")])))),
    42: Spec("json", (
        C("1.133 ± 0.006 × STO (std over realisations 0.014)",
          lambda: (lambda r, e, per: f"{pm(r, e)} × STO (std over realisations "
                                     f"{num(np.std(per, ddof=1))})")(
              *_dns_ratio(policy("pretrained/ku1")))),
        C("minimal (Ku = 1 fit) 1.065 ± 0.005",
          lambda: f"minimal (Ku = 1 fit) {pm(*_dns_ratio('minimal(ku1)')[:2])}"))),
    43: Spec("npz"),
    44: Spec("json", (
        C("100 flows × 200 per box", lambda: "{} flows × {} per box".format(*_one(
            (rec(f"{RI}/box/{n}/comparison.json")["n_flows"],
             rec(f"{RI}/box/{n}/comparison.json")["n_swimmers"]) for n in BOXES))),
        C("spacing 0.025 ℓ_f; STO 0.5315 ± 0.0027, smart 0.6937 ± 0.0022",
          lambda: "spacing {:g} ℓ_f; STO {}, smart {}".format(
              _one(_box_flow(n)["spacing"] for n in BOXES[:2]),
              *(pm(_ri_box(BOXES[0])[k]["R_hat_mean"], _ri_box(BOXES[0])[k]["R_hat_sem"], 4)
                for k in ("sto", "policy0")))),
        C("L = 20 ℓ_f STO −1.6 ± 0.7 %, smart −0.7 ± 0.4 %",
          lambda: f"L = {_box_size('L20_100x200')} ℓ_f STO "
                  f"{_box_change('L20_100x200', 'sto')}, smart "
                  f"{_box_change('L20_100x200', 'policy0')}"),
        C("at spacing 0.05 ℓ_f (which at L = 10 ℓ_f changes STO by −0.3 ± 0.7 %, smart by "
          "−0.5 ± 0.4 %): STO −0.8 ± 0.7 %, smart −0.5 ± 0.4 %",
          lambda: "at spacing {:g} ℓ_f (which at L = {} ℓ_f changes STO by {}, smart by {}): "
                  "STO {}, smart {}".format(
                      _one(_box_flow(n)["spacing"] for n in
                           ("coarse_L10_100x200", "L100_coarse_100x200")),
                      _box_size("coarse_L10_100x200"),
                      _box_change("coarse_L10_100x200", "sto"),
                      _box_change("coarse_L10_100x200", "policy0"),
                      _box_change("L100_coarse_100x200", "sto"),
                      _box_change("L100_coarse_100x200", "policy0"))),
        C("smart / STO 1.305 ± 0.006, 1.317 ± 0.005, 1.309 ± 0.006 at L = 10, 20, 100 ℓ_f",
          lambda: "smart / STO {} at L = {} ℓ_f".format(
              ", ".join(_box_ratio(n) for n in BOXES),
              ", ".join(_box_size(n) for n in BOXES))),
        C("100 × 100", lambda: "{} × {}".format(*_one(
            (rec(f"ku1e7_readings/{n}/comparison.json")["n_flows"],
             rec(f"ku1e7_readings/{n}/comparison.json")["n_swimmers"])
            for n in ("default", "box_L20", "box_L40")))),
        C("naive 0.606 ± 0.018 → 0.531 ± 0.015", lambda: _box("naive", "naive")),
        C("(3 SEM, independent flows)", lambda: "({:.0f} SEM, independent flows)".format(
            (_reading("default")["naive"]["R_hat_mean"] - _reading("box_L20")["naive"]
             ["R_hat_mean"]) / math.hypot(_reading("default")["naive"]["R_hat_sem"],
                                          _reading("box_L20")["naive"]["R_hat_sem"]))),
        C("smart 0.731 ± 0.009 → 0.683 ± 0.007", lambda: _box("smart", "policy0")))),
    45: Spec("doc", unrecorded={"τ_f = 0.2 τ_K": "derived from the flow's definition "
                                                  "(physics.md), no record"}),
    46: Spec("json", (
        C("64 flows × 8 swimmers per update, minibatches of 2560",
          lambda: "{} flows × {} swimmers per update, minibatches of {}".format(*_one(
              (c["train"]["n_flows"], c["train"]["n_swimmers"], c["train"]["minibatch_size"])
              for c in _runs_config()))),
        C("lr 3e-3 / 1e-3 decaying linearly", lambda: "lr {} / {} decaying {}ly".format(*_one(
            (sci(c["optim"]["lr_actor"]), sci(c["optim"]["lr_critic"]), c["optim"]["anneal"])
            for c in _runs_config()))),
        C("(1e8 frames = 5000 episodes; 4.1e7 at Ku = 0.1)",
          lambda: "({} frames = 5000 episodes; {} at Ku = 0.1)".format(
              sci(_one(c["train"]["total_frames"] for c in _runs_config()[3:])),
              sci(_one(c["train"]["total_frames"] for c in _runs_config()[:3]), 1))),
        C("no entropy bonus, λ_GAE = 0.95",
          lambda: ("no entropy bonus" if _one(c["loss"]["entropy_coeff"]
                                              for c in _runs_config()) == 0 else "entropy")
          + f", λ_GAE = {_one(c['loss']['gae_lambda'] for c in _runs_config()):g}"),
        C("σ ≥ 0.5 (Ku ≤ 10) or ≥ 0.3 (1e7)", _min_std))),
    47: Spec("json", (
        C("16 flows × 32", lambda: "{} flows × {}".format(*_one(
            (c["train"]["eval_flows"], c["train"]["eval_swimmers"]) for c in _runs_config()))),
        C("(0.938-0.942 at the end)", lambda: f"({span(_curve_last('ku0.1'))} at the end)"),
        C("(0.671-0.681)", lambda: f"({span(_curve_last('ku10'))})"),
        C("Ku = 1 +0.01-0.03 over the second half",
          lambda: f"Ku = 1 {num(min(_second_half('ku1')), 2, sign=True)}-"
                  f"{num(max(_second_half('ku1')), 2)} over the second half"),
        C("(0.698, 0.676)", lambda: f"({nums(_curve_last('ku1e7')[:2])})")),
        unrecorded={"≈ 1000 episodes": "a reading of the curves",
                    "≈ 3000": "a reading of the curves"}),
    48: Spec("json", (
        C("within 0.014 (2 %) at Ku ≤ 10",
          lambda: f"within {num(_seed_spread()[0])} ({pct(_seed_spread()[1])}) at Ku ≤ 10"),
        C("seed 1 is 8 % below seeds 0 and 2", lambda: "seed 1 is " + pct(1 - seeds(
            protocol("ku1e7"))[1]["R_hat_mean"] / np.mean(
            [seeds(protocol("ku1e7"))[s]["R_hat_mean"] for s in (0, 2)]))
          + " below seeds 0 and 2"),
        C("(0.676 ± 0.009 against 0.734 ± 0.008, 0.736 ± 0.008)",
          lambda: "({} against {}, {})".format(*(pm(seeds(protocol("ku1e7"))[s]["R_hat_mean"],
                                                    seeds(protocol("ku1e7"))[s]["R_hat_sem"])
                                                 for s in (1, 0, 2)))))),
    49: Spec("json", (
        C("+0.2 ± 0.8 %, +0.3 ± 0.9 %, −1.4 ± 0.7 %, −2.7 ± 0.9 %, −22.8 ± 0.9 %",
          _noise_change),
        C("20 flows × 500", lambda: "{n_flows} flows × {n_swimmers}".format(
            **_noise()["sizes"]["sweep"])))),
    50: Spec("json", (
        C("smart / STO 1.309-1.324 (± 0.01) up to 1e-2", lambda: "smart / STO {} (± {}) up to "
          "1e-2".format(span(_noise()["derived"]["rot_diffusion"]["smart/STO"][:5]),
                         num(max(_noise()["derived"]["rot_diffusion"]["smart/STO_sem"][:5]),
                             2))),
        C("1.266 ± 0.009 at 1e-1", lambda: pm(
            _noise()["derived"]["rot_diffusion"]["smart/STO"][5],
            _noise()["derived"]["rot_diffusion"]["smart/STO_sem"][5]) + " at 1e-1"),
        C("at 1e-1 smart 0.534, STO 0.421, naive 0.225", lambda: "at 1e-1 " + ", ".join(
            f"{n} {num(_noise()['derived']['rot_diffusion']['mean'][n][5])}"
            for n in ("smart", "STO", "naive"))))),
    51: Spec("json", (
        C("0.614, 0.459, 0.334, 0.241 (std over flows 0.010-0.032) at T = 50, 100, 200, 400",
          lambda: "{} (std over flows {}) at T = {}".format(
              nums(_robust("duration")["mean"]["naive"]),
              span(_robust("duration")["std"]["naive"]),
              ", ".join(f"{x:g}" for x in _robust("duration")["x"]))),
        C("0.669, 0.473, 0.334, 0.236", _diffusive))),
    52: Spec("json", (
        C("0.821, 0.745, 0.691, 0.662 (std 0.013-0.032)", lambda: "{} (std {})".format(
            nums(_robust("duration")["mean"]["smart"]),
            span(_robust("duration")["std"]["smart"]))),
        C("−4 % from 200 to 400 τ_K, 19 % higher at 50 τ_K than at 200",
          lambda: "{} from 200 to 400 τ_K, {} higher at 50 τ_K than at 200".format(
              pct(_robust("duration")["mean"]["smart"][3]
                  / _robust("duration")["mean"]["smart"][2] - 1),
              pct(_robust("duration")["mean"]["smart"][0]
                  / _robust("duration")["mean"]["smart"][2] - 1))))),
    53: Spec("json", (
        C("smart 0.702, 0.691, 0.675, 0.603, 0.475, 0.357 and STO 0.537, 0.528, 0.503, 0.456, "
          "0.391, 0.322 at T_u / τ_K = 0.05, 0.1, 0.2, 0.5, 1, 2",
          lambda: "smart {} and STO {} at T_u / τ_K = {}".format(
              nums(_robust("update_interval")["mean"]["smart"]),
              nums(_robust("update_interval")["mean"]["STO"]),
              ", ".join(f"{x:g}" for x in _robust("update_interval")["x"]))),
        C("naive 0.332-0.337", lambda: "naive " + span(
            _robust("update_interval")["mean"]["naive"])))),
    54: Spec("json", (
        C("smart / STO 1.213 ± 0.009 / 1.109 ± 0.008, smart / naive 1.408 ± 0.013 / "
          "1.067 ± 0.008, STO / naive 1.161 ± 0.012 / 0.962 ± 0.008",
          lambda: "smart / STO {}, smart / naive {}, STO / naive {}".format(
              _robust_paired("smart", "STO"), _robust_paired("smart", "naive"),
              _robust_paired("STO", "naive"))),)),
    55: Spec("json", (
        C("smart 0.804, 0.691, 0.828; STO 0.670, 0.528, 0.670; naive 0.407, 0.334, 0.535 at "
          "v_s / u_rms = 0.354, 0.707, 1.414",
          lambda: "; ".join(f"{n} {nums(_robust('swim_speed')['mean'][n])}"
                            for n in ("smart", "STO", "naive"))
          + " at v_s / u_rms = " + ", ".join(f"{x:g}" for x in _robust("swim_speed")["x"])),
        C("smart / STO 1.200 ± 0.009, 1.309 ± 0.012, 1.236 ± 0.014", lambda: "smart / STO "
          + ", ".join(pm(r, e) for r, e in zip(_robust("swim_speed")["smart/STO"],
                                               _robust("swim_speed")["smart/STO_sem"],
                                               strict=True))),
        C("v_s / u_rms = 0.1, 0.25, 2, 4", lambda: "v_s / u_rms = " + ", ".join(
            _swim_speed_of(v) for v in SWIM_NEW)),
        C("its v_s = 0.707 run gives robustness.json's per-flow R̂ exactly", _swim_same_flows),
        C("smart 1.471, 0.906, 0.911, 0.967; STO 1.407, 0.799, 0.804, 0.950; naive 1.116, "
          "0.527, 0.683, 0.913", lambda: "; ".join(_swim_new(n) for n, _ in SWIM_KEYS)),
        C("smart / STO 1.045 ± 0.007, 1.133 ± 0.006, 1.133 ± 0.010, 1.017 ± 0.001",
          lambda: "smart / STO " + ", ".join(pm(*_swim_ratio(v)) for v in SWIM_NEW)),
        C("smart / naive ≥ 1.059 ± 0.004", lambda: "smart / naive ≥ " + pm(*min(
            _swim_ratio(v, "naive") for v in SWIM_NEW))),
        C("every strategy's R̂ lowest at v_s = 0.707", _swim_lowest))),
    56: Spec("json", (
        C("at v_s = 0.1 every R̂ exceeds 1 (smart 1.471 ± 0.025, STO 1.407 ± 0.022, naive "
          "1.116 ± 0.019), from 0.906, 0.799, 0.527 at 0.25", _swim_slow),
        C("naive 0.132 → 0.112, smart 0.226 → 0.147", _swim_distance),
        C("at v_s = 4 R̂ = 0.913-0.967 (all three; 0.683-0.911 at 2)", _swim_fast),
        C("+4.5 ± 0.7 % (v_s = 0.1) and +1.7 ± 0.1 % (v_s = 4)", _swim_margins),
        C("20 flows × 500", lambda: "{} flows × {}".format(*_one(
            (rec(f"{RI}/swim_speed/vs{v}/comparison.json")["n_flows"],
             rec(f"{RI}/swim_speed/vs{v}/comparison.json")["n_swimmers"])
            for v in SWIM_NEW)))),
        unrecorded={"v_s = 0.1-4 u_rms": SETUP}),
    57: Spec("none"),
    58: Spec("npz", unrecorded={
        "5.02 L, STO 3.95 L, naive 2.54 L": "dns_figures/record.npz (not JSON/CSV), via the "
                                            "table docs/figures/dnsFlow_replay.md",
        "0.702 / 0.553 / 0.355 ± 0.010-0.011": "dns_figures/record.npz (not JSON/CSV)"}),
}


# -- the tests -----------------------------------------------------------------------------------
def test_every_verdict_row_has_an_entry_and_every_entry_a_row():
    rows = verdict_rows()
    assert len(rows) > 50
    assert sorted(rows) == list(range(1, max(rows) + 1)), "rows are numbered 1..N once"
    assert set(rows) - set(ROWS) == set(), "rows of the page without an entry here"
    assert set(ROWS) - set(rows) == set(), "entries here without a row on the page"


def _oe(ku: str) -> dict:
    """One Ku of ``referee_items/optimal_escape/optimal_escape.json`` (row 4)."""
    path = DOCS / "results" / "referee_items" / "optimal_escape" / "optimal_escape.json"
    return json.loads(path.read_text())["by_ku"][ku]


def _oe_diff(ku: str, t: str) -> str:
    """Best-orientation R_hat of Lambda = -0.98 minus Lambda = 0.98's at ``t``, paired."""
    d = _oe(ku)["best_minus_prolate"]["-0.98"][t]
    return pm(d["mean"], d["sem"])


def _dns_seeds() -> dict:
    """The three-seed DNS transfer summary (``three_seeds/dns_transfer/summary.json``)."""
    return json.loads((DOCS / "results" / "three_seeds" / "dns_transfer" / "summary.json")
                      .read_text())


def _counts(rows) -> tuple[int, ...]:
    words = [re.match(r"\*\*([a-z ]+)\*\*", r.verdict) for r in rows]
    assert all(words), "a verdict cell that does not start with a bold verdict word"
    counted = [w.group(1) for w in words]
    return (len(counted), counted.count("agrees"), counted.count("agrees in part"),
            counted.count("differs"), counted.count("not attempted"))


def test_the_counts_of_verdicts_add_up():
    """The first verdict word of each row, counted per section and in all, against the page's
    count table (``·`` for none)."""
    table = {}
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        m = re.match(r"^\| (?:\[([^\]]+)\]\(#[^)]*\)|(all)) \|((?: [\d·]+ \|){5})$", line)
        if m:
            table[m.group(1) or "all"] = tuple(
                0 if c.strip() == "·" else int(c) for c in m.group(3).strip(" |").split(" | "))
    rows = list(verdict_rows().values())
    sections = {r.section for r in rows}
    assert set(table) == sections | {"all"}, "sections and the count table differ"
    for name in sections:
        assert table[name] == _counts([r for r in rows if r.section == name]), name
    assert table["all"] == _counts(rows)


def test_the_page_writes_powers_of_ten_as_the_configs_take_them():
    """``1e7``, ``5e-3`` (as ``flow.kubo=1e7``), never ``10^7`` or ``10⁷``; code spans and
    LaTeX maths aside."""
    text = re.sub(r"`[^`]*`|\$[^$\n]*\$|\\\(.*?\\\)", " ", PAGE.read_text(encoding="utf-8"))
    found = re.findall(r".{0,30}(?:10\^|10[⁰¹²³⁴⁵⁶⁷⁸⁹⁻]).{0,10}", text)
    assert not found, found


@pytest.mark.parametrize("number", sorted(ROWS))
def test_the_record_clause_is_what_the_entry_says(number):
    row, spec = verdict_rows()[number], ROWS[number]
    clause = row.record
    assert clause, f"row {number}: no 'Record:' clause"
    for target in cited_targets(row):
        assert target.exists(), f"row {number} cites {target.relative_to(DOCS)}: no such file"
    if spec.record in ("none", "figure only", "no committed record"):
        assert clause.startswith(spec.record), f"row {number}: {clause[:80]!r}"
        assert not spec.checks, f"row {number}: checks against no record"
        assert not record_roots(row), (
            f"row {number} says {spec.record!r} and cites records {record_roots(row)}")
    elif spec.record == "json":
        roots = record_roots(row)
        assert roots, f"row {number}: cites no record under docs/results ({clause[:80]!r})"
        for root in roots:
            files = [root] if root.is_file() else [
                name for _, _, names in os.walk(root, followlinks=True) for name in names
                if name.endswith((".json", ".csv"))]  # paper_runs/<run> are links
            assert files, f"row {number}: {root.relative_to(DOCS)} holds no JSON or CSV record"
    elif spec.record == "npz":
        assert any(t.suffix == ".npz" for t in record_roots(row)), f"row {number}: no .npz"
    elif spec.record == "test":
        m = re.search(r"`(tests/[\w/]+\.py)` \(`(test_\w+)`\)", clause)
        assert m, f"row {number}: {clause!r}"
        assert f"def {m.group(2)}(" in (ROOT / m.group(1)).read_text(encoding="utf-8")
    elif spec.record == "doc":
        assert any(t.suffix == ".md" and RESULTS not in t.parents for t in cited_targets(row))
    else:
        pytest.fail(f"row {number}: unknown record kind {spec.record!r}")


@pytest.mark.parametrize("number", sorted(n for n, s in ROWS.items() if s.checks))
def test_quoted_numbers_match_the_cited_records(number):
    row, spec = verdict_rows()[number], ROWS[number]
    roots = record_roots(row)
    bad = []
    for check in spec.checks:
        cell = row.ours if check.where == "ours" else row.verdict
        if check.quote not in cell:
            bad.append(f"not quoted in the {check.where} cell: {check.quote!r}")
            continue
        del _READ[:]
        got = check.compute()
        outside = sorted({p.relative_to(DOCS).as_posix() for p in _READ
                          if not any(p == r or r in p.parents for r in roots)})
        if outside:
            bad.append(f"{check.quote!r} read records the row does not cite: {outside}")
        if got != check.quote:
            bad.append(f"the page: {check.quote!r}; the records: {got!r}")
    assert not bad, f"row {number}:\n" + "\n".join(bad)


@pytest.mark.parametrize("number", sorted(ROWS))
def test_every_quoted_number_is_checked_or_declared(number):
    row, spec = verdict_rows()[number], ROWS[number]
    text = row.measure
    for quote in [c.quote for c in spec.checks if c.where == "ours"] + list(spec.unrecorded):
        assert quote in row.ours, f"row {number}: the entry quotes {quote!r}, the page does not"
        text = text.replace(quote, " ")
    for pattern in NOT_COUNTED:
        text = pattern.sub(" ", text)
    left = NUMBER.findall(text)
    assert not left, (f"row {number}: numbers neither checked against a record nor declared "
                      f"unrecorded: {left}")
