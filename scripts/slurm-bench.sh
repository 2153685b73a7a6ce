#!/usr/bin/env bash
# A sharded pointsight run on a Slurm cluster: `pointsight ARGS --shard K/N` as a job array of
# N tasks, each writing its own folder, then `pointsight merge` in a job that Slurm starts once
# every task has succeeded (--dependency=afterok). See usage() below or run with --help.
#
# Why a dependent job rather than this script waiting: the merge then needs nothing alive on
# the login node (you may log out, and login nodes often kill long processes), and it starts
# the moment the last shard ends. --wait adds the waiting for those who want an answer (CI,
# scripts): it follows both jobs and, when a shard fails, names it and shows its log.
#
# Failures: each task writes its exit status to DIR/slurm/shard-K.status; a shard that exits
# non-zero fails its array task, Slurm then cancels the merge (--kill-on-invalid-dep=yes) and
# `--check DIR` (or --wait) says which shard failed, how, and where its log is. A task killed
# by Slurm (time limit, memory, node failure, scancel) leaves no status file; its Slurm state
# is reported while the controller still remembers the job (MinJobAge, 300 s by default).
set -euo pipefail

usage() {
  cat <<'EOF'
Usage: scripts/slurm-bench.sh [OPTIONS] [-- POINTSIGHT_ARGS...]
       scripts/slurm-bench.sh --check DIR

Submits `pointsight POINTSIGHT_ARGS --shard K/N` as a Slurm job array (tasks K = 1..N), task K
writing DIR/shard-K, and `pointsight merge --out DIR/merged DIR/shard-1 ... DIR/shard-N` as a
job that starts when every task has succeeded (--dependency=afterok). POINTSIGHT_ARGS is
`bench [OPTIONS]` (the default: `bench`) or `run EXPERIMENT [OPTIONS]`; the script adds
--shard and the output folder (--reports for bench, --out for run) itself. The jobs run in
the current directory with the current environment (sbatch --export=ALL), so relative paths
and POINTSIGHT_DATA / POINTSIGHT_METHODS mean what they mean here; every folder must be on a
filesystem the compute nodes share.

Options:
  -n, --shards N       number of shards, the array's tasks (default 8)
  -o, --out DIR        output folder, which must not hold an earlier run (default
                       slurm-reports): DIR/shard-K/ each task's results, DIR/merged/ the
                       merged reports, DIR/slurm/ the job scripts, logs and exit statuses
  -b, --bin PATH       the pointsight binary (default: `pointsight` on PATH, else this
                       clone's target/release/pointsight)
  -p, --partition P    sbatch --partition, for every job
  -t, --time T         sbatch --time, for each shard and for the merge (e.g. 2:00:00)
      --mem M          sbatch --mem, for each shard and for the merge (e.g. 8G)
  -c, --cpus C         sbatch --cpus-per-task for each shard (pointsight uses them all)
      --max-running M  at most M shards at once (--array=1-N%M)
      --sbatch ARG     any other sbatch option for every job; repeatable
                       (e.g. --sbatch=--account=lab --sbatch=--qos=short)
      --wait           wait for the merge, then exit 0 with the merged folder as the last
                       line of stdout, or 1 naming each failed shard and its log
      --check DIR      report on a run submitted earlier into DIR (without waiting)
  -h, --help           this text

Examples:
  scripts/slurm-bench.sh -n 8 -p batch -t 4:00:00 --mem 16G -o /scratch/$USER/ps -- bench
  scripts/slurm-bench.sh -n 3 --wait -- run visibility --quick --datasets sphere-plane-24000
EOF
}

die() {
  echo "slurm-bench: $*" >&2
  exit 2
}

# --- arguments (builtins only up to the sbatch check, so that a missing PATH says so) -------
shards=8
out=slurm-reports
bin=""
partition=""
time_limit=""
mem=""
cpus=""
max_running=""
extra_sbatch=()
wait_merge=0
check_dir=""
ps_args=()

need_value() {
  [ "$2" -ge 2 ] || die "$1 needs a value (see --help)"
}
while [ $# -gt 0 ]; do
  case "$1" in
  -h | --help)
    usage
    exit 0
    ;;
  --) shift; ps_args=("$@"); break ;;
  -n | --shards) need_value "$1" $#; shards=$2; shift 2 ;;
  --shards=*) shards=${1#*=}; shift ;;
  -o | --out) need_value "$1" $#; out=$2; shift 2 ;;
  --out=*) out=${1#*=}; shift ;;
  -b | --bin) need_value "$1" $#; bin=$2; shift 2 ;;
  --bin=*) bin=${1#*=}; shift ;;
  -p | --partition) need_value "$1" $#; partition=$2; shift 2 ;;
  --partition=*) partition=${1#*=}; shift ;;
  -t | --time) need_value "$1" $#; time_limit=$2; shift 2 ;;
  --time=*) time_limit=${1#*=}; shift ;;
  --mem) need_value "$1" $#; mem=$2; shift 2 ;;
  --mem=*) mem=${1#*=}; shift ;;
  -c | --cpus) need_value "$1" $#; cpus=$2; shift 2 ;;
  --cpus=*) cpus=${1#*=}; shift ;;
  --max-running) need_value "$1" $#; max_running=$2; shift 2 ;;
  --max-running=*) max_running=${1#*=}; shift ;;
  --sbatch) need_value "$1" $#; extra_sbatch+=("$2"); shift 2 ;;
  --sbatch=*) extra_sbatch+=("${1#*=}"); shift ;;
  --wait) wait_merge=1; shift ;;
  --check) need_value "$1" $#; check_dir=$2; shift 2 ;;
  --check=*) check_dir=${1#*=}; shift ;;
  *) die "unknown option $1 (pointsight's own arguments go after --; see --help)" ;;
  esac
