#!/usr/bin/env bash
# The Slurm job array of deploy/slurm-nightly-array.sh, run for real on a single-node cluster.
#
#   bash deploy/test/slurm.sh [FLEETDYN_BINARY]     (as root; default target/release/fleetdyn)
#
# 1. Installs slurm-wlm and munge from the distribution when they are missing (apt-get).
# 2. Writes a single-node configuration under a temporary folder (slurmctld and slurmd on this
#    host, proctrack/linuxproc, task/none, state and spool folders in the temporary folder) and
#    starts munged, slurmctld and slurmd in the foreground as background processes.
# 3. Clean case: submits deploy/slurm-nightly-array.sh unchanged, as an array of 3 over the
#    bundled fixture drives (pipelines/nightly.toml), and the reduce step as a job that depends on
#    it; waits (bounded); asserts that every output equals an unsharded run's byte for byte, the
#    run reports' wall times aside (run_report.json and summary.md of the reduce step) and the
#    shards' own reports (`shard-i-of-3/`, which an unsharded run does not write).
# 4. Fault case: a fresh dataset, the array again; one array task is cancelled after it finished
#    a drive and before it finished its shard, then requeued; after the array and the reduce step,
#    the same byte-for-byte check, and the requeued task's log must show the drive it reused.
# 5. Stops every daemon it started, by PID, and removes the temporary folder.
#
# Exits 0 when every check holds, 1 when one fails, 77 when it cannot run here (not root, no
# apt-get and no Slurm), each with a printed reason. Prints its wall time.
set -euo pipefail
cd "$(dirname "$0")/../.."
repo=$PWD
t_start=$(date +%s)
timeout_s=${FLEETDYN_SLURM_TIMEOUT_S:-600}

skip() {
    echo "slurm test skipped: $*"
    exit 77
}
fail() {
    echo "slurm test FAILED: $*" >&2
    exit 1
}

[ "$(id -u)" = 0 ] || skip "not root (the daemons run as root on a throw-away node)"
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    command -v apt-get >/dev/null || skip "no slurmctld/munged and no apt-get to install them"
    echo "installing slurm-wlm and munge …"
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null; } ||
        skip "slurm-wlm and munge could not be installed from the distribution"
fi

bin=$(realpath "${1:-target/release/fleetdyn}")
[ -x "$bin" ] || fail "no fleetdyn binary at $bin (cargo build --release)"

work=$(mktemp -d /tmp/fleetdyn-slurm.XXXXXX)
pids=()
cleanup() {
    for p in "${pids[@]}"; do
        kill "$p" 2>/dev/null || true
    done
    for p in "${pids[@]}"; do
        wait "$p" 2>/dev/null || true
    done
    rm -rf "$work"
}
trap cleanup EXIT

# ---- a single-node cluster ----------------------------------------------------------------------
host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 512))
mkdir -p "$work"/{state,spool,logs,munge,run}
chmod 700 "$work/munge"
if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null
    chmod 400 /etc/munge/munge.key
fi
conf=$work/slurm.conf
cat >"$conf" <<EOF
ClusterName=fleetdyn-test
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/run/slurmctld.pid
SlurmdPidFile=$work/run/slurmd.pid
SlurmctldPort=16817
SlurmdPort=16818
SlurmctldLogFile=$work/logs/slurmctld.log
SlurmdLogFile=$work/logs/slurmd.log
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SchedulerParameters=sched_interval=1
MinJobAge=3600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$conf
munged -F --socket="$work/munge/munge.socket" --pid-file="$work/run/munged.pid" \
    --log-file="$work/logs/munged.log" --seed-file="$work/munge/seed" --force \
    >"$work/logs/munged.out" 2>&1 &
pids+=($!)
sleep 1
slurmctld -D -f "$conf" >"$work/logs/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$conf" >"$work/logs/slurmd.out" 2>&1 &
pids+=($!)
for _ in $(seq 60); do
    sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)' && break
    sleep 1
done
sinfo -h -o %T | grep -qE '^(idle|mixed|allocated)' ||
    fail "the node did not come up: $(sinfo 2>&1 | tail -2); $(tail -5 "$work/logs/slurmctld.log" 2>/dev/null)"
echo "single-node cluster up: $(sinfo -h -o '%P %D %T %c')"

# ---- helpers ------------------------------------------------------------------------------------
wait_done() { # job id: every task of it in a final state, bounded
    local deadline=$(($(date +%s) + timeout_s))
    while [ "$(date +%s)" -lt "$deadline" ]; do
        if ! scontrol show job "$1" 2>/dev/null | grep -qE 'JobState=(PENDING|RUNNING|CONFIGURING|COMPLETING|REQUEUED|SUSPENDED)'; then
            return 0
        fi
        sleep 1
    done
    fail "job $1 not done within ${timeout_s} s: $(scontrol show job "$1" | grep -o 'JobState=[A-Z_]*' | sort | uniq -c | tr '\n' ' ')"
}
all_completed() { # job id
    local bad
    bad=$(scontrol show job "$1" | grep -o 'JobState=[A-Z_]*' | grep -v COMPLETED || true)
    [ -z "$bad" ] || fail "job $1 ended with: $bad; logs: $(tail -n 3 "$work"/submit/logs/*.log 2>/dev/null)"
}
# every output file but the run reports' wall-time files and the shards' own reports (an
# unsharded run has none), hashed
digest() { (cd "$1" && find . -type f ! -name run_report.json ! -name summary.md ! -path '*/shard-*-of-*/*' |
    LC_ALL=C sort | xargs sha256sum); }
