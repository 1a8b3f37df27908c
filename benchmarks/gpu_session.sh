#!/usr/bin/env bash
# The GPU checks of docs/training.md ("On a GPU") as one scripted run:
#   1. the gpu-marked tests (CUDA-graphed updates equal the eager ones; CUDA env = CPU env);
#   2. benchmarks/bench_train.py on the device: long_floor05, wide, parallel_gpu and wide_gpu,
#      compiled and CUDA-graphed;
#   3. benchmarks/bench_env.py on the device: the env step of 256 x 64 = 16384 swimmers (the GPU
#      floor's batch), eager against compiled;
#   4. benchmarks/bench_eval.py on the device: one evaluation of 16 flows x 32 swimmers over one
#      episode (the periodic evaluation's size), compiled kernel;
#   5. a Ku = 10 run of train_preset=wide_gpu from scratch (1e8 frames), wall-clock timed
#      from the command's start (compilation and graph capture included).
# Everything it writes lands in OUT as at most 10 flat files: gpu_tests.log (device, versions,
# where swimrl was imported from, step 1), bench_train_DEV.txt, bench_env_DEV.txt,
# bench_eval_DEV.txt, train.log, wall.json, metrics.json, curves.csv, policy.pt and the
# periodic policies with the run's .hydra/ as policies.tar. A failed step is reported at the
# end (exit status 1) without stopping the steps after it.
#
#   benchmarks/gpu_session.sh OUT [DEVICE=cuda] [TOTAL_FRAMES=100000000] [EVAL_EVERY=48]
#
# Every Python step runs in a scratch directory outside the source tree (the benchmarks by
# absolute path, the training as `python -m swimrl.cli.train`, the tests from a copy of tests/),
# so the *installed* swimrl is what is imported: from the repository root the source tree's
# swimrl/ would shadow the install, and it has no swimrl.conf (shipped from conf/). The install:
# the interpreter's own when it imports torchrl, tensordict, hydra, zarr and swimrl.conf;
# otherwise the wheels of .whl/ (benchmarks/gpu_wheels.sh) and swimrl itself are installed into
# $SITE (default /tmp/site), first on PYTHONPATH; with the dependencies at hand but no swimrl,
# swimrl alone.
#
# DEVICE=cpu runs the same steps without CUDA graphs: a dry run of the script (use a small
# TOTAL_FRAMES), e.g. `benchmarks/gpu_session.sh /tmp/out cpu 262144 1`. Environment:
#   PYTHON=python3    the interpreter
#   SMOKE=1           every benchmark at its --smoke size and the training run on a 64^2 grid
#                     with 2 x 4 swimmers, eager (the dry run of tests/test_benchmarks.py,
#                     seconds; e.g. `SMOKE=1 SKIP_TESTS=1 gpu_session.sh OUT cpu 160 1`)
#   SKIP_TESTS=1      skip step 1
#   EXTRA_OVERRIDES   config overrides appended to the training run of step 5 and to
#                     bench_train.py's stacks (swimrl-train keys)
#   BENCH_ARGS, ENV_ARGS, EVAL_ARGS   replace the size and variant arguments of steps 2, 3, 4
#   SITE=/tmp/site    the install target when one is needed
#   TMPDIR            where the scratch directory is made (default /tmp)
set -euo pipefail
REPO=$(cd "$(dirname "$0")/.." && pwd)
OUT=${1:?usage: gpu_session.sh OUT [DEVICE] [TOTAL_FRAMES] [EVAL_EVERY]}
DEVICE=${2:-cuda}; FRAMES=${3:-100000000}; EVAL_EVERY=${4:-48}
PY=${PYTHON:-python3}
SITE=${SITE:-/tmp/site}
export PYTHONUNBUFFERED=1
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
WORK=$(mktemp -d "${TMPDIR:-/tmp}/swimrl_gpu_session.XXXXXX")
cd "$WORK"  # outside the source tree from here on
echo "scratch directory $WORK"

