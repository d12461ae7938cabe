#!/usr/bin/env bash
# `relume batch --slurm` on a real one-node Slurm cluster started here (issue 23): munged with its
# own key and socket, slurmctld and slurmd with a slurm.conf written into a temporary folder
# (localhost only, ports picked free, no accounting), all started and stopped by PID. It records
# 10 tiny simulated sessions and one slower one with the relume CLI, processes them as one job
# array, cancels the slow session's array task mid-way (scancel), checks that the index lists it as
# failed with its log and that no result of it was published, resubmits it alone (--only-failed)
# and checks the index is then complete and the resubmitted task reused the stages the cancelled
# one had finished.
#   slurm_cluster_test.sh RELUME_BINARY SOURCE_DIR
# Exit 77 (CTest: skipped) only when Slurm or munge is not installed; anything else that stops the
# cluster from running is a failure (CI installs slurm-wlm and munge: scripts/install-deps.sh).
set -euo pipefail
relume=$1
src=$2
PATH="$PATH:/usr/sbin:/sbin"

for program in munged munge slurmctld slurmd sbatch squeue scancel sinfo; do
  if ! command -v "$program" >/dev/null; then
    echo "SKIPPED: $program is not installed; scripts/install-deps.sh installs slurm-wlm and munge"
    exit 77
  fi
done
if [ "$(id -u)" -ne 0 ]; then
  echo "FAILED: the test cluster runs slurmd, which must be root (CI runs as root)" >&2
  exit 1
fi

