#!/usr/bin/env bash
# Runs the README's Slurm recipe ("Sweep, shards and merge") on a one-node
# Slurm cluster stood up here from Debian's packages, and checks that the
# merged shards equal one run of the same sweep byte for byte.
#
#   bash .ci/slurm/run.sh
#
# Needs root and apt (Debian 12: slurmctld, slurmd, slurm-client and munge
# 22.05 are installed if missing) and a Rust toolchain. The daemons listen on
# loopback on free ports, keep every file in a temporary directory, and are
# stopped on exit; nothing outside that directory is changed but the packages.
#
# The job script and the submit commands are read from README.md, so the test
# runs what a user copies. Only the workload is made small (the #SBATCH
# --cpus-per-task line, --noise and --trials are substituted):
#   FRAMEID_SLURM_CPUS    cores per array task      (default 1)
#   FRAMEID_SLURM_NOISE   noise levels              (default 0,0.01)
#   FRAMEID_SLURM_TRIALS  trials per noise level    (default 6)
#   FRAMEID_SLURM_TIMEOUT seconds the jobs may take (default 900)
#   FRAMEID_SLURM_KEEP=1  keep the temporary directory
#
# Exit status: 0 the recipe ran and merge == one run; 1 the recipe, a job,
# the merge or the comparison failed; 77 this machine cannot run Slurm (no
# root, no packages, or a daemon does not come up: its log is printed).
set -euo pipefail

PATH=$PATH:/usr/sbin:/sbin  # the daemons and mungekey live in sbin
repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"

CPUS=${FRAMEID_SLURM_CPUS:-1}
NOISE=${FRAMEID_SLURM_NOISE:-0,0.01}
TRIALS=${FRAMEID_SLURM_TRIALS:-6}
TIMEOUT=${FRAMEID_SLURM_TIMEOUT:-900}
SCENARIO=scenarios/paper-case1.toml

t0=$(date +%s)
say() { echo "slurm-test [$(($(date +%s) - t0)) s]: $*"; }
verdict=
fail() { verdict="FAILED: $*"; echo "slurm-test: $verdict" >&2; exit 1; }
cannot() { verdict="CANNOT RUN SLURM HERE: $*"; echo "slurm-test: $verdict" >&2; exit 77; }

# --- packages -------------------------------------------------------------
[ "$(id -u)" = 0 ] || cannot "needs root (to install packages and run slurmd)"
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null ||
    ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
    command -v apt-get >/dev/null || cannot "Slurm is not installed and there is no apt-get"
    say "installing slurmctld slurmd slurm-client munge"
    export DEBIAN_FRONTEND=noninteractive
    apt_log=$(mktemp)
    { apt-get update -qq && apt-get install -y -qq --no-install-recommends \
        slurmctld slurmd slurm-client munge; } >"$apt_log" 2>&1 ||
        { cat "$apt_log" >&2; rm -f "$apt_log"; cannot "apt-get install slurmctld slurmd slurm-client munge failed"; }
    rm -f "$apt_log"
fi
say "$(slurmd -V)"

# --- build frameid --------------------------------------------------------
say "cargo build --release --bin frameid"
frameid=$(cargo build --release --bin frameid --message-format=json-render-diagnostics |
    sed -n 's/.*"executable":"\([^"]*\/frameid\)".*/\1/p' | tail -n 1)
[ -x "$frameid" ] || fail "cargo build did not report the frameid executable"
# Compute nodes find frameid on the PATH of the submitting shell.
PATH="$(dirname "$frameid"):$PATH"
export PATH