if ! $PY -c "import torchrl, tensordict, hydra, zarr" 2>/dev/null; then
  $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
      --target "$SITE" "$REPO"/.whl/*.whl
  (cd "$REPO" && $PY -m pip install -q --no-index --no-deps --no-build-isolation --no-compile \
      --no-cache-dir --upgrade --target "$SITE" .)
  export PYTHONPATH="$SITE"${PYTHONPATH:+:$PYTHONPATH}
elif ! $PY -c "import swimrl.conf" 2>/dev/null; then
  (cd "$REPO" && $PY -m pip install -q --no-index --no-deps --no-build-isolation --no-compile \
      --no-cache-dir --upgrade --target "$SITE" .)
  export PYTHONPATH="$SITE"${PYTHONPATH:+:$PYTHONPATH}
fi

if [ "${DEVICE%%:*}" = cuda ]; then
  VARIANTS=compiled,graphed; GRAPHS=train.cudagraphs=true; THREADS=4
else
  VARIANTS=compiled; GRAPHS=; THREADS=1
fi
if [ "${SMOKE:-0}" = 1 ]; then
  BENCH_DEFAULT="--smoke --presets long_floor05,wide_gpu"
  ENV_DEFAULT="--smoke --kernels eager"
  EVAL_DEFAULT="--smoke"
  TRAIN_SIZES="flow.n_grid=64 flow.spacing=0.1 episode.duration=2.0 train.n_flows=2
    train.n_swimmers=4 train.rollout_length=10 train.minibatch_size=40
    train.minibatches_per_epoch=null train.epochs=1 train.compile=false train.stagger=1 train.eval_flows=1
    train.eval_swimmers=4 eval.n_flows=1 eval.n_swimmers=4"
  GRAPHS=
else
  BENCH_DEFAULT="--presets long_floor05,wide,parallel_gpu,wide_gpu --variants $VARIANTS --updates 5 --warmup 6"
  ENV_DEFAULT="--batches 256x64 --kernels eager compiled"
  EVAL_DEFAULT="--flows 16 --swimmers 32 --kernel compiled"
  TRAIN_SIZES=
fi
EXTRA=${EXTRA_OVERRIDES:-}

FAILED=()
# step NAME LOG CMD...: CMD's output (its Warning lines dropped) appended to LOG and shown;
# a non-zero exit status is recorded in FAILED and does not stop the script.
step() {
  local name=$1 log=$2 rc
  shift 2
  echo "== $name: $*" | tee -a "$log"
  set +e
  "$@" 2>&1 | { grep -v Warning || true; } | tee -a "$log"
  rc=${PIPESTATUS[0]}
  set -e
  if [ "$rc" -ne 0 ]; then
    FAILED+=("$name (exit $rc)")
    echo "== $name FAILED: exit $rc" | tee -a "$log"
  fi
}

TESTS_LOG=$OUT/gpu_tests.log
: > "$TESTS_LOG"
if [ "${DEVICE%%:*}" = cuda ]; then
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv | tee -a "$TESTS_LOG" \
      || true
fi
# what is imported: never the source tree (its swimrl has no swimrl.conf)
step versions "$TESTS_LOG" $PY -c "import importlib.metadata as md, swimrl, swimrl.conf
print(*(f'{p} {md.version(p)}' for p in ('torch', 'torchrl', 'tensordict')), 'swimrl',
      swimrl.__version__, 'from', swimrl.__path__[0], 'conf', swimrl.conf.__path__[0])"

# 1. tests that need the device (skipped without CUDA), from a copy of tests/
if [ "${SKIP_TESTS:-0}" != 1 ]; then
  cp -r "$REPO/tests" "$WORK/tests"
  printf '[pytest]\nmarkers =\n    slow: long checks\n    gpu: needs a CUDA device\n' \
      > "$WORK/pytest.ini"
  step tests "$TESTS_LOG" $PY -m pytest -q -p no:cacheprovider --rootdir "$WORK" -m gpu \
      tests/test_train.py tests/test_gpu.py
fi

# 2. throughput, the layouts side by side (variants interleaved update by update)
: > "$OUT/bench_train_$DEVICE.txt"
# shellcheck disable=SC2086  # word splitting of the argument lists is intended
step bench_train "$OUT/bench_train_$DEVICE.txt" $PY "$REPO/benchmarks/bench_train.py" \
    --device "$DEVICE" --threads $THREADS --out "$WORK/bench_train" ${BENCH_ARGS:-$BENCH_DEFAULT} \
    $EXTRA

# 3. the env step of the GPU floor's batch, eager against compiled
: > "$OUT/bench_env_$DEVICE.txt"
# shellcheck disable=SC2086
step bench_env "$OUT/bench_env_$DEVICE.txt" $PY "$REPO/benchmarks/bench_env.py" \
    --device "$DEVICE" --threads $THREADS ${ENV_ARGS:-$ENV_DEFAULT}

# 4. one periodic evaluation (16 x 32, one episode)
: > "$OUT/bench_eval_$DEVICE.txt"
# shellcheck disable=SC2086
step bench_eval "$OUT/bench_eval_$DEVICE.txt" $PY "$REPO/benchmarks/bench_eval.py" \
    --device "$DEVICE" --threads $THREADS ${EVAL_ARGS:-$EVAL_DEFAULT}

# 5. the paper's budget at Ku = 10 from scratch, timed
RUN=$WORK/run
: > "$OUT/train.log"
t0=$(date +%s.%N)
# shellcheck disable=SC2086
step train "$OUT/train.log" $PY -m swimrl.cli.train \
    train_preset=wide_gpu flow.kubo=10 seed=0 device="$DEVICE" $GRAPHS threads=$THREADS \
    train.total_frames="$FRAMES" train.eval_every="$EVAL_EVERY" train.progress=false \
    $TRAIN_SIZES $EXTRA hydra.run.dir="$RUN"
t1=$(date +%s.%N)
if [ -f "$RUN/metrics.json" ]; then
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
  cp "$RUN/metrics.json" "$RUN/curves.csv" "$RUN/policy.pt" "$OUT/"
  parts=(.hydra)
  [ -d "$RUN/policies" ] && parts+=(policies)
  tar -cf "$OUT/policies.tar" -C "$RUN" "${parts[@]}"
else
  FAILED+=("train: no $RUN/metrics.json")
fi

ls -l "$OUT"
if [ ${#FAILED[@]} -gt 0 ]; then
  printf 'FAILED: %s\n' "${FAILED[@]}" >&2
  exit 1
fi
echo "all steps done; records in $OUT"
