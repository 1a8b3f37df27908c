r"""``swimrl-table-search``: the best 12-state table of the vertical-migration problem.

    swimrl-table-search                                  # Phi = 0.3, Psi = 1 (~15 min)
    swimrl-table-search swimmer.psi=3 table_search.n_random_starts=1

Coordinate ascent over the $4^{12}$ tables (:mod:`swimrl.analysis.table_search`) with the
swimmer, episode and task of the config (``actuation=steer``, ``task=vertical``,
``flow=taylor_green``); prints each sweep and the best table, writes ``table_search.json``.
"""

from __future__ import annotations

import logging
from pathlib import Path

from omegaconf import DictConfig

from swimrl.analysis.table_search import coordinate_ascent
from swimrl.cli import command, run_dir
from swimrl.config import env_params, record_of, runtime
from swimrl.errors import as_float, as_int, require
from swimrl.policies.steering import parse_table, table_text
from swimrl.runs.records import refuse_overwrite, write_json

log = logging.getLogger(__name__)
RECORD = "table_search.json"


def check(cfg: DictConfig, out: Path | None) -> dict:
    """The settings checked (a steering swimmer with ``task=vertical`` in Taylor-Green);
    the record not replaced unless ``overwrite``."""
    t = cfg.table_search
    params = env_params(cfg)
    require(str(cfg.flow.name) == "taylor_green", "flow", cfg.flow.name, "taylor_green")
    require(params.task.vertical, "task", params.task.name, "vertical")
    require(params.actuation.name == "steer", "actuation", params.actuation.name, "steer")
    c = {"params": params,
         "n_swimmers": as_int("table_search.n_swimmers", t.n_swimmers, low=1),
         "n_random_starts": as_int("table_search.n_random_starts", t.n_random_starts, low=0),
         "max_sweeps": as_int("table_search.max_sweeps", t.max_sweeps, low=1),
         "tol": as_float("table_search.tol", t.tol, lambda v: v >= 0, ">= 0"),
         "search_seed": as_int("table_search.search_seed", t.search_seed, low=0),
         "starts": [parse_table(x) for x in t.starts]}
    if out is not None:
        refuse_overwrite(Path(out) / RECORD, bool(cfg.overwrite))
    return c


@command("table_search", check=check)
def main(cfg: DictConfig) -> dict:
    out = run_dir()
    c = check(cfg, out)
    rt = runtime(cfg)
    rt.apply()
    res = coordinate_ascent(c["params"], c["n_swimmers"], int(cfg.seed), rt,
                            c["n_random_starts"], c["max_sweeps"], c["tol"], c["search_seed"],
                            c["starts"], log.info)
    for r in res.starts:
        r["table_text"] = table_text(r["table"])
        r["start_text"] = table_text(r["start"])
    record = {"config": record_of(cfg), "best_table": table_text(res.table),
              "best_value": res.value, "evaluations": res.evaluations, "starts": res.starts}
    print(f"best table {table_text(res.table)}: <v_z>/v_s = {res.value:.4f} "
          f"({res.evaluations} table evaluations)", flush=True)
    log.info("wrote %s", write_json(record, out / RECORD, overwrite=bool(cfg.overwrite)))
    return record


if __name__ == "__main__":
    main()
