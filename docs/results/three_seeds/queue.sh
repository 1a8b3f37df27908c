#!/bin/bash
# Sequential job queue: worker 1 always; worker 2 only while no swimrl-train runs.
# A job is started only if now + its estimate (minutes) ends before 09:30 UTC.
cd /work/frozen/logs/three_seeds
DEADLINE=$(date -u -d "09:30" +%s)
pop() { # prints the next job line and removes it, under a lock
  exec 9>queue.lock; flock 9
  line=$(head -n1 jobs.txt); [ -n "$line" ] && sed -i 1d jobs.txt
  flock -u 9; echo "$line"
}
worker() {
  w=$1
  while true; do
    if [ "$w" = 2 ] && pgrep -f swimrl-train >/dev/null; then sleep 60; [ -s jobs.txt ] || break; continue; fi
    [ -f STOP ] && break
    line=$(pop); [ -z "$line" ] && break
    est=${line%% *}; cmd=${line#* }
    now=$(date -u +%s)
    if [ $((now + est*60)) -gt $DEADLINE ]; then echo "[w$w $(date -u +%T)] SKIP (would end after 09:30): $cmd" >> queue.log; continue; fi
    echo "[w$w $(date -u +%T)] START $cmd" >> queue.log
    $cmd > "job_$(echo $cmd | tr ' /.' '___').log" 2>&1
    echo "[w$w $(date -u +%T)] END rc=$? $cmd" >> queue.log
  done
  echo "[w$w $(date -u +%T)] worker done" >> queue.log
}
# wait for the fits driver to finish first
while pgrep -f run_fits.sh >/dev/null; do sleep 20; done
worker 1 &
sleep 5
worker 2 &
wait
