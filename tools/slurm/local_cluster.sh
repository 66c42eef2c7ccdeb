#!/usr/bin/env bash
# A one-machine Slurm cluster for tests and trials, without systemd: munged, slurmctld and N slurmd
# (fake nodes n1..nN on this host) started by hand, everything in one folder.
#
#   tools/slurm/local_cluster.sh start DIR [NODES [CPUS]]   # 2 nodes of 1 CPU by default; prints
#                                                            # the line to eval: export SLURM_CONF=...
#   tools/slurm/local_cluster.sh stop DIR            # stops every daemon it started, by PID
#
# DIR must be an empty folder of its own (mktemp -d). Needs root (slurmd starts jobs as their
# user) and Debian 12's slurmctld, slurmd, slurm-client and munge packages (tools/deps.sh). The
# daemons listen on free ports of 127.0.0.1 and talk through their own munge socket, so several
# such clusters, and a real one, can run side by side. Exit status 3 (with the reason on stderr)
# when Slurm cannot run here: not installed, not root, or the daemons do not come up.
#
# The settings are those that work in a sandbox without systemd or cgroups (docs/farm.md):
# proctrack/linuxproc, task/none, no accounting; kill_invalid_depend (a failed dependency cancels
# its dependants instead of leaving them pending), no scheduling delays (batch_sched_delay=0,
# sched_min_interval=0: each dependency step costs about a second instead of three), and
# MinJobAge=600 so that `scontrol show job` still knows finished jobs (there is no sacct without
# accounting).
set -euo pipefail

usage() {
    echo "usage: $0 start DIR [NODES [CPUS]] | stop DIR" >&2
    exit 2
}

unavailable() {
    echo "local_cluster: Slurm cannot run here: $*" >&2
    exit 3
}

