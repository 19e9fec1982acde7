#!/usr/bin/env bash
# The Slurm recipe of docs/cluster.md, run on a real one-node Slurm (issue 27).
#
#   tests/cluster/slurm-test.sh
#
# Needs root and Debian's slurm-wlm and munge (.ci/run installs them). It starts munged,
# slurmctld and slurmd from a temporary folder (its own munge key and socket, a slurm.conf
# through SLURM_CONF, state and spool folders, ports), builds the release binary and puts it
# on PATH, and, with ROOT pointing at a temporary folder holding the sample office:
#   1. the recipe: runs the priming job and slurm-submit.sh (4 shards) exactly as
#      docs/cluster.md writes them, over two weeks (ANNUAL_ARGS="--start … --end …"), the
#      scripts of docs/examples/cluster unchanged; the merge must be byte-identical to one
#      unsharded run with the same flags;
#   2. preemption: a second study over the same cache (40 days, --forward), whose array task 2
#      is killed by `scontrol requeue` once it has written its first checkpoint; it must
#      continue from that checkpoint, and the merge must again be byte-identical.
# It stops the daemons it started, by PID, and removes its folders, also when it fails.
# Where it cannot start a cluster it prints "skipped: <why>" and exits 0 (.ci/run fails then).
#
# Environment: SLURM_TEST_TIMEOUT (seconds for all jobs, default 900), SLURM_TEST_PORT
# (slurmctld's port, slurmd's is the next one; default 26817), SLURM_TEST_KEEP=1 (keep the
# temporary folder), DAYSTEP_BIN_DIR (a folder holding a release `daystep`; default: cargo
# build --release --locked).
set -euo pipefail

t0=$SECONDS
repo=$(cd "$(dirname "$0")/../.." && pwd)
# shellcheck disable=SC2034 # used by the documented block, through eval
examples=$repo/docs/examples/cluster
shards=4
# The recipe's period: two weeks of June.
recipe_start=2021-06-14
recipe_end=2021-06-27
# The preemption study's: 40 days, 10 per shard, so that a shard writes a checkpoint (a batch
# of 8 days) well before it ends.
requeue_start=2021-06-01
requeue_end=2021-07-10
timeout=${SLURM_TEST_TIMEOUT:-900}
port=${SLURM_TEST_PORT:-26817}
victim=2 # the array task killed and requeued mid-shard

say() { printf 'slurm-test: %s\n' "$*"; }
skip() {
  printf 'skipped: %s\n' "$*"
  exit 0
}
fail() {
  printf 'slurm-test: FAILED: %s\n' "$*" >&2
  exit 1
}

# --- can a cluster start here? ---
if [[ $(id -u) != 0 ]]; then
  skip "not root (slurmd must run as root to start jobs)"
fi
for c in munged munge slurmctld slurmd sbatch scontrol squeue scancel sinfo; do
  command -v "$c" >/dev/null || skip "no $c (apt-get install slurm-wlm munge)"
done