done

is_count() {
  [[ "$1" =~ ^[1-9][0-9]*$ ]]
}

if [ -z "$check_dir" ]; then
  is_count "$shards" || die "--shards expects a whole number >= 1, got '$shards'"
  [ -z "$max_running" ] || is_count "$max_running" ||
    die "--max-running expects a whole number >= 1, got '$max_running'"
  [ -z "$cpus" ] || is_count "$cpus" || die "--cpus expects a whole number >= 1, got '$cpus'"
  [ -n "$out" ] || die "--out expects a folder"
  [ "${#ps_args[@]}" -gt 0 ] || ps_args=(bench)
  case "${ps_args[0]}" in
  bench) out_flag=--reports ;;
  run)
    [ "${#ps_args[@]}" -ge 2 ] && [[ "${ps_args[1]}" != -* ]] ||
      die "\`run\` needs the experiment's name first (for example: -- run visibility --quick)"
    out_flag=--out
    ;;
  *) die "pointsight's arguments must start with \`bench\` or \`run EXPERIMENT\`, got '${ps_args[0]}'" ;;
  esac
  for a in "${ps_args[@]:1}"; do
    case "$a" in
    --shard | --shard=* | "$out_flag" | "$out_flag"=*)
      die "pointsight's $a is set by this script: give the output folder as --out DIR before --"
      ;;
    esac
  done
fi

for cmd in sbatch squeue scontrol; do
  command -v "$cmd" >/dev/null 2>&1 ||
    die "$cmd not found on PATH: run this on a Slurm login node (on Debian: apt-get install slurm-client; a single-node test cluster: scripts/slurm-local.sh)"
done

# --- reporting -------------------------------------------------------------------------------

# Slurm's state of job $1 ("COMPLETED", "FAILED (NonZeroExitCode)", ...), or why it is unknown.
job_state() {
  local line state reason
  if ! line=$(scontrol show job -o "$1" 2>/dev/null) || [ -z "$line" ]; then
    echo "no longer known to Slurm"
    return
  fi
  state=$(sed -n 's/.*JobState=\([^ ]*\).*/\1/p' <<<"$line")
  reason=$(sed -n 's/.*Reason=\([^ ]*\).*/\1/p' <<<"$line")
  if [ -n "$reason" ] && [ "$reason" != None ]; then
    echo "${state:-unknown} ($reason)"
  else
    echo "${state:-unknown}"
  fi
}

# Reads DIR/slurm/run.env (written at submission) into n, array_id, merge_id.
load_run() {
  local dir=$1
  [ -f "$dir/slurm/run.env" ] ||
    die "$dir/slurm/run.env not found: $dir holds no run submitted by this script"
  n=$(sed -n 's/^shards=//p' "$dir/slurm/run.env")
  array_id=$(sed -n 's/^array=//p' "$dir/slurm/run.env")
  merge_id=$(sed -n 's/^merge=//p' "$dir/slurm/run.env")
  is_count "$n" && [ -n "$array_id" ] && [ -n "$merge_id" ] ||
    die "$dir/slurm/run.env is damaged"
}

