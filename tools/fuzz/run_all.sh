#!/usr/bin/env bash
# Runs the libFuzzer targets of tools/fuzz (docs/reliability.md) over their corpus (the
# regression inputs in tools/fuzz/corpus/<target>/ and the seeds from models/), then on new
# inputs, with a fixed seed and the target's dictionary (<name>.dict), and prints
# "<target>: <N> inputs, <S> s, ok" per target.
#
#   tools/fuzz/run_all.sh [--runs N] [--seed S] [--bin-dir DIR] [--only TARGET]
#
#   --runs N      inputs per target (default 100000); the ctest fuzz tests use 2000
#   --seed S      libFuzzer's random seed (default 1: the same inputs every time)
#   --bin-dir DIR where the targets are (default build-asan/bin, a DDOC_FUZZ=ON clang build)
#   --only T      run one target
#
# New interesting inputs go to a temporary directory, never into the checked-in corpus. A crash,
# sanitizer report, leak, timeout (> 10 s per input) or out-of-memory (> 2 GB) stops the target;
# the input is kept as $TMPDIR/ddoc_fuzz_<target>_crash/* and the script exits 1. Add it to
# tools/fuzz/corpus/<target>/ once fixed.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
runs=100000 seed=1 bin_dir="$root/build-asan/bin" only=""
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --bin-dir) bin_dir=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    *) echo "run_all.sh: unknown argument '$1' (expected --runs, --seed, --bin-dir, --only)" >&2
       exit 2 ;;
  esac
done

# Seeds from models/ per target (beside corpus/<target>/).
seeds_of() {
  case "$1" in
    fuzz_scenario) echo "$root/models/scenarios" "$root/models/scenarios/experiments" ;;
    fuzz_mjcf) echo "$root/models" ;;
    *) ;;
  esac
}

status=0
for target in fuzz_scenario fuzz_mjcf fuzz_flags fuzz_law; do
  [ -n "$only" ] && [ "$only" != "$target" ] && continue
  bin="$bin_dir/$target"
  if [ ! -x "$bin" ]; then
    echo "run_all.sh: $bin not found: build with -DDDOC_FUZZ=ON (CC=clang CXX=clang++)" >&2
    exit 2
  fi
  work=$(mktemp -d "${TMPDIR:-/tmp}/ddoc_fuzz_${target}_XXXXXX")
  # The target's own temporary files (its copy of models/) go here, removed even after a crash.
  scratch=$(mktemp -d "${TMPDIR:-/tmp}/ddoc_fuzz_${target}_tmp_XXXXXX")
  crash="${TMPDIR:-/tmp}/ddoc_fuzz_${target}_crash"
  mkdir -p "$crash"
  corpus=("$work")
  [ -d "$here/corpus/$target" ] && corpus+=("$here/corpus/$target")
  for s in $(seeds_of "$target"); do corpus+=("$s"); done
  dict=()
  [ -f "$here/${target#fuzz_}.dict" ] && dict=(-dict="$here/${target#fuzz_}.dict")
  log="$work.log"
  start=$(date +%s.%N)
  # -close_fd_mask=1: MuJoCo's warnings on stdout would drown the log.
  if TMPDIR="$scratch" "$bin" -runs="$runs" -seed="$seed" -max_len=16384 -timeout=10 -rss_limit_mb=2048 \
       -malloc_limit_mb=2048 -close_fd_mask=1 -print_final_stats=1 \
       -artifact_prefix="$crash/" "${dict[@]}" "${corpus[@]}" >"$log" 2>&1; then
    done_runs=$(grep -o 'Done [0-9]* runs' "$log" | tail -1 | grep -o '[0-9]*' || echo "?")
    secs=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { print b - a }')
    if [ -n "$(ls -A "$scratch")" ]; then
      # A target that ends normally removes what it wrote (fuzz_util.h's ModelsCopy).
      echo "$target: FAILED: left $(ls -A "$scratch" | head -3 | tr '\n' ' ')in its TMPDIR"
      rm -rf "$scratch"
      status=1
      continue
    fi
    printf '%s: %s inputs, %.1f s, ok\n' "$target" "$done_runs" "$secs"
  else
    echo "$target: FAILED (log: $log; input kept in $crash/)"
    grep -E 'ERROR|SUMMARY|runtime error|==[0-9]+==' "$log" | head -20 || true
    rm -rf "$scratch"
    status=1
    continue
  fi
  rm -rf "$work" "$log" "$scratch"
  rmdir "$crash" 2>/dev/null || true
done
exit $status