# --- the daemons, from one temporary folder ---
tmp=$(mktemp -d "${TMPDIR:-/tmp}/daystep-slurm.XXXXXX")
# The cluster's state, the sample's runs and caches take ~400 MB. A full disk does not stop
# slurmctld, it only leaves jobs pending (seen in CI), so refuse to start without room.
need_mb=1024
free_mb=$(df -Pm "$tmp" | awk 'NR == 2 { print $4 }')
if ((free_mb < need_mb)); then
  rmdir "$tmp"
  fail "only ${free_mb} MB free under ${tmp%/*} (needs ${need_mb} MB): $(df -Ph "${tmp%/*}" | tail -n 1)"
fi
chmod 755 "$tmp" # munged wants its socket's folders searchable by all
declare -A pid=()
stop_daemons() {
  local name p n
  # Cancel what is left (only this cluster's jobs: SLURM_CONF names our slurmctld), so no
  # job step outlives the test, then stop slurmd, slurmctld and munged in that order.
  if [[ -n ${pid[slurmctld]:-} ]] && kill -0 "${pid[slurmctld]}" 2>/dev/null; then
    mapfile -t jobs < <(squeue -h -o %A 2>/dev/null || true)
    if ((${#jobs[@]})); then
      scancel "${jobs[@]}" 2>/dev/null || true
      for ((n = 0; n < 30; n++)); do
        [[ -z $(squeue -h -o %A 2>/dev/null || true) ]] && break
        sleep 1
      done
    fi
  fi
  for name in slurmd slurmctld munged; do
    p=${pid[$name]:-}
    [[ -n $p ]] || continue
    kill -TERM "$p" 2>/dev/null || true
    for ((n = 0; n < 50; n++)); do
      kill -0 "$p" 2>/dev/null || break
      sleep 0.2
    done
    if kill -0 "$p" 2>/dev/null; then
      kill -KILL "$p" 2>/dev/null || true
    fi
    wait "$p" 2>/dev/null || true
    unset "pid[$name]"
    stopped+=("$name($p)")
  done
}
show_logs() {
  local f
  for f in "$tmp"/slurmctld.log "$tmp"/slurmd.log "$tmp"/submit/*.out; do
    [[ -f $f ]] || continue
    printf -- '--- %s (last 30 lines)\n' "${f#"$tmp"/}" >&2
    tail -n 30 "$f" >&2
  done
}
cleanup() {
  local rc=$?
  set +e
  stopped=()
  ((rc == 0)) || show_logs
  stop_daemons
  ((${#stopped[@]})) && say "daemons stopped: ${stopped[*]}"
  if [[ ${SLURM_TEST_KEEP:-} == 1 ]]; then
    say "kept $tmp"
  else
    rm -rf "$tmp"
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

node=$(hostname -s)
for p in "$port" "$((port + 1))"; do
  if (: <"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then
    fail "port $p is in use (set SLURM_TEST_PORT)"
  fi
done
mkdir -p "$tmp"/munge "$tmp"/state "$tmp"/spool
head -c 1024 /dev/urandom >"$tmp"/munge/munge.key
chmod 400 "$tmp"/munge/munge.key
socket=$tmp/munge/munge.socket
export SLURM_CONF=$tmp/slurm.conf
# One node with 16 CPUs whatever this machine has (config_overrides): the 4 shard tasks ask
# for 4 CPUs each and then run at once. Memory is not a consumable resource (CR_Core), so
# the scripts' --mem requests fit on any machine.
cat >"$SLURM_CONF" <<EOF
ClusterName=daystep-test
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# cred_expire also delays a requeued job's start (default 120 s).
AuthInfo=socket=$socket,cred_expire=5
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
SlurmdParameters=config_overrides
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=3600
KillWait=5
# A requeued task appends to its output file, so the log shows both runs.
JobFileAppend=1
NodeName=$node NodeAddr=127.0.0.1 CPUs=16 RealMemory=65536 State=UNKNOWN
PartitionName=daystep Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF

munged --foreground --force --key-file="$tmp"/munge/munge.key --socket="$socket" \
  --pid-file="$tmp"/munge/munged.pid --seed-file="$tmp"/munge/munged.seed \
  >"$tmp"/munged.log 2>&1 &
pid[munged]=$!
for ((n = 0; n < 50; n++)); do
  [[ -S $socket ]] && break
  sleep 0.1
done
munge -S "$socket" -n | unmunge -S "$socket" >/dev/null || fail "munged does not answer ($(cat "$tmp"/munged.log))"
slurmctld -D >"$tmp"/slurmctld.err 2>&1 &
pid[slurmctld]=$!
slurmd -D -N "$node" >"$tmp"/slurmd.err 2>&1 &
pid[slurmd]=$!
up=
for ((n = 0; n < 60; n++)); do
  if [[ $(sinfo -h -n "$node" -o %t 2>/dev/null) == idle ]]; then
    up=1
    break
  fi
  for name in "${!pid[@]}"; do
    kill -0 "${pid[$name]}" 2>/dev/null || fail "$name exited: $(tail -n 5 "$tmp/$name".err "$tmp/$name".log 2>/dev/null)"
  done
  sleep 0.5
done
[[ -n $up ]] || fail "node $node is not idle after 30 s: $(sinfo 2>&1)"
t_cluster=$SECONDS
say "cluster up in $((t_cluster - t0)) s: munged ${pid[munged]}, slurmctld ${pid[slurmctld]}, slurmd ${pid[slurmd]} on $node (SLURM_CONF=$SLURM_CONF)"

# --- the binary the scripts call ---
if [[ -n ${DAYSTEP_BIN_DIR:-} ]]; then
  bin=$DAYSTEP_BIN_DIR
else
  target=${CARGO_TARGET_DIR:-target}
  [[ $target == /* ]] || target=$repo/$target
  (cd "$repo" && cargo build --release --locked --quiet)
  bin=$target/release
fi
[[ -x $bin/daystep ]] || fail "no daystep in $bin"
export PATH=$bin:$PATH
t_build=$SECONDS
say "daystep: $(command -v daystep) ($((t_build - t_cluster)) s to build)"

# --- the shared folder, as docs/cluster.md lays it out ---
export ROOT=$tmp/shared
mkdir -p "$ROOT"/scenes/office "$ROOT"/weather "$ROOT"/runs
cp "$repo"/scenes/office/{scene.toml,office.obj,office.mtl,office.pts} "$ROOT"/scenes/office/
cp "$repo"/scenes/office/weather.epw "$ROOT"/weather/greensboro.epw
SCENE=$ROOT/scenes/office/scene.toml
EPW=$ROOT/weather/greensboro.epw
mkdir -p "$tmp"/submit
cd "$tmp"/submit # where the jobs' output files go

deadline=$((SECONDS + timeout))
state_of() { # JobId → its JobState (one job or one array task)
  scontrol -o show job "$1" 2>/dev/null | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p' | head -n 1
}
until_state() { # JOB STATE…: waits until the job is in one of the states; fails on a final other one
  local job=$1 s want
  shift
  while :; do
    s=$(state_of "$job")
    for want in "$@"; do
      [[ $s == "$want" ]] && return 0
    done
    case $s in
    FAILED | CANCELLED | TIMEOUT | NODE_FAIL | OUT_OF_MEMORY | BOOT_FAIL | DEADLINE | PREEMPTED)
      fail "job $job is $s (waited for $*)"
      ;;
    esac
    if grep -qs 'No space left on device' "$tmp"/slurmctld.log "$tmp"/slurmd.log; then
      fail "the disk is full ($(df -Ph "$tmp" | tail -n 1)); job $job is ${s:-unknown}"
    fi
    ((SECONDS < deadline)) || fail "job $job is still ${s:-unknown} after ${timeout} s (waited for $*)"
    sleep 0.2
  done
}
job_ids() { # the output of slurm-submit.sh → "ARRAY MERGE"
  local a m
  a=$(sed -n 's/.*shards in job \([0-9]*\) .*/\1/p' <<<"$1")
  m=$(sed -n 's/.*merge in job \([0-9]*\).*/\1/p' <<<"$1")
  [[ -n $a && -n $m ]] || fail "cannot read the job ids in: $1"
  echo "$a $m"
}
check_study() { # STUDY ARRAY: every task completed with exit code 0
  local k line
  for ((k = 1; k <= shards; k++)); do
    line=$(scontrol -o show job "${2}_$k")
    [[ $line == *JobState=COMPLETED* && $line == *ExitCode=0:0* ]] || fail "study $1, array task ${2}_$k: $line"
  done
}
same_as_unsharded() { # STUDY ANNUAL_ARGS…: one unsharded run (a cache of its own) = the merge
  local study=$1 f t=$SECONDS
  shift
  daystep annual "$SCENE" --weather "$EPW" --out "$tmp/unsharded-$study" --cache "$tmp/cache-$study" \
    --quality default "$@" 2>&1 | tail -n 1
  for f in illuminance.csv direct_sun.csv metrics.csv summary.json; do
    cmp "$ROOT/runs/$study/merged/$f" "$tmp/unsharded-$study/$f" ||
      fail "study $study: merged $f differs from the unsharded run's"
  done
  say "study $study: the merge of $shards shards is byte-identical to one unsharded run" \
    "(illuminance.csv direct_sun.csv metrics.csv summary.json; unsharded run $((SECONDS - t)) s)"
}