# Says how the run in $1 stands; returns 0 when merged, 1 when something failed, 3 when
# jobs are still pending or running.
report() {
  local dir=$1 k rc log state failed=0
  load_run "$dir"
  for k in $(seq 1 "$n"); do
    log=$dir/slurm/shard-$k.log
    if [ -f "$dir/slurm/shard-$k.status" ]; then
      rc=$(cat "$dir/slurm/shard-$k.status")
      [ "$rc" = 0 ] && continue
      echo "slurm-bench: shard $k/$n failed: pointsight exited with status $rc (job ${array_id}_$k); its log: $log" >&2
    else
      state=$(job_state "${array_id}_$k")
      case "$state" in
      PENDING* | RUNNING* | CONFIGURING* | COMPLETING* | SUSPENDED*) continue ;;
      esac
      echo "slurm-bench: shard $k/$n failed: no exit status, so Slurm stopped it (time limit, memory, node failure or scancel): $state (job ${array_id}_$k); its log: $log" >&2
    fi
    failed=$((failed + 1))
    if [ -f "$log" ]; then
      echo "--- last lines of $log:" >&2
      tail -n 12 "$log" | sed 's/^/    /' >&2
    else
      echo "    (no log: the task never started)" >&2
    fi
  done
  if [ "$failed" -gt 0 ]; then
    echo "slurm-bench: $failed of $n shard(s) failed; the merge job $merge_id is $(job_state "$merge_id") and $dir/merged is not written" >&2
    return 1
  fi
  if [ -f "$dir/slurm/merge.status" ]; then
    rc=$(cat "$dir/slurm/merge.status")
    if [ "$rc" = 0 ]; then
      echo "slurm-bench: all $n shards succeeded and were merged into $dir/merged" >&2
      return 0
    fi
    echo "slurm-bench: the merge (job $merge_id) failed: pointsight merge exited with status $rc; its log: $dir/slurm/merge.log" >&2
    tail -n 12 "$dir/slurm/merge.log" 2>/dev/null | sed 's/^/    /' >&2
    return 1
  fi
  case "$(job_state "$merge_id")" in
  PENDING* | RUNNING* | CONFIGURING* | COMPLETING*)
    echo "slurm-bench: still running: $(squeue -h -j "$array_id,$merge_id" -o '%i %T' 2>/dev/null | tr '\n' ',' | sed 's/,$//')" >&2
    return 3
    ;;
  esac
  echo "slurm-bench: the merge (job $merge_id) left no exit status: $(job_state "$merge_id"); its log: $dir/slurm/merge.log" >&2
  return 1
}

if [ -n "$check_dir" ]; then
  check_dir=$(cd "$check_dir" 2>/dev/null && pwd) || die "--check: no folder $check_dir"
  rc=0
  report "$check_dir" || rc=$?
  [ "$rc" -ne 0 ] || echo "$check_dir/merged"
  exit "$rc"
fi

# --- submission ------------------------------------------------------------------------------

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [ -z "$bin" ]; then
  bin=$(command -v pointsight 2>/dev/null || true)
  [ -n "$bin" ] || bin=$here/../target/release/pointsight
  [ -x "$bin" ] ||
    die "no pointsight binary: give --bin PATH, or build one (cargo build --release -p harness)"
fi
[ -f "$bin" ] && [ -x "$bin" ] || die "--bin $bin is not an executable file"
bin=$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")

mkdir -p "$out"
out=$(cd "$out" && pwd)
if [ -n "$(ls -A "$out")" ]; then
  die "$out is not empty (an earlier run?): give another --out, or remove it first"
fi
mkdir -p "$out/slurm"

