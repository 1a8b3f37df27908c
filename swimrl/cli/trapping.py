r"""``swimrl-trapping``: the trapping map of naive gyrotactic swimmers in the Taylor-Green flow.

    swimrl-trapping                                   # the 5 x 4 grid, 256 starts (~5 min)
    swimrl-trapping 'trapping.phi=[0.3]' 'trapping.psi=[0.3,1,3]'

For every $(\Phi, \Psi)$ of ``trapping.phi`` x ``trapping.psi``
(:func:`~swimrl.analysis.trapping.naive_map`): the trapped fraction and $\langle v_z\rangle/v_s$
of ``trapping.n_swimmers`` naive swimmers, beside the condition derived in ``docs/physics.md``
(:func:`~swimrl.analysis.trapping.trapping_condition`). Prints the table; writes
``trapping.json`` (the record), ``trapping.md`` and ``trapping.png`` to the run directory.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

from omegaconf import DictConfig

from swimrl.analysis.trapping import critical_psi, naive_map
from swimrl.cli import command, run_dir
from swimrl.config import record_of, runtime
from swimrl.errors import as_float, require
from swimrl.runs.atomic import atomic_write_text
from swimrl.runs.records import refuse_overwrite, write_json

log = logging.getLogger(__name__)
RECORD, TABLE, FIGURE = "trapping.json", "trapping.md", "trapping.png"


def _grid(key: str, values) -> list[float]:
    require(values is not None and len(values) > 0, key, values, "a non-empty list")
    return [as_float(key, v, lambda x: x > 0, "a list of numbers > 0") for v in values]


def check(cfg: DictConfig, out: Path | None) -> dict:
    """The grid and sizes checked; the records not replaced unless ``overwrite``."""
    t = cfg.trapping
    c = {"phi": _grid("trapping.phi", t.phi), "psi": _grid("trapping.psi", t.psi),
         "n_swimmers": int(as_float("trapping.n_swimmers", t.n_swimmers, lambda v: v >= 1,
                                    "an integer >= 1")),
         "duration": as_float("trapping.duration", t.duration, lambda v: v > 0, "> 0"),
         "burn_in": as_float("trapping.burn_in", t.burn_in,
                             lambda v: 0 <= v < float(t.duration),
                             f"in [0, trapping.duration={t.duration})"),
         "update_interval": as_float("trapping.update_interval", t.update_interval,
                                     lambda v: v > 0, "> 0")}
    if out is not None:
        for name in (RECORD, TABLE, FIGURE):
            refuse_overwrite(Path(out) / name, bool(cfg.overwrite))
    return c


def markdown(points: list[dict]) -> str:
    """The map as a table: trapped fraction (and ``<v_z>/v_s``) per point, the condition's
    prediction beside it."""
    phis = sorted({p["phi"] for p in points})
    psis = sorted({p["psi"] for p in points})
    at = {(p["phi"], p["psi"]): p for p in points}
    head = "| Φ \\ Ψ | " + " | ".join(f"{s:g}" for s in psis) + " | Ψ*(Φ) |"
    rows = [head, "|" + "---|" * (len(psis) + 2)]
    for f in phis:
        cells = []
        for s in psis:
            p = at[(f, s)]
            mark = "T" if p["predicted"] else "–"
            cells.append(f"{p['trapped']:.2f} ({p['vertical_velocity']:+.2f}) {mark}")
        rows.append(f"| {f:g} | " + " | ".join(cells) + f" | {critical_psi(f):.3g} |")
    return ("Trapped fraction of naive swimmers (<v_z>/v_s); T: the condition Φ < 1/2, "
            "Ψ < Ψ*(Φ) = (1 - 4Φ²)^-1/2 predicts an attracting fixed point.\n\n"
            + "\n".join(rows) + "\n")


def plot(points: list[dict], path: Path) -> None:
    """The trapped fraction over $(\\Phi, \\Psi)$ with the boundary $\\Psi^*(\\Phi)$."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    fig, ax = plt.subplots(figsize=(5.2, 4))
    sc = ax.scatter([p["phi"] for p in points], [p["psi"] for p in points],
                    c=[p["trapped"] for p in points], s=260, cmap="viridis", vmin=0, vmax=1,
                    edgecolors="k")
    phi = np.linspace(0.0, 0.4999, 400)
    ax.plot(phi, 1 / np.sqrt(1 - 4 * phi ** 2), "r-", label=r"$\Psi^* = (1-4\Phi^2)^{-1/2}$")
    ax.axvline(0.5, color="r", ls="--", lw=1, label=r"$\Phi = 1/2$")
    ax.set(xlabel=r"$\Phi = v_s/u_0$", ylabel=r"$\Psi = B\omega_0$", yscale="log",
           ylim=(0.05, 6), title="naive gyrotactic swimmers, Taylor-Green")
    fig.colorbar(sc, label="trapped fraction")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


@command("trapping", check=check)
def main(cfg: DictConfig) -> dict:
    out = run_dir()
    c = check(cfg, out)
    rt = runtime(cfg)
    rt.apply()
    points = naive_map(c["phi"], c["psi"], c["n_swimmers"], c["duration"], c["burn_in"],
                       c["update_interval"], float(cfg.episode.dt), int(cfg.seed), rt,
                       log.info)
    rows = [dataclasses.asdict(p) for p in points]
    table = markdown(rows)
    print(table, flush=True)
    atomic_write_text(out / TABLE, table)
    plot(rows, out / FIGURE)
    record = {"config": record_of(cfg), "points": rows}
    log.info("wrote %s", write_json(record, out / RECORD, overwrite=bool(cfg.overwrite)))
    return record


if __name__ == "__main__":
    main()
