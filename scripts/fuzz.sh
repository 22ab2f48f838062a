#!/usr/bin/env bash
# Builds the fuzz preset (clang, libFuzzer, ASan + UBSan) and runs every fuzz target of tests/fuzz
# for SECONDS each (default 60), one after another, then prints a table per target.
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET ...]     e.g. scripts/fuzz.sh 20 read_pcd foveate
#   MFPC_FUZZ_TARGETS="read_pcd foveate" scripts/fuzz.sh  the same subset through the environment
#   MFPC_FUZZ_KNOWN=1 scripts/fuzz.sh ...                 do not skip inputs of known open findings
#   MFPC_FUZZ_RUNS=1000000 scripts/fuzz.sh 1800 ...       stop each target after that many executions
#                                                         (or at SECONDS, whichever comes first)
#
# Each target works in build/fuzz/corpus/<target>/, outside the tracked files: seeded there from
# tests/fuzz/corpus/<target>/ and the reproducers of tests/fuzz/regressions/<target>/ (but those its
# open-findings.txt lists, which would stop it at once), it keeps its new corpus entries there from
# one run to the next. Each crash, leak, timeout or out-of-memory input goes to
# build/fuzz/crashes/<target>/. Limits turn blow-ups into findings: 2 GB of RSS, 2 GB in
# one malloc, 10 s per input. Exits 1 when any target crashed, leaked, timed out or ran out of
# memory (its reproducer is then in build/fuzz/crashes/), 2 for a usage error.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds="${1:-60}"
[[ "$seconds" =~ ^[0-9]+$ ]] || { echo "usage: scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET ...]" >&2; exit 2; }
shift || true
wanted=("$@")
if ((${#wanted[@]} == 0)) && [[ -n "${MFPC_FUZZ_TARGETS:-}" ]]; then
  read -r -a wanted <<< "$MFPC_FUZZ_TARGETS"
fi

bash scripts/install-deps.sh
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz

build=build/fuzz
bin_dir="$build/tests/fuzz"
all=()
for bin in "$bin_dir"/fuzz_*; do
  [[ -x "$bin" && -f "$bin" ]] && all+=("$(basename "$bin")")
done
targets=()
if ((${#wanted[@]} == 0)); then
  targets=("${all[@]}")
else
  for name in "${wanted[@]}"; do
    name="fuzz_${name#fuzz_}"
    [[ -x "$bin_dir/$name" ]] || { echo "fuzz.sh: no target $name (have: ${all[*]#fuzz_})" >&2; exit 2; }
    targets+=("$name")
  done
fi

# The dictionary of each target's format, when it is a text format (tests/fuzz/dict/).
dict_of() {
  case "$1" in
    fuzz_read_pcd) echo pcd ;;
    fuzz_read_ply|fuzz_read_mesh_ply) echo ply ;;
    fuzz_read_mesh_obj) echo obj ;;
    fuzz_ground_truth|fuzz_instance_poses) echo ground_truth ;;
    fuzz_foveation_config|fuzz_recognition_params|fuzz_experiment_config|fuzz_dataset|fuzz_batch_output|fuzz_scene_list|fuzz_png)
      echo "${1#fuzz_}" ;;
  esac
}

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
failed=0
rows=()
for target in "${targets[@]}"; do
  corpus="$build/corpus/$target"
  crashes="$build/crashes/$target"
  mkdir -p "$corpus" "$crashes"
  args=(-max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=10
        -print_final_stats=1 -artifact_prefix="$crashes/")
  [[ -n "${MFPC_FUZZ_RUNS:-}" ]] && args+=(-runs="$MFPC_FUZZ_RUNS")
  dict="$(dict_of "$target")"
  [[ -n "$dict" && -f "tests/fuzz/dict/$dict.dict" ]] && args+=(-dict="tests/fuzz/dict/$dict.dict")
  cp -n "tests/fuzz/corpus/$target"/* "$corpus"/ 2>/dev/null || true
  regressions="tests/fuzz/regressions/$target"
  if [[ -d "$regressions" ]]; then
    for file in "$regressions"/*; do
      name="$(basename "$file")"
      [[ "$name" == README.md || "$name" == open-findings.txt ]] && continue
      grep -qE "^$name([[:space:]#]|$)" "$regressions/open-findings.txt" 2>/dev/null && continue
      cp -n "$file" "$corpus/" 2>/dev/null || true
    done
  fi
  log="$build/fuzz-logs/$target.log"
  mkdir -p "$(dirname "$log")"
  before=$(find "$corpus" -type f | wc -l)
  artifacts_before=$(find "$crashes" -type f | wc -l)
  echo "fuzz.sh: $target for ${seconds} s (log: $log)"
  status=0
  "$bin_dir/$target" "${args[@]}" "$corpus" >"$log" 2>&1 || status=$?
  after=$(find "$corpus" -type f | wc -l)
  artifacts=$(( $(find "$crashes" -type f | wc -l) - artifacts_before ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  last=$(grep -E '^#[0-9]+' "$log" | grep -E ' cov: ' | tail -1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<< "$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<< "$last")
  result=ok
  if ((status != 0)); then
    failed=1
    if grep -q 'ERROR: libFuzzer: timeout' "$log"; then result=timeout
    elif grep -qE 'ERROR: libFuzzer: (out-of-memory|malloc)' "$log"; then result=oom
    elif grep -q 'ERROR: LeakSanitizer' "$log"; then result=leak
    else result=crash; fi
    tail -n 60 "$log" | grep -E '^(==|SUMMARY|    #[0-9] |fuzz check failed|.*runtime error)' | head -20 >&2 || true
  fi
  rows+=("$(printf '%-28s %10s %8s %7s %7s %6s %8s  %s' "$target" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" \
            "$((after - before))" "$artifacts" "$result")")
done

echo
printf '%-28s %10s %8s %7s %7s %6s %8s  %s\n' target execs exec/s cov ft new crashes result
for row in "${rows[@]}"; do echo "$row"; done
if ((failed)); then
  echo "fuzz.sh: findings; reproducers in $build/crashes/<target>/ (see README, Fuzzing)" >&2
  exit 1
fi
