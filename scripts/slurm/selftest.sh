#!/usr/bin/env bash
# Self-test of scripts/slurm/local-cluster.sh, and a record of how Slurm (22.05) treats job
# arrays: starts a cluster in a temporary folder, runs a 4-task array and an afterok job,
# then checks what lamina relies on when a task fails, is requeued or retried; stops the
# cluster and checks that none of its processes is left. Root only; exit 77 = cannot run here.
#   scripts/slurm/selftest.sh          (about a minute and a half)
#   KEEP=1 scripts/slurm/selftest.sh   keep the temporary folder
# Single quotes keep $SLURM_* for the job; functions run through traps and wait_for.
# shellcheck disable=SC2016,SC2317
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cluster=$here/local-cluster.sh

tmp=$(mktemp -d /tmp/slurm-selftest.XXXXXX)
dir=$tmp/cluster
work=$tmp/work
fail=0
cleanup() {
  local rc=$?
  "$cluster" stop "$dir" || rc=1
  # A daemon of this cluster has $dir in its arguments or environment (SLURM_CONF, the marker).
  local left="" pid
  for pid in $(pgrep -x 'munged|slurmctld|slurmd|slurmstepd' || true); do
    [[ $(awk '{print $3}' "/proc/$pid/stat" 2>/dev/null) == Z ]] && continue
    grep -qaF "$dir" "/proc/$pid/cmdline" "/proc/$pid/environ" 2>/dev/null && left+=" $pid"
  done
  echo "+ pgrep -a 'slurm|munge'"
  pgrep -a 'slurm|munge' || echo "(none)"
  if [[ -n $left ]]; then
    echo "FAIL: processes of the cluster left after stop: $left" >&2
    rc=1
  else
    echo "ok: no process of the cluster left"
  fi
  if [[ -n ${KEEP:-} ]]; then echo "kept $tmp"; else rm -rf "$tmp"; fi
  exit "$rc"
}

now() { echo "${EPOCHREALTIME/,/.}"; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }
run() {
  echo "+ $*" >&2
  "$@"
}
check() {
  local what=$1
  shift
  if "$@"; then
    echo "ok: $what"
  else
    echo "FAIL: $what" >&2
    fail=1
  fi
}
# Polls until the command succeeds; fails after $1 seconds.
wait_for() {
  local timeout=$1 deadline
  shift
  deadline=$((SECONDS + timeout))
  until "$@"; do
    ((SECONDS < deadline)) || {
      echo "timed out after ${timeout}s waiting for: $*" >&2
      return 1
    }
    sleep 0.3
  done
}
# One field of `scontrol show job` (JobState, Reason, Dependency, Restarts, ExitCode).
field() { scontrol show job -o "$1" | tr ' ' '\n' | sed -n "s/^$2=//p" | head -n 1; }
queue_empty() { [[ -z $(squeue -h) ]]; }
gone() { [[ -z $(squeue -h -r -j "$1" 2>/dev/null) ]]; }
state_is() { [[ $(field "$1" JobState) == "$2" ]]; }
reason_is() { [[ $(field "$1" Reason) == "$2" ]]; }

t=$(now)
rc=0
"$cluster" start "$dir" || rc=$?
((rc == 77)) && exit 77
((rc == 0)) || exit "$rc"
trap cleanup EXIT
echo "cluster started in $(since "$t") s"
# shellcheck source=/dev/null
. "$dir/env.sh"
mkdir -p "$work"
cd "$work"
check "sbatch is the cluster's wrapper" [ "$(command -v sbatch)" = "$dir/bin/sbatch" ]
check "the cluster's network has lo only" \
  [ "$("$dir/run-in-cluster" ip -o link show | awk -F': ' '{print $2}')" = lo ]

echo "== 1. a 4-task array, then an afterok job"
cat >array.sh <<'EOF'
#!/bin/bash
#SBATCH --array=0-3
#SBATCH --requeue
#SBATCH --output=array_%A_%a.out
echo "$SLURM_ARRAY_TASK_ID" > "out_$SLURM_ARRAY_TASK_ID"
echo "task $SLURM_ARRAY_TASK_ID of $SLURM_ARRAY_JOB_ID is job $SLURM_JOB_ID"
sleep 2
EOF
t=$(now)
array=$(run sbatch --parsable array.sh)
after=$(run sbatch --parsable --dependency="afterok:$array" --output=after_%j.out \
  --wrap 'cat out_0 out_1 out_2 out_3 | tr "\n" " "')
wait_for 120 queue_empty
echo "array + afterok job done in $(since "$t") s"
check "each task wrote its index" [ "$(cat out_0 out_1 out_2 out_3 | tr '\n' ' ')" = "0 1 2 3 " ]
check "afterok job ran after all tasks" [ "$(cat "after_$after.out")" = "0 1 2 3 " ]
check "one output file per task (%A_%a)" [ "$(echo array_"$array"_{0,1,2,3}.out)" = \
  "$(find . -name "array_${array}_*.out" | sort | sed 's|^./||' | tr '\n' ' ' | sed 's/ $//')" ]
check "afterok job COMPLETED" state_is "$after" COMPLETED
head array_"$array"_*.out

