#!/usr/bin/env bash
# The GPU checks of docs/training.md ("Training on a GPU") as one scripted run:
#   1. the gpu-marked tests (CUDA-graphed updates equal the eager ones; CUDA env = CPU env);
#   2. benchmarks/bench_train.py on the device: long_floor05, parallel and parallel_gpu,
#      compiled and CUDA-graphed;
#   3. a Ku = 10 run of train_preset=parallel_gpu from scratch (1e8 frames), wall-clock timed
#      from the command's start (compilation and graph capture included).
# Everything it writes lands in OUT as at most 8 flat files (benchmark output, test log,
# metrics.json, curves.csv, policy.pt, the periodic policies as one tar, train.log, wall.json).
#
#   benchmarks/gpu_session.sh OUT [DEVICE=cuda] [TOTAL_FRAMES=100000000] [EVAL_EVERY=48]
#
# DEVICE=cpu runs the same steps without CUDA graphs: a dry run of the script (use a small
# TOTAL_FRAMES). On a machine without torchrl/tensordict/hydra it installs the wheels of .whl/
# (benchmarks/gpu_wheels.sh) and swimrl itself into /tmp/site first.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:?usage: gpu_session.sh OUT [DEVICE] [TOTAL_FRAMES] [EVAL_EVERY]}
DEVICE=${2:-cuda}; FRAMES=${3:-100000000}; EVAL_EVERY=${4:-48}
PY=${PYTHON:-python3}
export PYTHONUNBUFFERED=1
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
if ! $PY -c "import torchrl, tensordict, hydra, zarr" 2>/dev/null; then
  $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
      --target /tmp/site .whl/*.whl
  $PY -m pip install -q --no-index --no-deps --no-build-isolation --no-compile --no-cache-dir \
      --target /tmp/site .
  export PYTHONPATH=/tmp/site
fi
if [ "${DEVICE%%:*}" = cuda ]; then
  VARIANTS=compiled,graphed; GRAPHS=train.cudagraphs=true; THREADS=4
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv | tee "$OUT/gpu_tests.log"
else
  VARIANTS=compiled; GRAPHS=; THREADS=1
fi
$PY -c "import torch, torchrl; print('torch', torch.__version__, 'torchrl', torchrl.__version__)" \
    | tee -a "$OUT/gpu_tests.log"

# 1. tests that need the device (skipped without CUDA)
$PY -m pytest -q -p no:cacheprovider -m gpu tests/test_train.py tests/test_gpu.py 2>&1 \
    | tee -a "$OUT/gpu_tests.log" || true

# 2. throughput, the layouts side by side (variants interleaved update by update)
$PY benchmarks/bench_train.py --device "$DEVICE" --threads $THREADS \
    --presets long_floor05,parallel,parallel_gpu --variants $VARIANTS ${BENCH_ARGS:---updates 5 --warmup 6} \
    2>&1 | grep -v Warning | tee "$OUT/bench_train_$DEVICE.txt"

# 3. the paper's budget at Ku = 10 from scratch, timed
RUN=/tmp/swimrl_gpu_run; rm -rf $RUN
t0=$(date +%s.%N)
$PY -c 'import sys; from swimrl.cli.train import main; sys.exit(main())' \
    train_preset=parallel_gpu flow.kubo=10 seed=0 device="$DEVICE" $GRAPHS threads=$THREADS \
    train.total_frames="$FRAMES" train.eval_every="$EVAL_EVERY" train.progress=false \
    hydra.run.dir=$RUN 2>&1 | grep -v Warning | tee "$OUT/train.log"
t1=$(date +%s.%N)
$PY - "$t0" "$t1" "$RUN" "$OUT" <<'PY'
import json, sys
t0, t1, run, out = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3], sys.argv[4]
m = json.load(open(f"{run}/metrics.json"))
rec = {"wall_s": t1 - t0, "frames": m["training"]["frames"],
       "frames_per_s_wall": m["training"]["frames"] / (t1 - t0),
       "frames_per_s_training": m["training"]["frames_per_s"],
       "R_hat_final": m["R_hat_mean"], "R_hat_sem": m["R_hat_sem"]}
json.dump(rec, open(f"{out}/wall.json", "w"), indent=1)
print(rec)
PY
cp $RUN/metrics.json $RUN/curves.csv $RUN/policy.pt "$OUT/"
tar -cf "$OUT/policies.tar" -C $RUN policies .hydra
