"""``swimrl-dns-plots STORE``: figures and a JSON summary of a stored DNS run
(:mod:`swimrl.analysis.dns_plots`)."""

from __future__ import annotations

import argparse
import json

import torch

from swimrl.analysis.dns_plots import make_plots


def main(argv: list[str] | None = None) -> dict:
    """``swimrl-dns-plots <store> [--out DIR] [--snapshots M]``."""
    ap = argparse.ArgumentParser(description="Figures of a stored swimrl DNS run")
    ap.add_argument("store")
    ap.add_argument("--out", default="docs/img")
    ap.add_argument("--snapshots", type=int, default=50, help="snapshots averaged (evenly spaced)")
    ap.add_argument("--fit", type=float, nargs=2, default=(6.0, 40.0),
                    help="k range of the spectral slope fit")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    summary = make_plots(args.store, args.out, args.snapshots, tuple(args.fit))
    print(json.dumps(summary, indent=1))
    return summary


if __name__ == "__main__":
    main()
