#!/bin/bash
# Fig. ablation (b) per Ku and training seed: smart (protocol policy of seed S), the minimal model fitted to it
# (logs/three_seeds/minimal_fits/seedS/kuK, 20 x 500) and STO on 20 flows x 500 (test seed 0).
# Usage: run_ablation_b.sh S K
cd /work/frozen
S=$1; K=$2
D=logs/three_seeds/ablation_b/ku${K}_seed$S
FITS=logs/three_seeds/fits_one/seed${S}_ku$K
mkdir -p $D/png $FITS
ln -sfn ../../minimal_fits/seed$S/ku$K $FITS/ku$K
echo "=== ablation seed $S ku $K start $(date -u +%T)"
CMD=".venv/bin/swimrl-figures only=ablation policies=logs/three_seeds/policies/seed$S fits=$FITS records=$D out=$D/png cache=logs/three_seeds/cache figures.refresh=[ablation] threads=1 progress=false"
echo "$CMD" >> $D/commands.txt
/usr/bin/time -f "ablation seed $S ku $K wall %e s maxrss %M kB" $CMD
echo "=== ablation seed $S ku $K end $(date -u +%T)"
