#!/bin/bash
# Minimal-model fits (swimrl-fit-minimal) of the protocol's three policies per Ku, 20 flows x 500, test seed 0.
cd /work/frozen
for S in 0 1 2; do
  echo "=== seed $S start $(date -u +%T)"
  /usr/bin/time -f "seed $S wall %e s maxrss %M kB" .venv/bin/swimrl-fit-minimal -m flow.kubo=0.1,1,10,1e7 \
    "policy='docs/results/paper_runs/ku\${ku:\${flow.kubo}}_seed$S'" \
    eval.n_flows=20 eval.n_swimmers=500 threads=1 \
    hydra.sweep.dir=logs/three_seeds/minimal_fits/seed$S "hydra.sweep.subdir='ku\${ku:\${flow.kubo}}'"
  echo "=== seed $S end $(date -u +%T)"
done