echo "== 2. a failing task: the afterok job never runs"
fails=$(run sbatch --parsable --array=0-3 --output=fail_%A_%a.out \
  --wrap 'sleep 1; [ "$SLURM_ARRAY_TASK_ID" != 2 ]')
stays=$(run sbatch --parsable --dependency="afterok:$fails" --wrap true)
killed=$(run sbatch --parsable --dependency="afterok:$fails" --kill-on-invalid-dep=yes --wrap true)
wait_for 60 gone "$fails"
check "task 2 FAILED, exit code 1:0" \
  [ "$(field "${fails}_2" JobState) $(field "${fails}_2" ExitCode)" = "FAILED 1:0" ]
wait_for 15 state_is "$killed" CANCELLED
check "--kill-on-invalid-dep=yes: CANCELLED" state_is "$killed" CANCELLED
check "default: PENDING (DependencyNeverSatisfied)" [ "$(field "$stays" JobState) $(field "$stays" \
  Reason)" = "PENDING DependencyNeverSatisfied" ]
scontrol show job "$stays" | grep -E 'JobState|Dependency'
run scancel "$stays"

echo "== 3. scontrol requeue of a running task"
requeued=$(run sbatch --parsable --array=0-1 --open-mode=append --output=rq_%A_%a.out \
  --wrap 'echo "task $SLURM_ARRAY_TASK_ID run ${SLURM_RESTART_COUNT:-0}"; sleep 4')
waiter=$(run sbatch --parsable --dependency="afterok:$requeued" --wrap true)
wait_for 30 state_is "${requeued}_1" RUNNING
t=$(now)
run scontrol requeue "${requeued}_1"
squeue -r -o '%i %T %r'
wait_for 90 gone "$requeued"
echo "requeued task finished its rerun $(since "$t") s after the requeue"
check "task 1 ran twice (open-mode=append keeps both)" \
  [ "$(grep '^task 1 run' "rq_${requeued}_1.out" | tr '\n' ' ')" = "task 1 run 0 task 1 run 1 " ]
cat "rq_${requeued}_1.out"
check "Restarts=1" [ "$(field "${requeued}_1" Restarts)" = 1 ]
wait_for 15 state_is "$waiter" COMPLETED
check "afterok job ran after the rerun" state_is "$waiter" COMPLETED

echo "== 4a. retry inside the job script"
cat >retry.sh <<'EOF'
#!/bin/bash
#SBATCH --array=0-3
#SBATCH --output=retry_%A_%a.out
# The first attempt of task 1 fails; the loop runs it again. Slurm sees one success.
attempt() {
  [ "$SLURM_ARRAY_TASK_ID" != 1 ] || [ -e "tried_$SLURM_ARRAY_JOB_ID" ] ||
    { touch "tried_$SLURM_ARRAY_JOB_ID"; return 1; }
}
for try in 1 2 3; do
  if attempt; then echo "task $SLURM_ARRAY_TASK_ID ok on try $try"; exit 0; fi
  echo "task $SLURM_ARRAY_TASK_ID failed on try $try" >&2
  sleep 1
done
exit 1
EOF
retried=$(run sbatch --parsable retry.sh)
retry_after=$(run sbatch --parsable --dependency="afterok:$retried" --wrap true)
wait_for 60 gone "$retried"
wait_for 15 state_is "$retry_after" COMPLETED
check "task 1 ok on try 2" grep -q "task 1 ok on try 2" "retry_${retried}_1.out"
check "afterok job ran" state_is "$retry_after" COMPLETED

echo "== 4b. scontrol requeue of a FAILED task"
failed=$(run sbatch --parsable --array=0-3 --open-mode=append --output=rf_%A_%a.out \
  --wrap 'echo "run ${SLURM_RESTART_COUNT:-0}"; [ "$SLURM_ARRAY_TASK_ID" != 2 ] || [ -e fixed ]')
whole=$(run sbatch --parsable --dependency="afterok:$failed" --wrap true)
wait_for 60 gone "$failed"
wait_for 15 reason_is "$whole" DependencyNeverSatisfied
touch fixed
run scontrol requeue "${failed}_2"
t=$(now)
wait_for 90 state_is "${failed}_2" COMPLETED
echo "requeued FAILED task completed $(since "$t") s after the requeue"
check "the FAILED task ran again and passed" \
  [ "$(tr '\n' ' ' <"rf_${failed}_2.out")" = "run 0 run 1 " ]
sleep 3
check "afterok on the whole array stays unsatisfied" \
  [ "$(field "$whole" Reason)" = DependencyNeverSatisfied ]
scontrol show job "$whole" | grep -E 'JobState|Dependency'
run scontrol update jobid="$whole" \
  dependency="afterok:${failed}_0:${failed}_1:${failed}_2:${failed}_3"
wait_for 15 state_is "$whole" COMPLETED
check "after a dependency update to the 4 tasks, the job runs" state_is "$whole" COMPLETED

echo
echo "jobcomp.log (one line per finished job or requeued run):"
sed -E 's/.*(JobId=[0-9]+).*(JobState=[A-Z]+).*(StartTime=[^ ]+) (EndTime=[^ ]+).*/\1 \2 \3 \4/' \
  "$dir/log/jobcomp.log" | tail -n 8
((fail == 0)) && echo "ALL OK" || echo "SOME CHECKS FAILED"
exit "$fail"
