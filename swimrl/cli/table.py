r"""``swimrl-table DIR``: one Markdown/CSV table of every result below a sweep directory.

    swimrl-table multirun/train/2026-01-01_12-00-00 --md table.md --csv table.csv
    swimrl-table multirun/train/2026-01-01_12-00-00 --average seed

See :mod:`swimrl.analysis.table` for the columns and ``--average``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from swimrl.analysis.table import build_rows, collect, markdown, swept_keys, to_csv
from swimrl.runs.atomic import atomic_write_text


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="swimrl-table", description="one table of all results under a sweep directory"
    )
    p.add_argument("dir", type=Path, help="sweep (or any) directory to search for results")
    p.add_argument("--csv", type=Path, help="write the table as CSV here")
    p.add_argument("--md", type=Path, help="write the table as Markdown here")
    p.add_argument(
        "--average", action="append", default=[], metavar="KEY", help="pool runs over KEY"
    )
    args = p.parse_args(argv)
    if not args.dir.is_dir():
        p.error(f"{args.dir} is not a directory")
    records = collect(args.dir)
    if not records:
        p.error(f"no metrics.json or comparison.json below {args.dir}")
    swept = swept_keys(records)
    for key in args.average:
        if key not in swept:
            p.error(f"--average {key}: not a key that varies between these results "
                    f"(allowed: {', '.join(swept) or 'none'})")
    keys, rows = build_rows(records, args.average)
    md = markdown(keys, rows)
    if args.md:
        atomic_write_text(args.md, md)
    if args.csv:
        atomic_write_text(args.csv, to_csv(keys, rows))
    sys.stdout.write(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