# --- 1. the recipe: priming, then slurm-submit.sh, as docs/cluster.md writes them ---
# The priming block of docs/cluster.md with this test's ROOT, study and shard count; a
# change of that block's shape fails here, so the docs and this test stay one.
study=greensboro
export ANNUAL_ARGS="--start $recipe_start --end $recipe_end"
block=$(awk '/^prime=\$\(sbatch /{p = 1} p {print} p && /slurm-submit\.sh/ {exit}' "$repo"/docs/cluster.md)
# shellcheck disable=SC2016 # the docs' text, not expanded
[[ $block == *'sbatch --parsable'*'--wrap "daystep annual $SCENE --weather $EPW'* ]] ||
  fail "docs/cluster.md: no priming block (prime=\$(sbatch --parsable … --wrap \"daystep annual \$SCENE --weather \$EPW …)"
# shellcheck disable=SC2016 # $ROOT, $examples, … are expanded by the eval below.
block=$(printf '%s\n' "$block" |
  sed -e 's#/shared/daystep#$ROOT#g' \
    -e 's#\./slurm-submit\.sh pittsburgh "\$EPW" 8#"$examples"/slurm-submit.sh "$study" "$EPW" "$shards"#')
# shellcheck disable=SC2016
[[ $block == *'"$examples"/slurm-submit.sh'* && $block != *'/shared/'* ]] ||
  fail "docs/cluster.md: the priming block changed shape: $block"
