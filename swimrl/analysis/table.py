r"""One table of all results under a sweep directory (``swimrl-table``).

Collects every ``metrics.json`` (``swimrl-eval``, ``swimrl-train``) and ``comparison.json``
(``swimrl-compare``, one row per strategy) below ``DIR``. The columns are the config keys
whose values differ between the results (the swept keys, e.g. ``flow.kubo``, ``seed``),
then the strategy and ``R_hat`` (mean +- SEM over flows, std over flows), the evaluation
size, and for comparisons the paired ratio to the first strategy.

``--average KEY`` (repeatable, e.g. ``--average seed``) groups the rows that differ only in
``KEY`` and reports the mean of ``R_hat`` over the group, its standard deviation over the
group (run-to-run spread) and ``n``.

"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

from swimrl.evaluation.statistics import mean_std_sem
from swimrl.runs.layout import RunLayout
from swimrl.runs.records import csv_table, flatten, markdown_table

#: Keys never shown as swept: runtime settings, progress flags, bookkeeping.
IGNORED_KEYS = {
    "threads",
    "device",
    "kernel",
    "overwrite",
    "resume",
    "eval.progress",
    "train.progress",
    "train.stop_after_updates",
    "train.checkpoint_every",
    "train.checkpoint_seconds",
    "policy",
}
IGNORED_PREFIXES = ("hydra.", "strategy.", "compare.")
RESULT_COLUMNS = (
    "strategy",
    "R_hat_mean",
    "R_hat_sem",
    "R_hat_std",
    "n_flows",
    "n_swimmers",
    "ratio_to_first",
    "ratio_sem",
    "episodes",
)


def _records_from(path: Path, root: Path) -> list[dict]:
    data = json.loads(path.read_text())
    run = str(path.parent.relative_to(root)) or "."
    config = flatten(data.get("config", {}))
    if path.name == RunLayout(path.parent).comparison.name:
        return [
            {
                "run": run,
                "config": config,
                "strategy": row["label"],
                "R_hat_mean": row["R_hat_mean"],
                "R_hat_sem": row["R_hat_sem"],
                "R_hat_std": row["R_hat_std"],
                "n_flows": data.get("n_flows"),
                "n_swimmers": data.get("n_swimmers"),
                "ratio_to_first": row.get("ratio_to_first"),
                "ratio_sem": row.get("ratio_sem"),
            }
            for row in data["rows"]
        ]
    return [
        {
            "run": run,
            "config": config,
            "strategy": data.get("strategy", "?"),
            "R_hat_mean": data["R_hat_mean"],
            "R_hat_sem": data.get("R_hat_sem"),
            "R_hat_std": data.get("R_hat_std"),
            "n_flows": data.get("n_flows"),
            "n_swimmers": data.get("n_swimmers"),
            "episodes": data.get("training", {}).get("episodes"),
        }
    ]


def collect(root: Path) -> list[dict]:
    """All result records below ``root`` (sorted by path)."""
    root = Path(root)
    run = RunLayout(root)
    files = sorted(
        p
        for name in (run.metrics.name, run.comparison.name)
        for p in root.rglob(name)
        if ".hydra" not in p.parts
    )
    records = []
    for f in files:
        records.extend(_records_from(f, root))
    return records


def swept_keys(records: Iterable[dict]) -> list[str]:
    """Config keys with more than one value among ``records`` (in config order)."""
    records = list(records)
    keys: list[str] = []
    for r in records:
        keys.extend(k for k in r["config"] if k not in keys)
    out = []
    for k in keys:
        if k in IGNORED_KEYS or k.startswith(IGNORED_PREFIXES):
            continue
        values = {json.dumps(r["config"].get(k), sort_keys=True) for r in records}
        if len(values) > 1:
            out.append(k)
    return out


def _sort_key(value):
    if isinstance(value, bool) or value is None:
        return (1, str(value))
    if isinstance(value, int | float):
        return (0, float(value))
    return (1, str(value))


def build_rows(records: list[dict], average: Iterable[str] = ()) -> tuple[list[str], list[dict]]:
    """Table rows: swept keys + result columns; ``average`` keys are pooled."""
    keys = swept_keys(records)
    average = [a for a in average]
    rows = []
    for r in records:
        row = {"run": r["run"], **{k: r["config"].get(k) for k in keys}}
        row.update({c: r.get(c) for c in RESULT_COLUMNS})
        rows.append(row)
    if average:
        keys = [k for k in keys if k not in average]
        groups: dict[tuple, list[dict]] = {}
        for row in rows:
            gk = tuple(json.dumps(row[k]) for k in keys) + (row["strategy"],)
            groups.setdefault(gk, []).append(row)
        rows = []
        for members in groups.values():
            mean, std, sem = mean_std_sem([m["R_hat_mean"] for m in members])
            first = members[0]
            rows.append(
                {
                    **{k: first[k] for k in keys},
                    "strategy": first["strategy"],
                    "n_runs": len(members),
                    "R_hat_mean": mean,
                    "R_hat_std_runs": std,
                    "R_hat_sem_runs": sem,
                    "n_flows": first["n_flows"],
                    "n_swimmers": first["n_swimmers"],
                }
            )
    rows.sort(key=lambda row: tuple(_sort_key(row[k]) for k in keys) + (str(row["strategy"]),))
    return keys, rows


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def markdown(keys: list[str], rows: list[dict]) -> str:
    """The rows as a Markdown table."""
    averaged = bool(rows) and "n_runs" in rows[0]
    head = list(keys) + ["strategy"]
    if averaged:
        head += ["runs", "R_hat (mean +- std over runs)", "flows x swimmers"]
    else:
        head += ["R_hat (mean +- SEM)", "std over flows", "flows x swimmers", "ratio to first"]
        head.insert(0, "run")
    cells = []
    for r in rows:
        row = [_fmt(r[k]) for k in keys] + [str(r["strategy"])]
        size = f"{_fmt(r['n_flows'])} x {_fmt(r['n_swimmers'])}"
        if averaged:
            row += [str(r["n_runs"]), f"{r['R_hat_mean']:.4f} +- {r['R_hat_std_runs']:.4f}", size]
        else:
            ratio = ""
            if r.get("ratio_to_first") is not None:
                ratio = f"{r['ratio_to_first']:.3f} +- {r['ratio_sem']:.3f}"
            sem = "" if r["R_hat_sem"] is None else f" +- {r['R_hat_sem']:.4f}"
            std = "" if r["R_hat_std"] is None else f"{r['R_hat_std']:.4f}"
            row = [r["run"], *row, f"{r['R_hat_mean']:.4f}{sem}", std, size, ratio]
        cells.append(row)
    return markdown_table(head, cells)


def to_csv(keys: list[str], rows: list[dict]) -> str:
    """The rows as CSV (full precision)."""
    return csv_table(rows)