markers() { find "$1/_state" -name '*.json' 2>/dev/null | wc -l; }

submit_dir=$work/submit
mkdir -p "$submit_dir/logs"
export FLEETDYN=$bin FLEETDYN_PIPELINE=$repo/pipelines/nightly.toml
submit_array() { # output root → job id
    (cd "$submit_dir" && FLEETDYN_OUTPUT=$1 sbatch --parsable --array=0-2 "$repo/deploy/slurm-nightly-array.sh")
}
submit_reduce() { # output root, dependency → job id
    (cd "$submit_dir" && sbatch --parsable ${2:+--dependency=afterany:$2} --output=logs/reduce-%j.log \
        --cpus-per-task=2 --wrap "exec '$bin' run '$FLEETDYN_PIPELINE' --output '$1' --jobs 2")
}

# ---- the reference: one unsharded run ----------------------------------------------------------
"$bin" run "$FLEETDYN_PIPELINE" --output "$work/whole" --jobs 2 >"$work/logs/whole.log" 2>&1 ||
    fail "the unsharded run failed: $(tail -3 "$work/logs/whole.log")"
n_markers=$(markers "$work/whole")
echo "unsharded run: $(digest "$work/whole" | wc -l) files, $n_markers drives"

# ---- 1. clean: the array of 3 and the dependent reduce step ------------------------------------
t0=$(date +%s)
array=$(submit_array "$work/clean")
reduce=$(submit_reduce "$work/clean" "$array")
echo "clean case: array job $array (3 tasks), reduce job $reduce (afterany)"
wait_done "$array"
all_completed "$array"
wait_done "$reduce"
all_completed "$reduce"
grep -q "0 processed, $n_markers reused" "$submit_dir"/logs/reduce-"$reduce".log ||
    fail "the reduce step processed drives: $(tail -2 "$submit_dir"/logs/reduce-"$reduce".log)"
diff <(digest "$work/whole") <(digest "$work/clean") >"$work/logs/clean.diff" ||
    fail "the array's dataset differs from the unsharded run: $(head -5 "$work/logs/clean.diff")"
echo "clean case: identical to the unsharded run ($(digest "$work/clean" | wc -l) files) in $(($(date +%s) - t0)) s"

# ---- 2. fault: one task cancelled mid-shard, then requeued -------------------------------------
t0=$(date +%s)
out=$work/fault
cancelled=""
for attempt in 1 2 3; do
    rm -rf "$out"
    array=$(submit_array "$out")
    deadline=$(($(date +%s) + timeout_s))
    while [ -z "$cancelled" ] && [ "$(date +%s)" -lt "$deadline" ]; do
        running=$(squeue -h -j "$array" -t RUNNING -o %K 2>/dev/null | head -1)
        if [ -n "$running" ] && [ -f "$submit_dir/logs/fleetdyn-${array}_${running}.log" ] &&
            grep -q ' ok ' "$submit_dir/logs/fleetdyn-${array}_${running}.log"; then
            # a drive of this task is done; cancel before its shard is
            scancel "${array}_${running}"
            sleep 2
            log=$submit_dir/logs/fleetdyn-${array}_${running}.log
            if scontrol show job "${array}_${running}" | grep -q 'JobState=CANCELLED' &&
                ! grep -q 'reused (up to date)' "$log"; then
                cancelled=$running
                cp "$log" "$work/logs/cancelled.log"
            fi
            break
        fi
        sleep 0.2
    done
    [ -n "$cancelled" ] && break
    wait_done "$array"
    echo "fault case, attempt $attempt: no task could be cancelled between two drives; again"
done
[ -n "$cancelled" ] || fail "no array task was cancelled mid-shard in 3 attempts"
echo "fault case: task ${array}_${cancelled} cancelled after $(grep -c ' ok ' "$work/logs/cancelled.log") drive(s)"
scontrol requeue "${array}_${cancelled}"
# a requeued job waits for a begin time; let it start at once
scontrol update JobId="${array}_${cancelled}" StartTime=now >/dev/null 2>&1 || true
wait_done "$array"
all_completed "$array"
log=$submit_dir/logs/fleetdyn-${array}_${cancelled}.log
grep -qE '[1-9][0-9]* reused' "$log" ||
    fail "the requeued task did not reuse the drive it had finished: $(tail -2 "$log")"
reduce=$(submit_reduce "$out" "")
wait_done "$reduce"
all_completed "$reduce"
diff <(digest "$work/whole") <(digest "$out") >"$work/logs/fault.diff" ||
    fail "after the requeue the dataset differs from the unsharded run: $(head -5 "$work/logs/fault.diff")"
echo "fault case: the requeued task resumed ($(grep -oE '[0-9]+ processed, [0-9]+ reused' "$log")); identical to the unsharded run in $(($(date +%s) - t0)) s"

echo "slurm test passed in $(($(date +%s) - t_start)) s (daemons stopped, $work removed)"
