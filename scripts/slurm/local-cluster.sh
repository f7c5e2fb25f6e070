#!/usr/bin/env bash
# A real one-node Slurm cluster (munged + slurmctld + slurmd) that lives in one state folder
# and talks over loopback only, for testing lamina's Slurm job arrays end to end.
#
#   scripts/slurm/local-cluster.sh install     apt-get install slurmctld slurmd slurm-client munge
#   scripts/slurm/local-cluster.sh start DIR   fresh cluster in DIR (new or empty folder); root only
#   scripts/slurm/local-cluster.sh status DIR  sinfo + squeue
#   scripts/slurm/local-cluster.sh stop DIR    stop what start started; safe to repeat
#
# After start, `. DIR/env.sh` (or prefix a command with DIR/run-in-cluster) to use it: both set
# SLURM_CONF and put DIR/bin first on PATH, whose sbatch/squeue/scontrol/... run the real
# client inside the cluster's network namespace. DIR/log holds the daemon logs and
# jobcomp.log (one line per finished job or requeued run, with its state and exit code); it
# all stays in DIR until the caller removes it (after stop).
#
# Network: the daemons, the jobs and the wrapped clients run in a private network namespace
# (kept at DIR/netns) whose only interface is lo, so nothing can listen on or reach any other
# address. There is no host-network mode: slurmctld 22.05 binds 0.0.0.0 even with
# CommunicationParameters=NoInAddrAny. Talking to the munge socket (a unix socket in DIR)
# works from anywhere.
#
# Exit code 77 means "cannot run here" (not root, no apt-get, Slurm not installed, no network
# namespaces), so a test can report a skip. Knobs: LAMINA_SLURM_START_TIMEOUT (s, default 60),
# LAMINA_SLURM_CRED_EXPIRE (s, default 10; also how long a requeued job waits before it may
# start again), LAMINA_SLURM_EXTRA_CONF (more slurm.conf lines, e.g. "RequeueExit=75").
set -euo pipefail

readonly PROG=local-cluster
readonly PACKAGES=(slurmctld slurmd slurm-client munge)
# Client commands that get a wrapper in DIR/bin (those that exist).
readonly CLIENTS=(sbatch srun salloc squeue scancel scontrol sinfo sacct sattach sbcast sdiag
  sprio sshare sstat strigger)
# Every daemon is started with this variable set to DIR; what they fork inherits it. That, and
# slurmstepd's SLURM_CONF, is how stop recognises this cluster's processes and nothing else.
readonly MARKER=LAMINA_SLURM_DAEMON_DIR
START_DIR=""
export PATH="$PATH:/usr/sbin:/sbin"

log() { printf '%s: %s\n' "$PROG" "$*" >&2; }
die() {
  log "error: $*"
  exit 1
}
skip() {
  log "cannot run here: $*"
  exit 77
}

