#!/usr/bin/env bash
# Runs deploy/slurm/sawyer-batch.sbatch on a real Slurm: a one-node cluster on this machine
# (munged, slurmctld and slurmd on localhost, started by hand from a generated slurm.conf), a job
# array of 4 tasks over a manifest of 4 phantom CT scans and one bad scan, then merges the shard
# registers and checks that every good log is registered exactly once, the bad one is reported
# failed in the batch CSVs, and the array tasks ended as they should (the bad log's task FAILED
# with exit 2, the others COMPLETED with 0). docs/batch.md ("Slurm") shows a run.
#
#   sudo deploy/slurm/test_local_slurm.sh [path/to/sawyer]
#
# Root only (it starts the Slurm and MUNGE daemons). Installs Debian's slurmctld, slurmd,
# slurm-client, munge and sqlite3 with apt-get where they are missing. Everything else it writes
# is under one temporary folder (mktemp -d: keys, sockets, slurm.conf, state, logs, scans,
# outputs), removed at the end unless KEEP=1; the daemons are stopped at the end whatever happens.
# Ports 16817/16818 on localhost (SLURM_TEST_PORT to move them) so a real cluster is not touched.
# Exit code: 0 all checks passed, 1 a check failed, 2 it cannot run here.
set -euo pipefail
me=$(basename "$0")
repo=$(cd "$(dirname "$0")/../.." && pwd)
refuse() { echo "$me: $*" >&2; exit 2; }
# This host cannot run the daemons (a container without what munged or slurmd need): not
# Sawyer's failure, so the test is skipped (exit 2), saying why.
host_refuse() { host_refused=1; echo "$me: cannot run here: $*" >&2; exit 2; }
fail() { echo "$me: FAILED: $*" >&2; exit 1; }
say() { echo "[$(date -u +%H:%M:%S)] $*"; }

[ "$(id -u)" -eq 0 ] || refuse "must run as root (it starts munged, slurmctld and slurmd)"
sawyer=${1:-${SAWYER:-}}
if [ -z "$sawyer" ]; then
  if [ -x "$repo/build/apps/sawyer/sawyer" ]; then sawyer=$repo/build/apps/sawyer/sawyer
  else sawyer=$(command -v sawyer || true); fi
fi
[ -n "$sawyer" ] ||
  refuse "no sawyer binary: give its path (build/apps/sawyer/sawyer is not built, none on PATH)"
{ [ -f "$sawyer" ] && [ -x "$sawyer" ]; } || refuse "$sawyer: not an executable file (the sawyer binary)"
sawyer=$(realpath "$sawyer")

t_start=$(date +%s)
need=()
for c in slurmctld slurmd sbatch squeue scontrol munged sqlite3; do
  command -v "$c" >/dev/null 2>&1 || need+=("$c")
