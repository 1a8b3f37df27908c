"""``swimrl-dns-plots STORE``: figures and a JSON summary of a stored DNS run
(:mod:`swimrl.analysis.dns_plots`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from swimrl.analysis.dns_plots import check_stores, make_plots
from swimrl.cli import one_line_errors


def run(argv: list[str] | None = None) -> dict:
    """``swimrl-dns-plots <store> [<store> ...] [--out DIR] [--snapshots M]``; by default the
    figures go next to the store, into ``<store>_plots/`` (never into the repository's
    ``docs/``); with several stores (or ``--checks``) also the checks across them into
    ``--out`` (default ``dns_checks/`` next to the first store), which keeps each run's
    record in ``runs/`` so that runs can be added later without their stores."""
    ap = argparse.ArgumentParser(description="Figures of stored swimrl DNS runs")
    ap.add_argument("store", nargs="+")
    ap.add_argument("--out", default=None,
                    help="directory of the figures (default: <store>_plots next to the store)")
    ap.add_argument("--snapshots", type=int, default=50, help="snapshots averaged (evenly spaced)")
    ap.add_argument("--fit", type=float, nargs=2, default=(6.0, 40.0),
                    help="k range of the spectral slope fit")
    ap.add_argument("--checks", action="store_true",
                    help="add the store(s) to the checks across runs in --out (the default "
                         "with several stores); runs already recorded there are kept")
    args = ap.parse_args(argv)
    if args.snapshots < 1:
        ap.error(f"--snapshots {args.snapshots}: allowed an integer >= 1")
    torch.set_num_threads(1)
    if len(args.store) > 1 or args.checks:
        out = args.out or str(Path(args.store[0]).parent / "dns_checks")
        summary = check_stores([Path(s) for s in args.store], Path(out), args.snapshots,
                               tuple(args.fit))
        shown = {k: v for k, v in summary.items() if k != "pooled_pdfs"}  # curves: in the file
        print(json.dumps(shown, indent=1))
        return summary
    out = args.out or str(Path(args.store[0]).with_suffix("")) + "_plots"
    summary = make_plots(args.store[0], out, args.snapshots, tuple(args.fit))
    print(json.dumps(summary, indent=1))
    return summary


@one_line_errors
def main(argv: list[str] | None = None) -> int:
    """The console entry: :func:`run`, exit status 0 (its summary is printed, not returned);
    a missing store is one ``error:`` line with status 2, a corrupt one (a damaged chunk, an
    impossible snapshot) with status 1."""
    run(argv)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