usage() {
  sed -n '5,8p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

# ---------------------------------------------------------------------------- install

cmd_install() {
  local missing=() tool
  for tool in slurmctld slurmd sbatch munged; do
    command -v "$tool" >/dev/null || missing+=("$tool")
  done
  if ((${#missing[@]} == 0)); then
    log "Slurm and munge are already installed"
    return 0
  fi
  local sudo=()
  if ((EUID != 0)); then
    command -v sudo >/dev/null || skip "need root or sudo to install ${PACKAGES[*]}"
    sudo=(sudo)
  fi
  command -v apt-get >/dev/null || skip "no apt-get; install ${PACKAGES[*]} by hand"
  log "installing ${PACKAGES[*]} (missing: ${missing[*]})"
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
    "${PACKAGES[@]}"
}

# ---------------------------------------------------------------------------- helpers

abs_dir() { (cd "$1" && pwd -P); }

# slurm.conf has no quoting, and unix socket paths (munge's, slurmd's spool) are limited to
# 107 bytes, so DIR must be plain and short.
check_dir_name() {
  local dir=$1
  [[ $dir =~ ^[A-Za-z0-9._/+-]+$ ]] || die "DIR must be a plain path (letters, digits, ._/+-): $dir"
  ((${#dir} <= 64)) || die "DIR path too long for unix sockets (max 64 bytes): $dir"
}

# True if the process exists and is not a zombie.
alive() {
  local pid=$1 state
  [[ $pid =~ ^[0-9]+$ ]] || return 1
  state=$(awk '{print $3}' "/proc/$pid/stat" 2>/dev/null) || return 1
  [[ -n $state && $state != Z && $state != X ]]
}

# True if the process belongs to the cluster in DIR: it carries MARKER=DIR (munged, slurmctld,
# slurmscriptd, slurmd), or it is a slurmstepd with SLURM_CONF=DIR/slurm.conf (slurmd gives
# slurmstepd an environment of just SLURM_CONF).
ours() {
  local pid=$1 dir=$2
  grep -qzxF -- "$MARKER=$dir" "/proc/$pid/environ" 2>/dev/null && return 0
  [[ $(cat "/proc/$pid/comm" 2>/dev/null) == slurmstepd ]] &&
    grep -qzxF -- "SLURM_CONF=$dir/slurm.conf" "/proc/$pid/environ" 2>/dev/null
}

# This shell and its ancestors, as " pid pid ... ": never signalled, never listed.
self_and_ancestors() {
  local pid=$$ list=" "
  while [[ $pid =~ ^[0-9]+$ ]] && ((pid > 1)); do
    list+="$pid "
    pid=$(awk '/^PPid:/ {print $2}' "/proc/$pid/status" 2>/dev/null) || break
  done
  echo "$list"
}

# Live processes of the cluster in DIR, except this shell and its ancestors.
our_pids() {
  local dir=$1 p pid skip
  skip=$(self_and_ancestors)
  for p in /proc/[0-9]*; do
    pid=${p#/proc/}
    [[ $skip == *" $pid "* ]] && continue
    alive "$pid" && ours "$pid" "$dir" && echo "$pid"
  done
  return 0
}

# Waits until none of the pids is alive; returns 1 after $2 seconds.
wait_gone() {
  local pids=$1 pid any deadline=$((SECONDS + $2))
  while ((SECONDS < deadline)); do
    any=0
    for pid in $pids; do alive "$pid" && any=1; done
    ((any == 0)) && return 0
    sleep 0.2
  done
  return 1
}

# SIGTERM, wait, then SIGKILL; only processes of the cluster in DIR are signalled.
terminate() {
  local dir=$1 what=$2 pids=$3 pid live=""
  for pid in $pids; do
    alive "$pid" && ours "$pid" "$dir" && live+=" $pid"
  done
  [[ -z $live ]] && return 0
  log "stopping $what (pid$live)"
  # shellcheck disable=SC2086 # the pid list is meant to be split
  kill -TERM $live 2>/dev/null || true
  wait_gone "$live" 15 && return 0
  log "$what did not exit after SIGTERM; sending SIGKILL"
  # shellcheck disable=SC2086
  kill -KILL $live 2>/dev/null || true
  wait_gone "$live" 5 || log "warning: $what (pid$live) still alive"
}

pid_from_file() {
  local pid
  [[ -f $1 ]] || return 0
  pid=$(tr -dc '0-9' <"$1")
  [[ -n $pid ]] && echo "$pid"
  return 0
}

has_netns() { [[ -f $1/netns ]] && mountpoint -q "$1/netns"; }

# Runs a command inside the cluster's network namespace with SLURM_CONF set.
in_cluster() {
  local dir=$1
  shift
  has_netns "$dir" || return 1
  SLURM_CONF=$dir/slurm.conf nsenter --net="$dir/netns" -- "$@"
}

print_logs() {
  local f
  for f in "$1"/log/{netns,start}.err "$1/munge/munged.log" "$1"/log/{slurmctld,slurmd}.log; do
    [[ -s $f ]] || continue
    printf '\n===== %s (last 60 lines) =====\n' "$f" >&2
    tail -n 60 "$f" >&2
  done
}

# ---------------------------------------------------------------------------- start

make_netns() {
  local dir=$1 tool
  for tool in unshare nsenter ip mountpoint; do
    command -v "$tool" >/dev/null || skip "$tool not found (util-linux, iproute2)"
  done
  : >"$dir/netns"
  unshare --net="$dir/netns" true 2>"$dir/log/netns.err" ||
    skip "cannot create a network namespace: $(cat "$dir/log/netns.err")"
  # lo is the only interface. 127.0.0.2 is a second loopback address because glibc's
  # getaddrinfo with AI_ADDRCONFIG and AF_INET, as Slurm calls it, finds no IPv4 address when
  # the only one is 127.0.0.1 and then fails even for "127.0.0.1".
  nsenter --net="$dir/netns" -- sh -c 'ip link set lo up && ip addr add 127.0.0.2/8 dev lo' \
    2>>"$dir/log/netns.err" || die "cannot set up lo in the network namespace"
  local links
  links=$(nsenter --net="$dir/netns" -- ip -o link show | awk -F': ' '{print $2}' | tr '\n' ' ')
  [[ $links == "lo " ]] || die "the network namespace has more than lo: $links"
}

write_conf() {
  local dir=$1 cpus mem
  cpus=$(nproc)
  # RealMemory above what slurmd finds would drain the node: ask slurmd.
  mem=$(slurmd -C 2>/dev/null | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' | head -n 1)
  [[ -n $mem ]] || mem=$(awk '/^MemTotal:/ {print int($2 / 1024)}' /proc/meminfo)
  cat >"$dir/slurm.conf" <<EOF
# Written by scripts/slurm/local-cluster.sh: one node, loopback only, everything in $dir.
ClusterName=lamina-test
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# cred_expire is also how long a requeued job waits before it may start again (default 120 s).
AuthInfo=socket=$dir/munge/munge.socket.2,cred_expire=${LAMINA_SLURM_CRED_EXPIRE:-10}
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/pgid
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/log/jobcomp.log
MpiDefault=none
MailProg=/bin/true
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
JobRequeue=1
KillWait=5
MinJobAge=600
# Look at pending jobs every second (defaults 60 s and 30 s), so that a job whose begin time
# passes (a requeued one) starts within a second or two.
SchedulerParameters=sched_interval=1,bf_interval=1
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=main Nodes=localhost Default=YES MaxTime=INFINITE State=UP
${LAMINA_SLURM_EXTRA_CONF:-}
EOF
  cat >"$dir/cgroup.conf" <<EOF
# Unused (proctrack/pgid, task/none); here so that nothing reads /etc/slurm/cgroup.conf.
CgroupPlugin=autodetect
EOF
}

write_client_env() {
  local dir=$1 name real
  mkdir -p "$dir/bin"
  for name in "${CLIENTS[@]}"; do
    real=$(command -v "$name") || continue
    cat >"$dir/bin/$name" <<EOF
#!/bin/sh
# $name of the local cluster in $dir, run in its network namespace.
SLURM_CONF=$dir/slurm.conf
export SLURM_CONF
# Without a config file Slurm clients look for one through DNS SRV records.
[ -f "\$SLURM_CONF" ] || { echo "$name: no cluster config \$SLURM_CONF" >&2; exit 1; }
exec nsenter --net=$dir/netns -- $real "\$@"
EOF
    chmod 755 "$dir/bin/$name"
  done
  cat >"$dir/run-in-cluster" <<EOF
#!/bin/sh
# Runs its arguments in the network namespace of the local cluster in $dir, with SLURM_CONF
# set and $dir/bin first on PATH.
SLURM_CONF=$dir/slurm.conf
PATH=$dir/bin:\$PATH
export SLURM_CONF PATH
exec nsenter --net=$dir/netns -- "\$@"
EOF
  chmod 755 "$dir/run-in-cluster"
  cat >"$dir/env.sh" <<EOF
# Source this to use the local Slurm cluster in $dir (its clients are in $dir/bin).
export SLURM_CONF=$dir/slurm.conf
export LAMINA_SLURM_DIR=$dir
case ":\$PATH:" in *":$dir/bin:"*) ;; *) export PATH=$dir/bin:\$PATH ;; esac
EOF
}

wait_munge() {
  local sock=$1/munge/munge.socket.2 deadline=$((SECONDS + 15))
  while ((SECONDS < deadline)); do
    if [[ -S $sock ]] && munge -n -S "$sock" 2>/dev/null | unmunge -S "$sock" >/dev/null 2>&1; then
      return 0
    fi
    sleep 0.2
  done
  return 1
}

cmd_start() {
  local dir=${1:-} tool
  [[ -n $dir ]] || usage
  ((EUID == 0)) || skip "start needs root (slurmd runs the jobs; the cluster gets its own netns)"
  for tool in munged munge unmunge slurmctld slurmd sinfo sbatch squeue scontrol scancel; do
    command -v "$tool" >/dev/null || skip "$tool not found; run: $0 install"
  done
  mkdir -p "$dir"
  dir=$(abs_dir "$dir")
  check_dir_name "$dir"
  [[ -z $(ls -A "$dir") ]] || die "$dir is not empty; start wants a fresh folder"

  local t0=$SECONDS
  START_DIR=$dir
  trap start_failed EXIT
  trap 'exit 130' INT TERM
  chmod 755 "$dir"
  mkdir -p "$dir/munge" "$dir/state" "$dir/spool" "$dir/log" "$dir/run"
  chmod 755 "$dir/munge"
  chmod 700 "$dir/state" "$dir/spool"
  make_netns "$dir"
  local ns=(nsenter "--net=$dir/netns" --)

  (umask 077 && dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none)
  # --force: munged refuses a socket whose folder's parents are not searchable by all (a
  # mktemp -d parent is 0700) and only warns with it; only root uses this socket.
  env "$MARKER=$dir" "${ns[@]}" munged --force \
    --socket="$dir/munge/munge.socket.2" --key-file="$dir/munge/munge.key" \
    --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" \
    --seed-file="$dir/munge/munged.seed" 2>>"$dir/log/start.err" ||
    die "munged failed to start"
  wait_munge "$dir" || die "munged does not answer on $dir/munge/munge.socket.2"

  write_conf "$dir"
  write_client_env "$dir"
  env "$MARKER=$dir" SLURM_CONF="$dir/slurm.conf" "${ns[@]}" slurmctld -f "$dir/slurm.conf" ||
    die "slurmctld failed to start"
  env "$MARKER=$dir" SLURM_CONF="$dir/slurm.conf" "${ns[@]}" \
    slurmd -f "$dir/slurm.conf" -N localhost || die "slurmd failed to start"

  local timeout=${LAMINA_SLURM_START_TIMEOUT:-60} state="" d
  local deadline=$((SECONDS + timeout))
  while ((SECONDS < deadline)); do
    state=$(in_cluster "$dir" sinfo -h -n localhost -o %T 2>/dev/null || true)
    [[ $state == idle ]] && break
    for d in slurmctld slurmd; do
      [[ -f $dir/run/$d.pid ]] && ! alive "$(pid_from_file "$dir/run/$d.pid")" && die "$d exited"
    done
    sleep 0.5
  done
  [[ $state == idle ]] || die "node not idle after ${timeout}s (state: ${state:-no answer})"
  trap - EXIT INT TERM
  log "cluster up in $((SECONDS - t0))s; use: . $dir/env.sh   (or $dir/run-in-cluster CMD)"
}

start_failed() {
  local rc=$?
  trap - EXIT
  log "start failed; logs follow"
  print_logs "$START_DIR"
  cmd_stop "$START_DIR" || true
  exit $((rc == 0 ? 1 : rc))
}

# ---------------------------------------------------------------------------- stop

cmd_stop() {
  local dir=${1:-}
  [[ -n $dir ]] || usage
  if [[ ! -d $dir ]]; then
    log "$dir does not exist; nothing to stop"
    return 0
  fi
  dir=$(abs_dir "$dir")
  local ctld slurmd munged pid rest=""
  ctld=$(pid_from_file "$dir/run/slurmctld.pid")
  slurmd=$(pid_from_file "$dir/run/slurmd.pid")
  munged=$(pid_from_file "$dir/munge/munged.pid")

  # Cancel the jobs first: slurmstepd outlives slurmd, and a cancel makes it kill the job's
  # processes and exit.
  if [[ -n $ctld && -n $slurmd ]] && alive "$ctld" && ours "$ctld" "$dir" && alive "$slurmd"; then
    local jobs
    # %i (1234_5, 1234_[6-9]) rather than a task's own job id, which scancel rejects as
    # "Invalid job id" once a finished array task has been requeued (22.05).
    jobs=$(in_cluster "$dir" timeout 10 squeue -h -o %i 2>/dev/null | sort -u | tr '\n' ' ' || true)
    if [[ -n ${jobs// /} ]]; then
      log "cancelling jobs: $jobs"
      # shellcheck disable=SC2086
      in_cluster "$dir" timeout 10 scancel $jobs 2>/dev/null || true
      # squeue lists pending, running and completing jobs; wait until none is left.
      local deadline=$((SECONDS + 30))
      while ((SECONDS < deadline)) &&
        [[ -n $(in_cluster "$dir" timeout 5 squeue -h -o %i 2>/dev/null || echo busy) ]]; do
        sleep 0.5
      done
    fi
  fi

  terminate "$dir" slurmd "$slurmd"
  terminate "$dir" slurmctld "$ctld"
  # Anything else of ours but munged: slurmscriptd, slurmstepd, a daemon that never wrote its
  # pid file.
  for pid in $(our_pids "$dir"); do
    [[ $pid == "$munged" || $(cat "/proc/$pid/comm" 2>/dev/null) == munged ]] || rest+=" $pid"
  done
  [[ -n $rest ]] && terminate "$dir" "leftover slurm processes" "$rest"
  terminate "$dir" munged "$munged"
  rest=$(our_pids "$dir" | tr '\n' ' ')
  [[ -n ${rest// /} ]] && terminate "$dir" "leftover processes" "$rest"

  if has_netns "$dir"; then
    # Processes still in the namespace were not started by the daemons (a shell from
    # run-in-cluster, say): they are left alone, and the namespace lives on until they exit.
    local ns_ino left="" f skip
    ns_ino=$(stat -L -c %i "$dir/netns" 2>/dev/null || true)
    skip=$(self_and_ancestors)
    for f in /proc/[0-9]*/ns/net; do
      [[ $(stat -L -c %i "$f" 2>/dev/null) == "$ns_ino" ]] || continue
      f=${f#/proc/}
      f=${f%%/*}
      [[ $skip == *" $f "* ]] || ! alive "$f" || left+=" $f"
    done
    [[ -n $left ]] && log "note: still in the cluster's network namespace, left alone: pid$left"
    umount "$dir/netns" || log "warning: could not unmount $dir/netns"
  fi
  [[ -f $dir/netns ]] && ! mountpoint -q "$dir/netns" && rm -f "$dir/netns"
  rm -f "$dir/run/slurmctld.pid" "$dir/run/slurmd.pid" "$dir/munge/munged.pid"
  log "stopped"
}

# ---------------------------------------------------------------------------- status

cmd_status() {
  local dir=${1:-}
  [[ -n $dir ]] || usage
  [[ -f $dir/slurm.conf ]] || die "no cluster in $dir"
  dir=$(abs_dir "$dir")
  has_netns "$dir" || die "the cluster in $dir is not running"
  in_cluster "$dir" sinfo -N -l
  in_cluster "$dir" squeue -l
}

case ${1:-} in
install) cmd_install ;;
start) cmd_start "${2:-}" ;;
stop) cmd_stop "${2:-}" ;;
status) cmd_status "${2:-}" ;;
*) usage ;;
esac
