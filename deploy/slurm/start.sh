#!/usr/bin/env bash
# A one-node Slurm cluster on loopback, for pflow's `slurm` tests and for trying --placement slurm on one machine
# (docs/cluster.md). Debian's slurm-wlm and munge; everything (keys, state, logs, sockets) under one directory.
#
#   deploy/slurm/start.sh DIR [--cpus N] [--gpus G] [--port-base P]   # prints `export SLURM_CONF=DIR/slurm.conf`
#   deploy/slurm/stop.sh DIR
#
# The node ("pflow-node1", address 127.0.0.1) declares N CPU slots (default 4) whatever the machine has
# (SlurmdParameters=config_overrides), in one partition "pflow"; --gpus G declares G GPUs as GRES (gpu:G on stand-in
# device files such as /dev/null: a machine without GPUs rehearses GPU placement). Daemons run as the calling user.
# Finished jobs stay visible to scontrol for an hour (MinJobAge): no accounting database is set up here.
set -euo pipefail
dir=${1:?usage: start.sh DIR [--cpus N] [--gpus G] [--port-base P]}
shift
cpus=4
gpus=0
port_base=$(( 17000 + RANDOM % 2000 ))
while [[ $# -gt 0 ]]; do
  case "$1" in
    --cpus) cpus=$2; shift 2 ;;
    --gpus) gpus=$2; shift 2 ;;
    --port-base) port_base=$2; shift 2 ;;
    *) echo "start.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
for tool in slurmctld slurmd munged sbatch; do
  command -v "$tool" >/dev/null || { echo "start.sh: $tool not found (apt-get install slurm-wlm munge)" >&2; exit 3; }
done
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
mkdir -p "$dir"/{munge,state,spool/pflow-node1,log}
chmod 700 "$dir/munge"
user=$(id -un)

# munge: a key of our own and a socket in DIR (the system's munged, if any, is left alone).
if [[ ! -f "$dir/munge/munge.key" ]]; then
  dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$dir/munge/munge.key"
fi
munged --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket" \
       --pid-file="$dir/munge/munged.pid" --log-file="$dir/log/munged.log" --seed-file="$dir/munge/munge.seed" \
       --force

cat > "$dir/slurm.conf" <<CONF
ClusterName=pflow
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$port_base
SlurmdPort=$((port_base + 1))
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool/%n
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd-%n.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd-%n.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SlurmdParameters=config_overrides
ReturnToService=2
SchedulerType=sched/backfill
SchedulerParameters=sched_interval=1
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MinJobAge=3600
KillWait=5
InactiveLimit=0
SlurmctldTimeout=30
SlurmdTimeout=60
$( ((gpus > 0)) && echo "GresTypes=gpu" )
NodeName=pflow-node1 NodeAddr=127.0.0.1 NodeHostname=localhost CPUs=$cpus RealMemory=4096 $( ((gpus > 0)) && echo "Gres=gpu:$gpus" ) State=UNKNOWN
PartitionName=pflow Nodes=pflow-node1 Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
CONF
if ((gpus > 0)); then
  # Slurm 22.05 drops GPUs without device files: each fake GPU is one of the always-present character devices.
  fakes=(/dev/null /dev/zero /dev/full /dev/random /dev/urandom)
  ((gpus <= ${#fakes[@]})) || { echo "start.sh: at most ${#fakes[@]} fake GPUs" >&2; exit 2; }
  : > "$dir/gres.conf"
  for ((i = 0; i < gpus; i++)); do echo "NodeName=pflow-node1 Name=gpu File=${fakes[$i]}" >> "$dir/gres.conf"; done
else
  rm -f "$dir/gres.conf"
fi

export SLURM_CONF="$dir/slurm.conf"
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF" -N pflow-node1

# Ready when the node is idle: at most PFLOW_SLURM_START_WAIT seconds (default 90: a loaded CI machine can take a
# while to bring slurmctld up and have slurmd register). A daemon that died, or a wait that ran out, prints the tails
# of the logs, so that the reason is in the caller's output and not only in DIR/log.
wait_s=${PFLOW_SLURM_START_WAIT:-90}
alive() { [[ -f "$1" ]] && kill -0 "$(cat "$1")" 2>/dev/null; }
state=
for _ in $(seq 1 $((wait_s * 2))); do
  state=$(sinfo -h -N -n pflow-node1 -o '%t' 2>/dev/null || true)
  if [[ "$state" == idle* ]]; then
    echo "export SLURM_CONF=$SLURM_CONF"
    exit 0
  fi
  sleep 0.5
  # slurmctld writes its pid file once it runs; give it a few seconds before calling it dead.
  if [[ -f "$dir/slurmctld.pid" ]] && ! alive "$dir/slurmctld.pid"; then state="slurmctld exited"; break; fi
done
{
  echo "start.sh: the node did not become idle within ${wait_s} s (state '${state:-?}', ports $port_base/$((port_base + 1))); logs in $dir/log"
  for f in "$dir"/log/slurmctld.log "$dir"/log/slurmd-*.log "$dir"/log/munged.log; do
    [[ -f "$f" ]] || continue
    echo "--- last lines of $f"
    tail -n 15 "$f"
  done
} >&2
exit 4
