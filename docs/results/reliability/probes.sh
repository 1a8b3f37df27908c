#!/usr/bin/env bash
# The probe cases of the data-integrity work, run against the installed commands in a scratch
# directory; prints each case's exit status, its last stderr line and what it left behind.
#   bash docs/results/reliability/probes.sh > docs/results/reliability/probes.txt
set -u
W=$(mktemp -d); cd "$W" || exit 1
SMALL="flow.n_grid=64 flow.spacing=0.1 episode.duration=2.0 eval.progress=false threads=1"
TINY="$SMALL train.compile=false train.n_flows=2 train.n_swimmers=4 train.frames_per_batch=80
      train.minibatch_size=40 train.eval_every=0 train.eval_flows=1 train.eval_swimmers=4
      train.checkpoint_every=1000 train.checkpoint_seconds=1e6 train.progress=false eval.n_flows=2
      eval.n_swimmers=4"
probe() {  # probe NAME RESULT_FILE CMD...
  local name=$1 result=$2; shift 2
  "$@" > out.txt 2> err.txt; local rc=$?
  printf '%-34s exit %-3s | %s\n' "$name" "$rc" "$(cat err.txt out.txt | grep -v '^\s*$' | grep -v Warning | tail -n 1)"
  printf '%-34s result file %s: %s\n' "" "$result" "$([ -e "$result" ] && echo present || echo absent)"
}

# 1. a corrupted DNS store (64 bytes flipped in 11 omega_hat chunks)
swimrl-dns dns.n=32 dns.nu=5e-3 dns.dt=4e-3 spinup.time=1.0 spinup.measure_time=0.2 \
  store.n_times=40 store.diag_every=5 progress=false threads=1 store.path=store.zarr \
  hydra.run.dir=dns > /dev/null 2>&1
python - <<'PY'
import pathlib
chunks = sorted(p for p in pathlib.Path("store.zarr/omega_hat").rglob("*") if p.is_file()
                and p.name != "zarr.json")
for p in chunks[5:16]:
    b = bytearray(p.read_bytes()); b[20:84] = bytes(x ^ 0xFF for x in b[20:84]); p.write_bytes(b)
print(f"flipped 64 bytes in {len(chunks[5:16])} of {len(chunks)} omega_hat chunks")
PY
probe "eval on the corrupted store" eval_dns/metrics.json swimrl-eval flow=dns_replay \
  flow.path=store.zarr strategy=sto episode.duration=2.0 eval.n_flows=2 eval.n_swimmers=10 \
  eval.progress=false threads=1 hydra.run.dir=eval_dns
probe "swimrl-dns-verify on it" - swimrl-dns-verify store.zarr

# 2. memory the machine does not have (48 GB of flow tables)
probe "eval n_flows=flows_per_batch=3000" mem/metrics.json swimrl-eval eval.n_flows=3000 \
  eval.flows_per_batch=3000 hydra.run.dir=mem

# 3. run directories that cannot be created
probe "hydra.run.dir=/proc/nope" /proc/nope swimrl-eval $SMALL hydra.run.dir=/proc/nope
touch afile
probe "hydra.run.dir=afile/run (train)" afile/run swimrl-train $TINY hydra.run.dir=afile/run

# 4. a policy file with NaN weights
python - <<'PY'
import torch
from swimrl.runs.policy_files import resolve_policy_file
d = torch.load(resolve_policy_file("pretrained/ku10"), weights_only=True)
k = next(iter(d["actor"])); d["actor"][k] = d["actor"][k] * float("nan")
torch.save(d, "nan_policy.pt")
PY
probe "eval a policy with NaN weights" nan/metrics.json swimrl-eval $SMALL strategy=policy \
  policy=nan_policy.pt hydra.run.dir=nan

# 5. SIGTERM during training, then a second process on the same directory, then resume
swimrl-train $TINY train.total_frames=40000 hydra.run.dir=run > train.out 2> train.err &
pid=$!
for _ in $(seq 600); do grep -q "PPO:" run/train.log 2>/dev/null && break; sleep 0.1; done
sleep 6
probe "second train on the same run dir" run/metrics.json swimrl-train $TINY \
  train.total_frames=40000 resume=true hydra.run.dir=run
kill -TERM $pid; wait $pid; rc=$?
printf '%-34s exit %-3s | %s\n' "SIGTERM during swimrl-train" "$rc" "$(grep preempted run/train.log | sed 's/.*- //')"
python -c "import torch; print(' ' * 35 + 'checkpoint holds update', torch.load('run/checkpoints/last.pt', weights_only=True)['counters']['updates'])"
probe "resume=true after it" run/metrics.json swimrl-train $TINY train.total_frames=40000 \
  resume=true hydra.run.dir=run
rm -rf "$W"