done
if [ ${#need[@]} -gt 0 ]; then
  command -v apt-get >/dev/null 2>&1 ||
    refuse "${need[*]} not installed and no apt-get to install them (Debian: slurmctld slurmd slurm-client munge sqlite3)"
  say "apt-get install slurmctld slurmd slurm-client munge sqlite3 (missing: ${need[*]})"
  export DEBIAN_FRONTEND=noninteractive
  pkgs=(slurmctld slurmd slurm-client munge sqlite3)
  apt-get install -y -qq --no-install-recommends "${pkgs[@]}" >/dev/null 2>&1 ||
    { apt-get update -qq && apt-get install -y -qq --no-install-recommends "${pkgs[@]}" >/dev/null; } ||
    refuse "apt-get could not install ${pkgs[*]}"
fi
t_installed=$(date +%s)
say "$(slurmctld -V), $(munged --version | head -1), sawyer $sawyer"

T=$(mktemp -d /tmp/sawyer_slurm.XXXXXX)
chmod 755 "$T"
pids=()
cleanup() {
  local rc=$?
  # 2 means "cannot run here" (refuse before this trap, host_refuse after it); a command that
  # failed later with status 2 is a failure, not a skip.
  if [ $rc -eq 2 ] && [ "${host_refused:-0}" != 1 ]; then rc=1; fi
  if [ -n "${jobid:-}" ]; then scancel "$jobid" >/dev/null 2>&1 || true; fi
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.2; done
    kill -9 "$p" 2>/dev/null || true
  done
  if [ "${KEEP:-0}" = 1 ]; then echo "$me: kept $T"; else rm -rf "$T"; fi
  exit $rc
}
trap cleanup EXIT
trap 'exit 130' INT TERM HUP

# ---- MUNGE: its own key, socket and files in $T ----------------------------------------------
mkdir -m 700 "$T/munge"
dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$T/munge/munge.key"
munged --foreground --force --key-file="$T/munge/munge.key" --socket="$T/munge/munge.sock" \
  --pid-file="$T/munge/munged.pid" --log-file="$T/munge/munged.log" \
  --seed-file="$T/munge/munge.seed" 2>>"$T/munge/munged.log" &
pids+=($!)
for _ in $(seq 50); do [ -S "$T/munge/munge.sock" ] && break; sleep 0.1; done
[ -S "$T/munge/munge.sock" ] || { cat "$T/munge/munged.log" >&2; host_refuse "munged did not start"; }

# ---- slurm.conf: one node, this machine ------------------------------------------------------
cpus=$(nproc)
mem_mb=$(awk '/^MemTotal:/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
port=${SLURM_TEST_PORT:-16817}
mkdir -p "$T/state" "$T/spool" "$T/log" "$T/node_tmp"
export SLURM_CONF=$T/slurm.conf
cat >"$SLURM_CONF" <<EOF
ClusterName=sawyertest
SlurmctldHost=localhost
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$T/munge/munge.sock
CredType=cred/munge
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/log/slurmctld.log
SlurmdLogFile=$T/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$T/log/jobcomp.txt
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
MpiDefault=none
ReturnToService=2
MinJobAge=3600
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF

slurmctld -D -i -f "$SLURM_CONF" >>"$T/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N localhost -f "$SLURM_CONF" >>"$T/log/slurmd.out" 2>&1 &
pids+=($!)
up=0
for _ in $(seq 100); do
  if sinfo -h -N -o '%t' 2>/dev/null | grep -qx 'idle'; then up=1; break; fi
  sleep 0.3
done
if [ $up = 0 ]; then
  tail -n 20 "$T/log/slurmctld.log" "$T/log/slurmd.log" "$T/log/"*.out >&2 || true
  host_refuse "the one-node cluster did not come up (node state: $(sinfo -h -N -o '%t' 2>&1))"
fi
say "cluster up: $(sinfo -h -N -o '%N %t cpus=%c mem=%mMB')"

# ---- the scans: 4 small phantoms (30 cm of Gran_1, fine enough for the scan QA) and one bad ---
mkdir -p "$T/scans/broken"
for s in 1 2 3 4; do
  "$sawyer" phantom "$repo/sample_logs/gran1_spruce/log.json" -o "$T/scans/log_$s" \
    --from-mm 1000 --to-mm 1300 --size 480 --pixel-mm 0.8 --seed "$s" \
    --threads "$cpus" >"$T/log/phantom_$s.log" 2>&1 ||
    { tail -n 5 "$T/log/phantom_$s.log" >&2; fail "sawyer phantom (seed $s) failed"; }
done
echo "not a DICOM file" >"$T/scans/broken/0001.dcm"
cat >"$T/manifest.csv" <<EOF
ct,id,species
scans/log_1,L1,spruce
scans/log_2,L2,spruce
scans/broken,BAD,pine
scans/log_3,L3,spruce
scans/log_4,L4,spruce
EOF
t_scans=$(date +%s)
say "4 phantom scans and one bad in $((t_scans - t_installed)) s; manifest:"
cat "$T/manifest.csv"

# ---- the job array: the production sbatch file, sized for this node on the command line ------
OUT=$T/out
mkdir -p "$OUT"
jobid=$(cd "$T" && sbatch --parsable --array=0-3 --cpus-per-task=1 --mem=1G --time=00:10:00 \
  --output="$T/log/sawyer-batch_%A_%a.log" \
  --export="ALL,MANIFEST=$T/manifest.csv,OUT=$OUT,SAWYER=$sawyer,JOBS=1,TMPDIR=$T/node_tmp" \
  "$repo/deploy/slurm/sawyer-batch.sbatch")
say "sbatch: job array $jobid (--array=0-3 --cpus-per-task=1 --mem=1G)"
for _ in $(seq 600); do
  [ -z "$(squeue -h -j "$jobid" 2>/dev/null)" ] && break
  sleep 1
done
[ -z "$(squeue -h -j "$jobid" 2>/dev/null)" ] || fail "job $jobid still queued or running after 600 s"
t_job=$(date +%s)
say "job array $jobid done in $((t_job - t_scans)) s"

# ---- check: each task's state and exit code (scontrol; jobcomp/filetxt has the same) ----------
echo "--- scontrol show job $jobid (one line per array task)"
scontrol -o show job "$jobid" | tr ' ' '\n' | grep -E '^(JobId|ArrayTaskId|JobState|ExitCode)=' |
  paste -d' ' - - - - | sort -t= -k3 -n
errors=0
check() { if ! eval "$2"; then echo "CHECK FAILED: $1" >&2; errors=$((errors + 1)); else echo "ok: $1"; fi; }
state_of() {  # task -> "STATE EXITCODE"
  scontrol -o show job "${jobid}_$1" | tr ' ' '\n' |
    awk -F= '$1=="JobState"{s=$2} $1=="ExitCode"{e=$2} END{print s, e}'
}
# Manifest rows 0..4 round-robin over 4 shards: BAD (row 2) is in task 2; L4 (row 4) in task 0.
for i in 0 1 3; do check "task $i COMPLETED with exit 0" "[ \"\$(state_of $i)\" = 'COMPLETED 0:0' ]"; done
check "task 2 (the bad scan's shard) FAILED with exit 2" "[ \"\$(state_of 2)\" = 'FAILED 2:0' ]"
check "jobcomp records 4 array tasks" \
  "[ \$(grep -c \"ArrayJobId=$jobid \" '$T/log/jobcomp.txt') -eq 4 ]"

# ---- check: the batch CSVs ---------------------------------------------------------------------
echo "--- $OUT/batch_*.csv"
for f in "$OUT"/batch_*.csv; do echo "$(basename "$f"):"; sed 's/^/  /' "$f"; done
check "one batch CSV per task" "[ \$(ls '$OUT'/batch_*.csv | wc -l) -eq 4 ]"
for id in L1 L2 L3 L4; do
  check "$id ok in exactly one batch CSV" \
    "[ \$(cat '$OUT'/batch_*.csv | grep -c '^$id,.*,ok,0,') -eq 1 ]"
done
check "BAD reported failed (exit 1, naming the file) in batch_2.csv" \
  "grep -q '^BAD,.*,failed,1,.*broken/0001.dcm' '$OUT/batch_2.csv'"

# ---- check: the merged register ----------------------------------------------------------------
echo "--- sawyer logs --db all.sqlite --merge $OUT/db/shard_*.sqlite"
"$sawyer" logs --db "$T/all.sqlite" --merge "$OUT"/db/shard_*.sqlite
"$sawyer" logs --db "$T/all.sqlite"
check "4 shard registers copied back" "[ \$(ls '$OUT'/db/shard_*.sqlite | wc -l) -eq 4 ]"
registered=$(sqlite3 "$T/all.sqlite" "SELECT log_id || ':' || scans FROM logs ORDER BY log_id" | tr '\n' ' ')
check "merged register holds L1 L2 L3 L4 once each, scanned once, and not BAD" \
  "[ '$registered' = 'L1:1 L2:1 L3:1 L4:1 ' ]"
check "each register row is its own scan folder" \
  "[ \$(sqlite3 '$T/all.sqlite' 'SELECT count(DISTINCT scan_source) FROM logs') -eq 4 ]"
check "each good log has its report" \
  "[ \$(ls '$OUT'/L?/report/report.pdf | wc -l) -eq 4 ]"
check "the bad log left no output folder" "[ ! -e '$OUT/BAD' ]"

echo "--- task 2's Slurm log"
cat "$T/log/sawyer-batch_${jobid}_2.log"
t_end=$(date +%s)
say "times: install $((t_installed - t_start)) s, scans $((t_scans - t_installed)) s, job array $((t_job - t_scans)) s, total $((t_end - t_start)) s"
[ $errors -eq 0 ] || fail "$errors checks failed (KEEP=1 keeps $T)"
say "$me: all checks passed"