tmp=$(mktemp -d /tmp/relume-slurm-test.XXXXXX)
chmod 755 "$tmp"
daemons=()  # PIDs, stopped in reverse order at exit
stop_daemons() {
  local status=$?
  for ((i = ${#daemons[@]} - 1; i >= 0; i--)); do
    kill -TERM "${daemons[i]}" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "${daemons[i]}" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "${daemons[i]}" 2>/dev/null || true
    wait "${daemons[i]}" 2>/dev/null || true
  done
  if [ "$status" -ne 0 ]; then
    echo "---- logs of the test cluster ($tmp) ----"
    for f in "$tmp"/log/*; do echo "== $f"; tail -n 30 "$f"; done
  fi
  if [ "${RELUME_KEEP_SLURM_TEST:-0}" = 1 ]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
  exit "$status"
}
trap stop_daemons EXIT
fail() { echo "FAILED: $*" >&2; exit 1; }

mkdir -p "$tmp"/{munge,sock,state,spool,log}
chmod 700 "$tmp/munge"
chmod 755 "$tmp/sock"
head -c 1024 /dev/urandom > "$tmp/munge/munge.key"
chmod 400 "$tmp/munge/munge.key"
munged --foreground --key-file="$tmp/munge/munge.key" --socket="$tmp/sock/munge.sock" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/log/munged.log" --seed-file="$tmp/munge/seed" \
  >"$tmp/log/munged.out" 2>&1 &
daemons+=($!)
for _ in $(seq 50); do [ -S "$tmp/sock/munge.sock" ] && break; sleep 0.1; done
munge -S "$tmp/sock/munge.sock" -n | unmunge -S "$tmp/sock/munge.sock" >/dev/null ||
  fail "munged does not answer on $tmp/sock/munge.sock"

# Two free ports on the loopback interface for slurmctld and slurmd.
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*(x.getsockname()[1] for x in s))')
memory_mb=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 / 2))
cat >"$tmp/slurm.conf" <<CONF
ClusterName=relumetest
SlurmctldHost=localhost
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/sock/munge.sock
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/state/slurmctld.pid
SlurmdPidFile=$tmp/spool/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$tmp/log/jobcomp.txt
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=$memory_mb State=UNKNOWN
PartitionName=relume Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$tmp/slurm.conf"
slurmctld -D -f "$SLURM_CONF" >"$tmp/log/slurmctld.out" 2>&1 &
daemons+=($!)
slurmd -D -N localhost -f "$SLURM_CONF" >"$tmp/log/slurmd.out" 2>&1 &
daemons+=($!)
for _ in $(seq 150); do
  state=$(sinfo --noheader --format=%t 2>/dev/null || true)
  [ "$state" = idle ] && break
  sleep 0.2
done
[ "$state" = idle ] || fail "the test cluster's node did not become idle (sinfo: '$state')"
echo "cluster up: slurmctld on 127.0.0.1:$ctld_port, slurmd on :$slurmd_port, $(nproc) CPUs"

# 10 tiny sessions and one slower one (a 640x480 camera), recorded by the CLI on simulated rigs.
start=$(date +%s)
for i in $(seq -w 1 10); do
  "$relume" capture --rig "$src/tests/data/rigs/sim-tiny-irm.yaml" --out "$tmp/field/day$i/session" \
    >"$tmp/log/capture-$i.txt" 2>&1 || { cat "$tmp/log/capture-$i.txt"; fail "capture $i failed"; }
  echo "$tmp/field/day$i/session" >>"$tmp/sessions.txt"
done
sed "s|scene: ../../../config|scene: $src/config|; s/width: 160, height: 120/width: 640, height: 480/" \
  "$src/tests/data/rigs/sim-tiny-irm.yaml" >"$tmp/slow-rig.yaml"
"$relume" capture --rig "$tmp/slow-rig.yaml" --out "$tmp/field/slow/session" >"$tmp/log/capture-slow.txt" 2>&1 ||
  { cat "$tmp/log/capture-slow.txt"; fail "capture of the slow session failed"; }
slow="$tmp/field/slow/session"
# The slow session is task 5 of 11.
sed -i "5a $slow" "$tmp/sessions.txt"
[ "$(sed -n 6p "$tmp/sessions.txt")" = "$slow" ] || fail "the session list is not as planned"
out="$tmp/batch"

# 1. The whole batch as a job array, two tasks at a time; the slow task is cancelled mid-way.
"$relume" batch --sessions-from "$tmp/sessions.txt" --out "$out" --slurm --pipeline irm --max-running 2 \
  --poll 0.3 >"$tmp/log/batch-1.txt" 2>&1 &
batch_pid=$!
slow_folder=""
for _ in $(seq 1200); do
  for f in "$out"/sessions/*/task.json; do
    [ -f "$f" ] && grep -q "\"session\": \"$slow\"" "$f" && slow_folder=$(dirname "$f")
  done
  # Mid-way: the task runs and has finished at least one stage, not all of them.
  if [ -n "$slow_folder" ] && grep -q '"state": "running"' "$slow_folder/task.json" &&
    compgen -G "$slow_folder/result.partial/stages/*/stage.json" >/dev/null; then
    break
  fi
  sleep 0.1
done
[ -n "$slow_folder" ] || fail "the slow session's task never started"
job=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["tasks"][5]["job_id"])' "$out/batch.json")
scancel "${job}_5"
echo "cancelled array task ${job}_5 with $(ls -d "$slow_folder"/result.partial/stages/*/ | wc -l) stage(s) done"
set +e
wait "$batch_pid"
batch_status=$?
set -e
cat "$tmp/log/batch-1.txt"
[ "$batch_status" -ne 0 ] || fail "relume batch exited 0 although a task was cancelled"
grep -q "^11 session(s): 10 done, 1 failed (task 5)" "$tmp/log/batch-1.txt" || fail "the summary does not name task 5"
grep -q "ended without a result (Slurm: CANCELLED, while running)" "$tmp/log/batch-1.txt" ||
  fail "the cancelled task is not reported as cancelled"
grep -q "only-failed" "$tmp/log/batch-1.txt" || fail "no word on how to rerun the failed task"
row=$(grep "^5," "$out/index.csv")
echo "$row" | grep -q ",failed," || fail "index.csv row 5 is not failed: $row"
echo "$row" | grep -q "logs/slurm-${job}_5.log" || fail "index.csv row 5 has no log: $row"
[ -f "$out/logs/slurm-${job}_5.log" ] || fail "the cancelled task's log is missing"
[ ! -e "$slow_folder/result" ] || fail "a cancelled task published a result"
[ -d "$slow_folder/result.partial" ] || fail "the cancelled task's work folder is gone"
[ "$(grep -c ',done,' "$out/index.csv")" -eq 10 ] || fail "index.csv does not list 10 done sessions"
grep -q 'data-failed="1"' "$out/index.html" || fail "index.html does not list the failed task"

# 2. The failed task alone, resubmitted.
"$relume" batch --out "$out" --only-failed --slurm --poll 0.3 >"$tmp/log/batch-2.txt" 2>&1 ||
  { cat "$tmp/log/batch-2.txt"; fail "the resubmission failed"; }
cat "$tmp/log/batch-2.txt"
grep -q "submitted Slurm job [0-9]*: 1 array task(s)" "$tmp/log/batch-2.txt" || fail "the resubmission was not one task"
grep -q "^11 session(s): 11 done; index: $out/index.html" "$tmp/log/batch-2.txt" || fail "the index is not complete"
[ "$(grep -c ',done,' "$out/index.csv")" -eq 11 ] || fail "index.csv does not list 11 done sessions"
grep -q 'data-done="11" data-failed="0"' "$out/index.html" || fail "index.html is not complete"
[ "$(grep -c 'href="sessions/.*/result/report.html">report</a>' "$out/index.html")" -eq 11 ] ||
  fail "index.html does not link 11 reports"
for f in "$out"/sessions/*/result/report.html; do [ -f "$f" ] || fail "missing report $f"; done
reused=$(grep -c '"action": "reuse"' "$slow_folder/result/summary.json" || true)
[ "$reused" -ge 1 ] || fail "the resubmitted task did not reuse the stages the cancelled one finished"
echo "the resubmitted task reused $reused stage(s) of the cancelled one"

# 3. The whole batch again, submitted without waiting, then collected: every stage is reused.
rerun_start=$(date +%s.%N)
"$relume" batch --sessions-from "$tmp/sessions.txt" --out "$out" --slurm --pipeline irm --no-wait \
  >"$tmp/log/batch-3.txt" 2>&1 || { cat "$tmp/log/batch-3.txt"; fail "the rerun was not submitted"; }
cat "$tmp/log/batch-3.txt"
grep -q "^job id: [0-9]*$" "$tmp/log/batch-3.txt" || fail "--no-wait did not print the job id"
"$relume" batch --out "$out" --collect --wait --poll 0.3 >"$tmp/log/batch-4.txt" 2>&1 ||
  { cat "$tmp/log/batch-4.txt"; fail "--collect --wait failed"; }
rerun_end=$(date +%s.%N)
grep -q "^11 session(s): 11 done; index: $out/index.html" "$tmp/log/batch-4.txt" || fail "the collected index is not complete"
ran=$(python3 -c '
import json, sys
print(sum(d.get("cache", False) and d["action"] == "run" for f in sys.argv[1:] for d in json.load(open(f))["decisions"]))
' "$out"/sessions/*/result/summary.json)
[ "$ran" -eq 0 ] || fail "an unchanged rerun recomputed $ran stage(s)"
echo "unchanged rerun of 11 sessions through Slurm (submit, run, collect): $(awk "BEGIN {print $rerun_end - $rerun_start}") s"
echo "PASSED in $(($(date +%s) - start)) s (sessions, three submissions and the checks)"