say "1. the recipe: the priming block of docs/cluster.md, as run (ROOT=$ROOT, ANNUAL_ARGS=\"$ANNUAL_ARGS\"):"
printf '    %s\n' "$block"
t_submit=$SECONDS
prime=
eval "$block" >"$tmp"/submitted.txt
cat "$tmp"/submitted.txt
prime=${prime%%;*}
read -r array merge <<<"$(job_ids "$(cat "$tmp"/submitted.txt)")"
until_state "$prime" COMPLETED
t_prime=$SECONDS
say "priming job $prime done in $((t_prime - t_submit)) s"
until_state "$merge" COMPLETED
check_study "$study" "$array"
t_recipe=$SECONDS
say "shards (job $array, 1-$shards) and merge (job $merge) done $((t_recipe - t_prime)) s after priming"
# A shard reads the primed operator, or needs none: every coefficient it sums was cached
# (by the priming job or a sibling shard), or its new nodes take their ancestors'
# interreflection and need only sensor rays. It never builds one.
for ((k = 1; k <= shards; k++)); do
  r="$ROOT/runs/$study/shard-$k/report.json"
  grep -q '"operator_from_cache": *true' "$r" || grep -q '"operator_needed": *false' "$r" ||
    fail "shard $k built the interreflection operator itself: the priming job did not fill the cache"
done
field() { # JOB NAME → the job's NAME=value
  scontrol -o show job "$1" | tr ' ' '\n' | sed -n "s/^$2=//p" | head -n 1
}
prime_end=$(field "$prime" EndTime)
for ((k = 1; k <= shards; k++)); do
  s=$(field "${array}_$k" StartTime)
  [[ ! $s < $prime_end ]] || fail "array task ${array}_$k started at $s, before the priming job ended ($prime_end)"
done
say "every shard started after the priming job ended ($prime_end) and read the interreflection operator it cached"
# shellcheck disable=SC2086 # ANNUAL_ARGS is split into words, as the sbatch script does.
same_as_unsharded "$study" $ANNUAL_ARGS
t_check1=$SECONDS