# --- the recipe, from the README ------------------------------------------
tmp=$(mktemp -d "${TMPDIR:-/tmp}/frameid-slurm.XXXXXX")
work=$tmp/work
mkdir -p "$work" "$tmp/slurm"/{state,spool,log,run} "$tmp/munge-key" "$tmp/munge-run"
# The job script is the README's sh block with #SBATCH lines; the submit
# commands, the block that submits with a dependency.
awk -v job="$tmp/job.sbatch" -v submit="$tmp/submit.sh" '
    /^```sh$/ { inside = 1; text = ""; next }
    /^```$/ && inside {
        inside = 0
        if (text ~ /#SBATCH/) { printf "%s", text > job; njob++ }
        if (text ~ /sbatch --dependency/) { printf "%s", text > submit; nsub++ }
        next
    }
    inside { text = text $0 "\n" }
    END { exit !(njob == 1 && nsub == 1) }
' README.md || fail "README.md: expected one sh block with #SBATCH lines and one with 'sbatch --dependency'"
grep -q 'sbatch --parsable sweep.sbatch' "$tmp/submit.sh" ||
    fail "README.md: the submit block does not run 'sbatch --parsable sweep.sbatch'"
# The small workload.
subst() { # file, sed expression, what
    local before
    before=$(cat "$1")
    sed -i -E "$2" "$1"
    [ "$(diff <(echo "$before") "$1" | grep -c '^>')" = 1 ] ||
        fail "README.md's job script: cannot substitute $3 (the recipe's text changed?)"
}
subst "$tmp/job.sbatch" "s/^#SBATCH --cpus-per-task=[0-9]+$/#SBATCH --cpus-per-task=$CPUS/" "--cpus-per-task"
subst "$tmp/job.sbatch" "s/ --noise [0-9.,]+ --trials [0-9]+ / --noise $NOISE --trials $TRIALS /" "--noise and --trials"
cp "$tmp/job.sbatch" "$work/sweep.sbatch"
# shellcheck disable=SC2016 # $jobid expands in submit.sh, where the README sets it
echo 'echo "array job: $jobid"' >>"$tmp/submit.sh"
cp -r scenarios "$work/"
say "job script (README's, workload substituted):"
sed 's/^/    /' "$work/sweep.sbatch"

# --- daemons --------------------------------------------------------------
pids=()  # the daemons this script started, and their names
names=()
cleanup() {
    local status=$?
    set +e
    # Cancel what is left of the jobs while the controller is up (this
    # controller has only this script's jobs).
    if [ -n "${ctld_pid:-}" ] && kill -0 "$ctld_pid" 2>/dev/null; then
        timeout 15 scancel --user=root >/dev/null 2>&1
        sleep 1
    fi
    # Stop only the daemons this script started, newest first.
    for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
        kill "${pids[i]}" 2>/dev/null
    done
    for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null; done
    if [ "$status" != 0 ]; then
        for f in "$tmp"/slurm/log/* "$work"/slurm-*.out; do
            [ -f "$f" ] || continue
            echo "----- ${f#"$tmp"/} (last 30 lines)" >&2
            tail -n 30 "$f" >&2
        done
        echo "slurm-test: ${verdict:-exit status $status} (logs above)" >&2
    fi
    if [ "${FRAMEID_SLURM_KEEP:-0}" = 1 ]; then
        echo "slurm-test: kept $tmp" >&2
    else
        rm -rf "$tmp"
    fi
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

free_port() { # a port nobody listens on, from a random start
    local p=$((20000 + RANDOM % 20000))
    while (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; do p=$((p + 1)); done
    echo "$p"
}
ctld_port=$(free_port)
slurmd_port=$(free_port)
[ "$ctld_port" != "$slurmd_port" ] || slurmd_port=$((ctld_port + 1))

# munged refuses a socket directory that others cannot traverse.
chmod 755 "$tmp" "$tmp/munge-run"
chmod 700 "$tmp/munge-key"
mungekey --create --keyfile="$tmp/munge-key/munge.key" ||
    cannot "mungekey could not create a key"
munged --foreground --key-file="$tmp/munge-key/munge.key" \
    --socket="$tmp/munge-run/munge.socket" --pid-file="$tmp/munge-run/munged.pid" \
    --seed-file="$tmp/munge-key/seed" --log-file="$tmp/slurm/log/munged.log" \
    >"$tmp/slurm/log/munged.out" 2>&1 &
pids+=($!)
names+=(munged)
for _ in $(seq 50); do [ -S "$tmp/munge-run/munge.socket" ] && break; sleep 0.1; done
munge --socket="$tmp/munge-run/munge.socket" --no-input |
    unmunge --socket="$tmp/munge-run/munge.socket" >/dev/null ||
    cannot "munged does not answer"

# One node with the machine's real topology (as slurmd -C reads it).
topology=$(slurmd -C | head -n 1 | tr ' ' '\n' |
    grep -E '^(CPUs|Boards|SocketsPerBoard|CoresPerSocket|ThreadsPerCore)=' | tr '\n' ' ')
[ -n "$topology" ] || cannot "slurmd -C printed no node configuration"
export SLURM_CONF=$tmp/slurm/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=frameidtest
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge-run/munge.socket
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$tmp/slurm/state
SlurmdSpoolDir=$tmp/slurm/spool
SlurmctldPidFile=$tmp/slurm/run/slurmctld.pid
SlurmdPidFile=$tmp/slurm/run/slurmd.pid
SlurmctldLogFile=$tmp/slurm/log/slurmctld.log
SlurmdLogFile=$tmp/slurm/log/slurmd.log
MailProg=/bin/true
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=3600
NodeName=localhost NodeAddr=127.0.0.1 NodeHostname=localhost $topology State=UNKNOWN
PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
say "slurmctld on port $ctld_port, slurmd on $slurmd_port: $topology"
slurmctld -D -i >"$tmp/slurm/log/slurmctld.out" 2>&1 &
pids+=($!)
names+=(slurmctld)
ctld_pid=$!
slurmd -D -N localhost >"$tmp/slurm/log/slurmd.out" 2>&1 &
pids+=($!)
names+=(slurmd)
state=
for _ in $(seq 120); do
    state=$(sinfo --noheader --nodes=localhost --format=%T 2>/dev/null || true)
    [ "$state" = idle ] && break
    for i in "${!pids[@]}"; do
        kill -0 "${pids[i]}" 2>/dev/null || cannot "${names[i]} exited at start-up (its log is below)"
    done
    sleep 0.5
done
[ "$state" = idle ] || cannot "the node is not idle after 60 s (state: '${state:-no answer}')"
say "node idle"

# --- submit as the README says, wait for the merge job --------------------
cd "$work"
submitted=$(timeout 60 bash -eu "$tmp/submit.sh") || fail "the README's submit commands failed"
echo "$submitted" | sed 's/^/    /'
merge_job=$(echo "$submitted" | sed -n 's/^Submitted batch job \([0-9]*\)$/\1/p' | tail -n 1)
[ -n "$merge_job" ] || fail "no merge job id in sbatch's output"
field() { # job, field of scontrol show job
    { scontrol show job "$1" 2>/dev/null || true; } | grep -o "\b$2=[^ ]*" | head -n 1 | cut -d= -f2- || true
}
array_tasks() { # the array's tasks that did not complete, with their exit codes
    scontrol show job "${array_job:-}" 2>/dev/null |
        awk '/ArrayTaskId=/ { for (i = 1; i <= NF; i++) if ($i ~ /^ArrayTaskId=/) t = $i }
             /JobState=/ { for (i = 1; i <= NF; i++) if ($i ~ /^JobState=/) s = $i }
             /ExitCode=/ { for (i = 1; i <= NF; i++) if ($i ~ /^ExitCode=/) e = $i
                           if (s != "JobState=COMPLETED") printf "%s %s %s; ", t, s, e }'
}
array_job=$(echo "$submitted" | sed -n 's/^array job: \([0-9]*\)$/\1/p')
deadline=$(($(date +%s) + TIMEOUT))
while :; do
    job_state=$(field "$merge_job" JobState)
    reason=$(field "$merge_job" Reason)
    case "$job_state" in
    COMPLETED) break ;;
    PENDING | CONFIGURING | RUNNING | COMPLETING)
        [ "$reason" != DependencyNeverSatisfied ] ||
            fail "a shard failed, so the merge job $merge_job can never start: $(array_tasks)"
        ;;
    *) fail "the merge job $merge_job ended $job_state (Reason=$reason ExitCode=$(field "$merge_job" ExitCode))" ;;
    esac
    [ "$(date +%s)" -lt "$deadline" ] ||
        fail "the jobs did not finish within $TIMEOUT s: $(squeue --noheader --all | tr -s ' ' | tr '\n' ';')"
    sleep 1
done
say "array and merge jobs completed"
[ -f out/sweep.html ] || fail "the merge job wrote no out/sweep.html"

# --- one run of the same sweep in one process -----------------------------
say "one run: frameid sweep $SCENARIO --noise $NOISE --trials $TRIALS"
frameid sweep "$SCENARIO" --noise "$NOISE" --trials "$TRIALS" --out one >one.log ||
    fail "the single run failed: $(cat one.log)"
for f in trials.csv summary.json sweep.json representative.json; do
    [ -f "out/sweep/$f" ] || fail "merge wrote no $f"
    cmp "one/$f" "out/sweep/$f" || fail "$f: merged shards differ from one run"
done
# The README's way to rerun a failed shard: that array task alone.
rm -rf shards/3
rerun=$(timeout "$TIMEOUT" sbatch --parsable --wait --array=3 sweep.sbatch) ||
    fail "sbatch --wait --array=3 sweep.sbatch failed (see slurm-*_3.out)"
[ "$(echo slurm-"$rerun"_*.out)" = "slurm-${rerun}_3.out" ] ||
    fail "sbatch --array=3 sweep.sbatch ran other tasks than 3: $(echo slurm-"$rerun"_*.out)"
frameid merge shards/* --out remerged >/dev/null || fail "merge after rerunning shard 3 failed"
for f in trials.csv summary.json sweep.json representative.json; do
    cmp "one/$f" "remerged/$f" || fail "$f: shards with shard 3 rerun differ from one run"
done
say "shard 3 rerun alone (sbatch --array=3 sweep.sbatch) and merged again: still == one run"
shards=$(ls -d shards/* | wc -l)
trials=$(($(wc -l <one/trials.csv) - 1))
say "PASSED: $shards shards merged == one run ($trials trials; trials.csv, summary.json, sweep.json, representative.json byte for byte)"
echo "slurm-test: 1 passed, 0 failed"
