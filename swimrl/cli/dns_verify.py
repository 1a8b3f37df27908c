"""``swimrl-dns-verify STORE [STORE ...]``: every check of a stored DNS run
(:func:`swimrl.flows.dns.verify.verify_store`), one line per check and a verdict per store;
exit status 0 if every store is clean, 1 if any check failed, 2 for a path that is not there."""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from swimrl.flows.dns.verify import verify_store


def main(argv: list[str] | None = None) -> int:
    """The console entry: prints the reports, returns the exit status."""
    ap = argparse.ArgumentParser(
        description="Check stored swimrl DNS runs: chunk checksums, finite snapshots, their rms "
                    "velocity against u_rms, energy and enstrophy against the diagnostics")
    ap.add_argument("store", nargs="+", help="zarr stores written by swimrl-dns")
    args = ap.parse_args(argv)
    missing = [s for s in args.store if not Path(s).exists()]
    if missing:
        ap.exit(2, f"error: no DNS store at {missing[0]}\n")
    torch.set_num_threads(1)
    reports = []
    for store in args.store:
        rep = verify_store(Path(store))
        print("\n".join(rep.lines()), flush=True)
        reports.append(rep)
    if len(reports) > 1:
        bad = [str(r.path) for r in reports if not r.clean]
        print(f"verdict: {len(reports) - len(bad)} of {len(reports)} stores clean"
              + (f"; problems in {', '.join(bad)}" if bad else ""))
    return 0 if all(r.clean for r in reports) else 1


if __name__ == "__main__":
    raise SystemExit(main())