# --- 2. preemption: a second study over the same cache; one task requeued mid-shard ---
# With daylight coefficients (the default) a shard spends its time on the coefficients and
# then writes its days in a fraction of a second, too fast to be caught between two
# checkpoints; --forward solves every step, so the days take seconds.
study=greensboro-requeue
export ANNUAL_ARGS="--start $requeue_start --end $requeue_end --forward"
say "2. preemption: slurm-submit.sh $study (ANNUAL_ARGS=\"$ANNUAL_ARGS\")"
submitted=$("$examples"/slurm-submit.sh "$study" "$EPW" "$shards")
echo "$submitted"
read -r array merge <<<"$(job_ids "$submitted")"
shard_dir=$ROOT/runs/$study/shard-$victim
partial=$shard_dir/illuminance.csv.partial
partial_sun=$shard_dir/direct_sun.csv.partial
until_state "${array}_$victim" RUNNING
# A checkpoint is a whole batch of days (24 hourly rows a day; a batch is an eighth of the
# shard's days, at least one) behind the header, in both tables: the first one is waited
# for. Each worker takes its days itself, so a day is never held back by a later one that
# a worker took while waiting inside it (sequence/day_feed.rs), and checkpoints follow the
# days; the first comes once the first days in flight are done.
rows=24
rows_in() { # FILE → its rows after the header (0 when absent)
  if [[ -f $1 ]]; then
    echo $(($(wc -l <"$1") - 1))
  else
    echo 0
  fi
}
while :; do
  (($(rows_in "$partial") >= rows && $(rows_in "$partial_sun") >= rows)) && break
  [[ -f $shard_dir/illuminance.csv ]] && fail "shard $victim finished before its first checkpoint was seen; lengthen the period"
  s=$(state_of "${array}_$victim")
  [[ $s == RUNNING ]] || fail "array task ${array}_$victim is $s before its first checkpoint"
  ((SECONDS < deadline)) || fail "no checkpoint in $partial after ${timeout} s"
  sleep 0.1
done
scontrol requeue "${array}_$victim"
t_kill=$SECONDS
killed_rows=$(rows_in "$partial")
[[ ! -f $shard_dir/illuminance.csv ]] || fail "shard $victim had finished when it was requeued; lengthen the period"
say "requeued array task ${array}_$victim mid-shard: $killed_rows rows in its checkpoint, no final table yet"
until_state "$merge" COMPLETED
check_study "$study" "$array"
t_done=$SECONDS
say "shards and merge done $((t_done - t_kill)) s after the requeue"
restarts=$(scontrol -o show job "${array}_$victim" | sed -n 's/.*Restarts=\([0-9]*\).*/\1/p')
[[ $restarts == 1 ]] || fail "array task ${array}_$victim ran $((restarts + 1)) times, not twice"
victim_out=$tmp/submit/daystep-$study-${array}_$victim.out
last=$(grep '^daystep annual: .* steps (' "$victim_out" | tail -n 1 || true)
resumed=$(sed -n 's/.* computed, \([0-9]*\) resumed.*/\1/p' <<<"$last")
[[ -n $resumed ]] || fail "no summary line in $victim_out"
((resumed >= rows)) || fail "the requeued shard resumed $resumed steps, not its checkpoint's $rows or more: $last"
say "the requeued task ran twice and continued from its checkpoint: $last"
# shellcheck disable=SC2086
same_as_unsharded "$study" $ANNUAL_ARGS

say "passed in $((SECONDS - t0)) s: cluster start $((t_cluster - t0)) s, build $((t_build - t_cluster)) s," \
  "recipe $((t_recipe - t_submit)) s (priming $((t_prime - t_submit)) s) + unsharded run $((t_check1 - t_recipe)) s," \
  "preemption study $((t_done - t_check1)) s + unsharded run $((SECONDS - t_done)) s"