# pointsight merge reads the same data, methods and manifest as the shards.
merge_opts=()
for ((i = 0; i < ${#ps_args[@]}; i++)); do
  case "${ps_args[i]}" in
  --data-dir | --methods-dir | --manifest)
    [ $((i + 1)) -lt ${#ps_args[@]} ] && merge_opts+=("${ps_args[i]}" "${ps_args[i + 1]}")
    ;;
  --data-dir=* | --methods-dir=* | --manifest=*) merge_opts+=("${ps_args[i]}") ;;
  esac
done

# Shell-quoted words, space-separated, for the job scripts.
q() {
  local s
  s=$(printf '%q ' "$@")
  printf '%s' "${s% }"
}

cat >"$out/slurm/shard.sh" <<EOF
#!/usr/bin/env bash
# Written by scripts/slurm-bench.sh: one shard of \`pointsight $(q "${ps_args[@]}")\`.
set -uo pipefail
k=\${SLURM_ARRAY_TASK_ID:?this script runs as a task of a Slurm job array}
echo "slurm-bench: shard \$k/$shards, array task \${SLURM_ARRAY_JOB_ID:-?}_\$k on \$(hostname) at \$(date -Is)"
$(q "$bin" "${ps_args[@]}") --shard "\$k/$shards" $out_flag $(q "$out")/shard-"\$k"
rc=\$?
echo "\$rc" >$(q "$out")/slurm/shard-"\$k".status
echo "slurm-bench: shard \$k/$shards exited with status \$rc at \$(date -Is)"
exit "\$rc"
EOF
shard_dirs=()
for k in $(seq 1 "$shards"); do shard_dirs+=("$out/shard-$k"); done
cat >"$out/slurm/merge.sh" <<EOF
#!/usr/bin/env bash
# Written by scripts/slurm-bench.sh: merges the $shards shards once all have succeeded.
set -uo pipefail
echo "slurm-bench: merging $shards shards on \$(hostname) at \$(date -Is)"
$(q "$bin" merge "${merge_opts[@]}" --out "$out/merged" "${shard_dirs[@]}")
rc=\$?
echo "\$rc" >$(q "$out")/slurm/merge.status
echo "slurm-bench: merge exited with status \$rc at \$(date -Is)"
exit "\$rc"
EOF
chmod +x "$out/slurm/shard.sh" "$out/slurm/merge.sh"

common=(--parsable --export=ALL "--chdir=$PWD")
[ -z "$partition" ] || common+=("--partition=$partition")
[ -z "$time_limit" ] || common+=("--time=$time_limit")
[ -z "$mem" ] || common+=("--mem=$mem")
common+=("${extra_sbatch[@]}")
array_opts=(--job-name=pointsight-shards "--array=1-$shards${max_running:+%$max_running}"
  "--output=$out/slurm/shard-%a.log")
[ -z "$cpus" ] || array_opts+=("--cpus-per-task=$cpus")

if ! array_id=$(sbatch "${common[@]}" "${array_opts[@]}" "$out/slurm/shard.sh" 2>&1); then
  die "sbatch refused the shards' array: $array_id"
fi
array_id=${array_id%%;*}
if ! merge_id=$(sbatch "${common[@]}" --job-name=pointsight-merge \
  "--dependency=afterok:$array_id" --kill-on-invalid-dep=yes \
  "--output=$out/slurm/merge.log" "$out/slurm/merge.sh" 2>&1); then
  scancel "$array_id" 2>/dev/null || true
  die "sbatch refused the merge job: $merge_id (the shards' array $array_id is cancelled)"
fi
merge_id=${merge_id%%;*}
printf 'shards=%s\narray=%s\nmerge=%s\n' "$shards" "$array_id" "$merge_id" >"$out/slurm/run.env"
echo "slurm-bench: submitted $shards shards as array $array_id and the merge as job $merge_id (after all succeed); logs in $out/slurm/" >&2

if [ "$wait_merge" -eq 0 ]; then
  echo "slurm-bench: follow with \`squeue -j $array_id,$merge_id\`; then \`$0 --check $out\` says how it went; the merged reports go to $out/merged" >&2
  echo "$out/merged"
  exit 0
fi

trap 'echo; echo "slurm-bench: stopped waiting; the jobs go on: \`$0 --check $out\`, or \`scancel $array_id $merge_id\`" >&2; exit 130' INT TERM
poll=${SLURM_BENCH_POLL:-2}
errors=0
while :; do
  if listed=$(squeue -h -j "$array_id,$merge_id" -o %i 2>&1); then
    errors=0
    [ -n "$listed" ] || break
  elif grep -q "Invalid job id" <<<"$listed"; then
    break # both already purged from the controller's memory
  else
    errors=$((errors + 1))
    [ "$errors" -lt 30 ] || die "squeue keeps failing: $listed"
  fi
  sleep "$poll"
done
trap - INT TERM
rc=0
report "$out" || rc=$?
[ "$rc" -ne 0 ] || echo "$out/merged"
exit "$rc"
