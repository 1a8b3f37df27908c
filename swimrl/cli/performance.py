r"""``swimrl-performance DIR... --out PNG``: smart vs STO vs naive across Ku (Fig.
smartPerformance(a)) from ``comparison.json`` files (:mod:`swimrl.analysis.performance`).

    swimrl-performance docs/results/smart_ku_sweep --out docs/img/smart_performance.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

from swimrl.analysis.performance import load, markdown, summarise
from swimrl.analysis.plots import plot_performance
from swimrl.runs.atomic import atomic_write_text


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="swimrl-performance",
        description="smart vs STO vs naive across Ku from comparison.json files",
    )
    ap.add_argument("paths", nargs="+", type=Path, help="comparison.json files or directories")
    ap.add_argument("--out", type=Path, default=None, help="PNG path (default: no plot)")
    ap.add_argument("--md", type=Path, default=None, help="also write the table to this file")
    ap.add_argument("--exclude", action="append", default=[],
                    help="leave out policy rows whose label contains this (repeatable)")
    args = ap.parse_args(argv)
    summaries = [summarise(r, tuple(args.exclude)) for r in load(args.paths)]
    table = markdown(summaries)
    print(table)
    if args.md is not None:
        atomic_write_text(args.md, table + "\n", make_dirs=True)
        print(f"wrote {args.md}")
    if args.out is not None:
        plot_performance(summaries, args.out)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
