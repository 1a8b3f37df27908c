"""Figure records (:func:`figure_record`): one JSON file per figure, ``<records>/<figure>.json``
(``docs/results/figures/``, committed), holding every number the figure draws in its titles
and the docs quote, and what they were computed from:

* ``format`` (:data:`RECORD_FORMAT`), ``figure``, ``command`` (the command that makes it);
* ``sizes``: ``{group: {n_flows, n_swimmers, flows_per_batch}}``: the one size of each group
  of evaluations (``sweep``, ``statistics``, ``trajectories``); every evaluation of a group
  has it (a record with mixed sizes is refused);
* ``seed``, ``dtype``, ``params`` (the swimmer and episode of every evaluation,
  :class:`~swimrl.env.EnvParams`), ``sources`` (``{path: sha256}`` of the committed files
  the figure reads besides the policies: comparisons, fits, run directories' records);
* ``evaluations``: ``{key: {group, setup: {flow (with kubo), changed (fields of params
  changed), n_flows, n_swimmers, flows_per_batch, seed}, actors: {name shown: actor},
  files: {actor: sha256 of its policy file}, per_flow: {name: [R_hat of each flow]},
  counts (where the evaluation counts samples), derived}}``;
* ``derived``: the figure's numbers (means, std over flows, paired ratios with their SEM,
  the S_nn statistic per seed, correlations).

A record is read only when it was made for what the config would evaluate now: its format,
sizes, seeds, flows, swimmer and episode, actors, the sha256 of every policy file and of every
source must be the current ones; otherwise it is refused (:class:`~swimrl.errors.ConfigError`,
one line naming the file, the field, the recorded and the current value, and how to remake it:
``figures.refresh=[<figure>]`` or deleting the file), never recomputed or replaced silently.
A missing record (or one named in ``figures.refresh``) is computed through the cached
evaluations and written atomically. A field added to the code after a record was made is
added to that record by :func:`extend_record`, which changes no other field.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict
from pathlib import Path

import numpy as np

from swimrl.errors import BadFileError, ConfigError
from swimrl.runs.policy_files import resolve_policy_file, sha256_file
from swimrl.runs.records import write_json

from .evaluations import Evaluation, is_policy
from .settings import FiguresConfig, portable

#: Version of the figure-record format; a record of another version is refused.
RECORD_FORMAT = 1


def plain(value):
    """``value`` as standard JSON holds it (tuples as lists, paths and dtypes as strings,
    numpy numbers as Python numbers, NaN and infinities as None)."""
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [plain(v) for v in (value.tolist() if isinstance(value, np.ndarray) else value)]
    if isinstance(value, bool | type(None) | str | int):
        return value
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return str(value)


def evaluation_identity(cfg: FiguresConfig, ev: Evaluation) -> dict:
    """What an evaluation of a record is made from: its group, setup (flow with kubo, the
    fields of ``cfg.params`` it changes, sizes, seed), actors and the sha256 of each policy
    file."""
    s = ev.setup
    base, now = asdict(cfg.params), asdict(s.params)
    return plain({
        "group": ev.group,
        "setup": {"flow": asdict(s.flow), "changed": {k: v for k, v in now.items()
                                                      if base[k] != v},
                  "n_flows": s.sizes.n_flows, "n_swimmers": s.sizes.n_swimmers,
                  "flows_per_batch": s.sizes.flows_per_batch, "seed": s.seed,
                  **({"options": dict(ev.options)} if ev.options else {})},
        "actors": dict(ev.actors),
        "files": {a: sha256_file(resolve_policy_file(a)) for a in ev.actors.values()
                  if is_policy(a)},
    })


def record_identity(cfg: FiguresConfig, figure: str, evaluations: list[Evaluation],
                    sources: Iterable[Path] = ()) -> dict:
    """The fields of ``figure``'s record that the config determines (what it is made for):
    every field but the values (``per_flow``, ``counts``, ``derived``)."""
    evals = {ev.key: evaluation_identity(cfg, ev) for ev in evaluations}
    sizes: dict[str, dict] = {}
    for e in evals.values():
        sizes.setdefault(e["group"], {k: e["setup"][k] for k in
                                      ("n_flows", "n_swimmers", "flows_per_batch")})
    return plain({"format": RECORD_FORMAT, "figure": figure,
                  "command": f"swimrl-figures only={figure}", "sizes": sizes,
                  "seed": cfg.seed, "dtype": str(cfg.runtime.dtype),
                  "params": asdict(cfg.params),
                  "sources": {portable(p): sha256_file(p) for p in sorted(sources)},
                  "evaluations": evals})


#: The fields of a record compared with the current config, in the order they are checked.
IDENTITY_FIELDS = ("format", "figure", "sizes", "seed", "dtype", "params", "sources",
                   "evaluations")
#: The fields of an evaluation compared with the current config.
EVALUATION_FIELDS = ("group", "setup", "actors", "files")


def _short(value, width: int = 90) -> str:
    text = json.dumps(value, sort_keys=True) if not isinstance(value, str) else repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def _remake(path: Path, figure: str) -> str:
    return f"remake it with figures.refresh=[{figure}] (or delete {path})"


def first_difference(recorded, current, key: str) -> tuple[str, object, object] | None:
    """``(field, recorded value, current value)`` of the first nested entry where the two
    differ (dicts key by key, in the current one's order, then the recorded one's extra
    keys), or None."""
    if isinstance(recorded, dict) and isinstance(current, dict):
        if list(recorded) != list(current) and set(recorded) != set(current):
            missing = [k for k in current if k not in recorded]
            extra = [k for k in recorded if k not in current]
            name = missing[0] if missing else extra[0]
            return (f"{key}.{name}", recorded.get(name, "(absent)"),
                    current.get(name, "(absent)"))
        for k in current:
            found = first_difference(recorded[k], current[k], f"{key}.{k}")
            if found:
                return found
        return None
    return None if recorded == current else (key, recorded, current)


def read_figure_record(path: Path) -> dict:
    """A figure record, checked on its own: readable JSON of :data:`RECORD_FORMAT`, every
    evaluation of its group's size, one per-flow value per flow and strategy (else one
    :class:`~swimrl.errors.BadFileError` / :class:`~swimrl.errors.ConfigError` line)."""
    path = Path(path)
    try:
        rec = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadFileError(f"{path}: not a readable figure record ({exc}); allowed: a record "
                           "written by swimrl-figures, or delete it to remake it") from exc
    figure = rec.get("figure", "?") if isinstance(rec, dict) else "?"
    if not isinstance(rec, dict) or rec.get("format") != RECORD_FORMAT:
        got = rec.get("format") if isinstance(rec, dict) else None
        raise ConfigError(f"{path}: format = {got!r} in the record, {RECORD_FORMAT} now; "
                          + _remake(path, figure))
    check_record(path, rec)
    return rec


def check_record(path: Path, rec: dict) -> None:
    """One size per group: each evaluation's sizes are its group's (``sizes``), and it holds
    ``n_flows`` per-flow values of each of its strategies; else one BadFileError line."""
    figure = rec.get("figure", "?")
    sizes = rec.get("sizes") or {}
    for key, ev in (rec.get("evaluations") or {}).items():
        group, setup = ev.get("group"), ev.get("setup") or {}
        if group not in sizes:
            raise BadFileError(f"{path}: evaluations.{key}.group = {group!r} has no sizes "
                               f"(sizes: {sorted(sizes)}); " + _remake(path, figure))
        for k, want in sizes[group].items():
            if setup.get(k) != want:
                raise BadFileError(
                    f"{path}: evaluations.{key}.setup.{k} = {setup.get(k)!r} but "
                    f"sizes.{group}.{k} = {want!r}: mixed sizes in one record; "
                    + _remake(path, figure))
        per = ev.get("per_flow") or {}
        if list(per) != list(ev.get("actors") or {}):
            raise BadFileError(f"{path}: evaluations.{key}.per_flow holds {list(per)}, its "
                               f"actors are {list(ev.get('actors') or {})}; "
                               + _remake(path, figure))
        for name, values in per.items():
            if len(values) != setup.get("n_flows"):
                raise BadFileError(
                    f"{path}: evaluations.{key}.per_flow.{name} holds {len(values)} flows, "
                    f"its setup.n_flows = {setup.get('n_flows')}: mixed sizes in one record; "
                    + _remake(path, figure))


def refuse_stale(path: Path, rec: dict, expected: dict) -> None:
    """ConfigError (one line: file, field, recorded and current value, how to remake it)
    unless ``rec`` was made for ``expected`` (:func:`record_identity`)."""
    def refuse(field_name: str, recorded, current) -> None:
        raise ConfigError(f"{path}: {field_name} = {_short(recorded)} in the record, "
                          f"{_short(current)} now; " + _remake(path, expected["figure"]))

    for name in IDENTITY_FIELDS:
        if name == "evaluations":
            continue
        found = first_difference(rec.get(name), expected[name], name)
        if found:
            refuse(*found)
    have, want = rec.get("evaluations") or {}, expected["evaluations"]
    if list(have) != list(want):
        refuse("evaluations", list(have), list(want))
    for key, ev in want.items():
        for name in EVALUATION_FIELDS:
            found = first_difference(have[key].get(name), ev[name],
                                     f"evaluations.{key}.{name}")
            if found:
                refuse(*found)


def figure_record(cfg: FiguresConfig, figure: str, evaluations: list[Evaluation],
                  compute: Callable[[Evaluation], dict],
                  derive: Callable[[dict], dict] | None = None,
                  sources: Iterable[Path] = ()) -> dict:
    """``figure``'s record ``<records>/<figure>.json``: read and checked against what the
    config evaluates now (:func:`refuse_stale`) where it exists; else (or with ``figure``
    in ``figures.refresh``) made: ``compute(ev)`` gives each evaluation's ``per_flow`` (and
    ``counts``, ``derived``), ``derive(record)`` the figure's ``derived`` numbers; written
    atomically."""
    path = Path(cfg.records) / f"{figure}.json"
    expected = record_identity(cfg, figure, evaluations, sources)
    if path.exists() and figure not in cfg.refresh:
        rec = read_figure_record(path)
        refuse_stale(path, rec, expected)
        return rec
    rec = dict(expected)
    rec["evaluations"] = {ev.key: {**expected["evaluations"][ev.key], **plain(compute(ev))}
                          for ev in evaluations}
    rec["derived"] = plain(derive(rec)) if derive is not None else {}
    check_record(path, rec)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json(rec, path)
    return rec


def record_sizes(rec: dict, group: str) -> tuple[int, int]:
    """``(n_flows, n_swimmers)`` of a record's group."""
    s = rec["sizes"][group]
    return int(s["n_flows"]), int(s["n_swimmers"])


def extend_record(cfg: FiguresConfig, rec: dict, edit: Callable[[dict], None]) -> dict:
    """``rec`` (a figure record as read or made by :func:`figure_record`) with ``edit``'s
    additions, written back (``<records>/<figure>.json``) where they change it; ``edit``
    adds fields and must change none (checked: every value of ``rec`` is kept)."""
    new = json.loads(json.dumps(rec))
    edit(new)
    new = plain(new)
    if new == rec:
        return rec
    lost = _changed(rec, new)
    if lost:
        raise AssertionError(f"extend_record changed {lost}: it may only add fields")
    path = Path(cfg.records) / f"{rec['figure']}.json"
    check_record(path, new)
    write_json(new, path)
    return new


def _changed(old, new, key: str = "") -> str | None:
    """The first entry of ``old`` that ``new`` does not keep as it was (None: only added)."""
    if isinstance(old, dict) and isinstance(new, dict):
        for k, v in old.items():
            if k not in new:
                return f"{key}.{k} (removed)"
            found = _changed(v, new[k], f"{key}.{k}")
            if found:
                return found
        return None
    return None if old == new else key
