"""``swimrl-dns``: spin a DNS up to a statistically steady state and store it.

    swimrl-dns                                   # 512^2 -> data/dns/dns_n512_seed0.zarr
    swimrl-dns dns.n=256 store.n_times=500 store.overwrite=true
    swimrl-dns store.n_times=5000 store.extend=true   # append to a finished store

See ``conf/dns.yaml``, ``conf/solver/dns.yaml`` and ``docs/dns.md``.
"""

from __future__ import annotations

import torch
from omegaconf import DictConfig, OmegaConf

from swimrl.cli import command
from swimrl.config import dns_run, dns_runtime
from swimrl.flows.dns.run import check_run, run_dns, summary


@command("dns", check=lambda cfg, out: check_run(dns_run(cfg)))
def main(cfg: DictConfig) -> None:
    run = dns_run(cfg)
    threads = dns_runtime(cfg).threads
    if threads:  # null: torch's default
        torch.set_num_threads(threads)
    path = run_dns(run)
    print(OmegaConf.to_yaml(OmegaConf.create(summary(path))))


if __name__ == "__main__":  # pragma: no cover
    main()