[ $# -ge 2 ] || usage
cmd=$1
dir=$2

stop_pid() { # name pidfile
    local pid
    [ -f "$2" ] || return 0
    pid=$(cat "$2")
    if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
        kill "$pid" 2>/dev/null || true
        for _ in $(seq 50); do
            kill -0 "$pid" 2>/dev/null || break
            sleep 0.1
        done
        if kill -0 "$pid" 2>/dev/null; then
            echo "local_cluster: $1 (pid $pid) did not stop in 5 s: killing it" >&2
            kill -9 "$pid" 2>/dev/null || true
        fi
    fi
    rm -f "$2"
}

stop_cluster() {
    [ -d "$dir/run" ] || return 0
    if [ -f "$dir/etc/slurm.conf" ] && [ -f "$dir/run/slurmctld.pid" ] && command -v scancel >/dev/null; then
        SLURM_CONF="$dir/etc/slurm.conf" scancel --user="$(id -un)" 2>/dev/null || true
    fi
    for f in "$dir"/run/slurmd-*.pid; do
        [ -e "$f" ] && stop_pid "slurmd $(basename "$f" .pid)" "$f"
    done
    stop_pid slurmctld "$dir/run/slurmctld.pid"
    stop_pid munged "$dir/run/munged.pid"
}

if [ "$cmd" = stop ]; then
    stop_cluster
    exit 0
fi
[ "$cmd" = start ] || usage
nodes=${3:-2}
cpus=${4:-1}
[[ "$nodes" =~ ^[1-9][0-9]?$ ]] && [[ "$cpus" =~ ^[1-9][0-9]?$ ]] || usage

for p in munged slurmctld slurmd sbatch squeue scontrol sinfo scancel python3; do
    command -v "$p" >/dev/null || unavailable "'$p' is not installed (apt-get install slurmctld slurmd slurm-client munge)"
done
[ "$(id -u)" -eq 0 ] || unavailable "slurmd needs root to start jobs"
[ -d "$dir" ] && [ -z "$(ls -A "$dir")" ] || { echo "local_cluster: '$dir' must be an empty folder" >&2; exit 2; }
dir=$(cd "$dir" && pwd)
# munged serves its socket to every user: each folder above it must be open to all (o+x)
d=$dir
while [ "$d" != / ]; do
    d=$(dirname "$d")
    [ "$(( 0$(stat -c %a "$d") & 1 ))" -eq 1 ] ||
        { echo "local_cluster: '$d' is closed to other users (chmod o+x it, or put DIR elsewhere): munged needs its socket reachable" >&2; exit 2; }
done
trap 'stop_cluster' ERR

chmod 755 "$dir"
mkdir -p "$dir/etc" "$dir/state" "$dir/log" "$dir/run" "$dir/munge"
mkdir -m 755 "$dir/socket"
chmod 700 "$dir/munge"
for i in $(seq "$nodes"); do mkdir -p "$dir/spool/n$i"; done

# munge: its own key and socket (munged wants the socket's folder open to all, the key private)
dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$dir/munge/munge.key"
socket="$dir/socket/munge.socket"
munged --foreground --socket="$socket" --key-file="$dir/munge/munge.key" \
    --pid-file="$dir/munge/munged.pid" --log-file="$dir/log/munged.log" --seed-file="$dir/munge/munged.seed" \
    > "$dir/log/munged.out" 2>&1 &
echo $! > "$dir/run/munged.pid"

# free ports for slurmctld and each slurmd
read -r -a ports < <(python3 - "$((nodes + 1))" <<'EOF'
import socket, sys
socks = []
for _ in range(int(sys.argv[1])):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    socks.append(s)
print(" ".join(str(s.getsockname()[1]) for s in socks))
EOF
)

host=$(hostname -s)
conf="$dir/etc/slurm.conf"
{
    echo "ClusterName=vbnllocal"
    echo "SlurmctldHost=$host(127.0.0.1)"
    echo "SlurmctldPort=${ports[0]}"
    echo "SlurmUser=root"
    echo "SlurmdUser=root"
    echo "AuthType=auth/munge"
    echo "AuthInfo=socket=$socket"
    echo "CredType=cred/munge"
    echo "StateSaveLocation=$dir/state"
    echo "SlurmdSpoolDir=$dir/spool/%n"
    echo "SlurmctldPidFile=$dir/state/slurmctld.pid"
    echo "SlurmdPidFile=$dir/state/slurmd-%n.pid"
    echo "SlurmctldLogFile=$dir/log/slurmctld.log"
    echo "SlurmdLogFile=$dir/log/slurmd-%n.log"
    echo "ProctrackType=proctrack/linuxproc"
    echo "TaskPlugin=task/none"
    echo "JobAcctGatherType=jobacct_gather/none"
    echo "AccountingStorageType=accounting_storage/none"
    echo "JobCompType=jobcomp/none"
    echo "MpiDefault=none"
    echo "SwitchType=switch/none"
    echo "SelectType=select/cons_tres"
    echo "SelectTypeParameters=CR_CPU"
    echo "SchedulerType=sched/builtin"
    echo "SchedulerParameters=kill_invalid_depend,batch_sched_delay=0,sched_min_interval=0"
    echo "ReturnToService=2"
    echo "MinJobAge=600"
    for i in $(seq "$nodes"); do
        echo "NodeName=n$i NodeHostname=localhost NodeAddr=127.0.0.1 Port=${ports[$i]} CPUs=$cpus State=UNKNOWN"
    done
    echo "PartitionName=local Nodes=ALL Default=YES MaxTime=INFINITE State=UP"
} > "$conf"

for _ in $(seq 50); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || { stop_cluster; unavailable "munged did not start ($(tail -2 "$dir/log/munged.out" 2>/dev/null | tr '\n' ' '))"; }

slurmctld -D -f "$conf" > "$dir/log/slurmctld.out" 2>&1 &
echo $! > "$dir/run/slurmctld.pid"
for i in $(seq "$nodes"); do
    slurmd -D -f "$conf" -N "n$i" > "$dir/log/slurmd-n$i.out" 2>&1 &
    echo $! > "$dir/run/slurmd-n$i.pid"
done

export SLURM_CONF="$conf"
idle=0
for _ in $(seq 150); do
    idle=$(sinfo -h -N -o '%t' 2>/dev/null | grep -c '^idle' || true)
    [ "$idle" -eq "$nodes" ] && break
    sleep 0.1
done
if [ "$idle" -ne "$nodes" ]; then
    why=$(tail -3 "$dir/log/slurmctld.log" "$dir"/log/slurmd-n1.log 2>/dev/null | tr '\n' ' ')
    stop_cluster
    unavailable "$idle of $nodes nodes came up in 15 s: $why"
fi
echo "export SLURM_CONF=$conf"
