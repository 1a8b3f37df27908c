#!/bin/bash
# Robustness sweeps (Figs. robustness-noise and robustness) at Ku = 10 with the protocol's policy of training seed S.
# Usage: run_robustness.sh S FIGURE   (FIGURE: robustness | robustness-noise)
cd /work/frozen
S=$1; F=$2
D=logs/three_seeds/robustness/ku10_seed$S
mkdir -p $D/png
echo "=== $F seed $S start $(date -u +%T)"
CMD=".venv/bin/swimrl-figures only=$F policies=logs/three_seeds/policies/seed$S records=$D out=$D/png cache=logs/three_seeds/cache figures.refresh=[$F] threads=1 progress=false"
echo "$CMD" >> $D/commands.txt
/usr/bin/time -f "$F seed $S wall %e s maxrss %M kB" $CMD
echo "=== $F seed $S end $(date -u +%T)"
