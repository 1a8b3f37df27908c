"""Result records on disk: atomic JSON files, and the one Markdown / CSV table writer.

``metrics.json`` (``swimrl-eval``, ``swimrl-train``), ``comparison.json`` (``swimrl-compare``)
and the other records are written with :func:`write_json` (atomically:
:func:`swimrl.runs.atomic.atomic_write`; an existing record is never replaced unless asked; standard
JSON only: a record holding NaN or an infinity is refused and nothing is written). Every table
the commands print or write goes through :func:`markdown_table` / :func:`csv_table`.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from swimrl.errors import NonFiniteError
from swimrl.flows.labels import ku_display
from swimrl.runs.atomic import atomic_write, atomic_write_text
from swimrl.runs.layout import RunLayout


def refuse_overwrite(path: Path, overwrite: bool) -> None:
    """``FileExistsError`` if ``path`` exists and ``overwrite`` is false."""
    if Path(path).exists() and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=true to replace it")


def nonfinite_entry(record, key: str = "") -> str | None:
    """``KEY=VALUE`` of the first NaN or infinite number in ``record`` (nested), else None."""
    if isinstance(record, float) and not math.isfinite(record):
        return f"{key or 'value'}={record}"
    items = record.items() if isinstance(record, dict) else (
        enumerate(record) if isinstance(record, list | tuple) else ())
    for k, v in items:
        found = nonfinite_entry(v, f"{key}.{k}" if key else str(k))
        if found is not None:
            return found
    return None


def write_json(record: dict, path: Path, overwrite: bool = True) -> Path:
    """Write ``record`` as standard JSON atomically (refusing to replace ``path`` unless
    ``overwrite``); a NaN or infinite number raises :class:`~swimrl.errors.NonFiniteError`
    and nothing is written."""
    path = Path(path)
    refuse_overwrite(path, overwrite)
    bad = nonfinite_entry(record)
    if bad is not None:
        raise NonFiniteError(f"{path} not written: {bad} is not finite")
    return atomic_write_text(path, json.dumps(record, indent=2, allow_nan=False))


def write_npz(data: dict, path: Path) -> Path:
    """Write the arrays ``data`` to ``path`` (``.npz``, compressed) atomically, making its
    directory."""
    return atomic_write(path, lambda fh: np.savez_compressed(fh, **data), make_dirs=True)


def read_npz(path: Path) -> dict:
    """Every array of an ``.npz`` file, loaded."""
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def markdown_table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """``| a | b |`` lines: a header, its ``|---|`` rule and one line per row."""
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def csv_table(rows: Sequence[dict]) -> str:
    """Rows (dicts) as CSV with the union of their keys as columns; None as empty."""
    cols: list[str] = []
    for r in rows:
        cols.extend(c for c in r if c not in cols)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({c: "" if r.get(c) is None else r.get(c) for c in cols})
    return buf.getvalue()


def flatten(d: dict, prefix: str = "") -> dict:
    """``{"a": {"b": 1}} -> {"a.b": 1}``; lists become strings like ``[n_r, n_theta]``."""
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, key + "."))
        elif isinstance(v, list):
            out[key] = "[" + ", ".join(str(x) for x in v) + "]"
        else:
            out[key] = v
    return out


def score_name(config: dict) -> str:
    """The printed name of a record's score: ``<v_z>/v_s`` for ``task=vertical``, else
    ``R_hat`` (the key in the records is ``R_hat_*`` for every task)."""
    vertical = (config.get("task") or {}).get("name") == "vertical"
    return "<v_z>/v_s" if vertical else "R_hat"


def summary_line(m: dict) -> str:
    """One line: strategy, flow, the score (R_hat or <v_z>/v_s) +- SEM, size, time and
    speed."""
    return (
        f"{m['strategy']} {ku_display(m['config']['flow'], '=')}: "
        f"{score_name(m['config'])} = {m['R_hat_mean']:.4f} +- "
        f"{m['R_hat_sem']:.4f} (SEM; std over flows {m['R_hat_std']:.4f}) over {m['n_flows']} "
        f"flows x {m['n_swimmers']} swimmers; {m['wall_s']:.1f} s, "
        f"{m['swimmer_substeps_per_s']:.3g} swimmer-substeps/s"
        + (f"; E_hat = {m['energy_mean']:.4f}" if "energy_mean" in m else "")
        + (f"; arrived {m['arrival_mean']:.4f} +- {m['arrival_sem']:.4f}"
           if "arrival_mean" in m else "")
        + (f"; trapped {m['trapped_mean']:.4f} +- {m['trapped_sem']:.4f}"
           if "trapped_mean" in m else "")
    )


def comparison_markdown(record: dict) -> str:
    """A ``comparison.json`` record as a Markdown table (paired ratios to the first row)."""
    first = record["rows"][0]["label"]
    title = (f"{ku_display(record['config']['flow'])}, {record['n_flows']} flows x "
             f"{record['n_swimmers']} swimmers, seed {record['seed']}\n\n")
    if record.get("task") == "target":
        title = (f"target at {record['target_distance']:g} ell_f, arrival radius "
                 f"{record['arrival_radius']:g} ell_f; " + title)
    head = ["strategy", f"{score_name(record['config'])} (mean +- SEM)", "std over flows",
            f"ratio to {first} (paired)"]
    rows = [[r["label"], f"{r['R_hat_mean']:.4f} +- {r['R_hat_sem']:.4f}",
             f"{r['R_hat_std']:.4f}", f"{r['ratio_to_first']:.3f} +- {r['ratio_sem']:.3f}"]
            for r in record["rows"]]
    if all("energy_mean" in r for r in record["rows"]):
        head.append("E_hat (mean +- SEM)")
        for row, r in zip(rows, record["rows"], strict=True):
            row.append(f"{r['energy_mean']:.4f} +- {r['energy_sem']:.4f}")
    if all("shape_change_mean" in r for r in record["rows"]):
        head.append("C_hat (mean +- SEM)")
        for row, r in zip(rows, record["rows"], strict=True):
            row.append(f"{r['shape_change_mean']:.4f} +- {r['shape_change_sem']:.4f}")
    if all("trapped_mean" in r for r in record["rows"]):
        head.append("trapped (mean +- SEM)")
        for row, r in zip(rows, record["rows"], strict=True):
            row.append(f"{r['trapped_mean']:.4f} +- {r['trapped_sem']:.4f}")
    if all("arrival_mean" in r for r in record["rows"]):
        head += ["arrived (mean +- SEM)", f"arrived - {first} (paired)",
                 "arrival time mean / median of the arrived (tau_K)", "final distance (ell_f)"]
        for row, r in zip(rows, record["rows"], strict=True):
            times = ("-" if r["arrival_time_mean"] is None else
                     f"{r['arrival_time_mean']:.1f} / {r['arrival_time_median']:.1f}")
            row += [f"{r['arrival_mean']:.4f} +- {r['arrival_sem']:.4f}",
                    f"{r['arrival_minus_first']:+.4f} +- {r['arrival_minus_first_sem']:.4f}",
                    times,
                    f"{r['final_distance_mean']:.2f} +- {r['final_distance_sem']:.2f}"]
        if all("arrival_time_rmst_mean" in r for r in record["rows"]):
            # censoring-aware (every swimmer counts): F(t) = 1/2, E[min(t_arrival, T)]
            head += ["half arrived by (tau_K)", "restricted mean time (tau_K)"]
            for row, r in zip(rows, record["rows"], strict=True):
                half = r["arrival_time_half"]
                row += ["> T" if half is None else f"{half:.1f}",
                        f"{r['arrival_time_rmst_mean']:.2f} +- {r['arrival_time_rmst_sem']:.2f}"]
    return title + markdown_table(head, rows)


def write_comparison(record: dict, out: Path) -> str:
    """``comparison.json`` (atomic) and ``comparison.md`` in ``out``; returns the table."""
    run = RunLayout(out)
    write_json(record, run.comparison)
    table = comparison_markdown(record)
    atomic_write_text(run.comparison_table, table)
    return table
