#!/usr/bin/env bash
# Checks that two builds of mfpc behave the same: runs recognize, foveate, experiment, demo and evaluate with
# each binary on the shared scenes and the built-in synthetic scene, and compares every JSON output with the
# timings, thread count and peak memory removed (they differ from run to run), and every written cloud byte for
# byte. Used to show that a refactoring changed no result.
#
#   scripts/compare-outputs.sh BEFORE_MFPC AFTER_MFPC [DATA_DIR]
#
# DATA_DIR defaults to $MFPC_DATA_DIR, else ../shared/data beside the repository. Exit 0 when every output
# matches, 1 with a diff of the first outputs that differ, 2 for a usage error.
set -euo pipefail

if (($# < 2 || $# > 3)); then
  sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
repo=$(cd "$(dirname "$0")/.." && pwd)
before=$(realpath "$1")
after=$(realpath "$2")
data=$(realpath "${3:-${MFPC_DATA_DIR:-$repo/../shared/data}}")
for tool in "$before" "$after"; do
  [[ -x $tool ]] || { echo "compare-outputs: $tool: not an executable" >&2; exit 2; }
done
[[ -f $data/milk_pair.pcd ]] || { echo "compare-outputs: $data: no milk_pair.pcd (the shared data)" >&2; exit 2; }
command -v jq >/dev/null || { echo "compare-outputs: jq not found (scripts/install-deps.sh installs it)" >&2; exit 2; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# One case per line: name, then the mfpc arguments; @OUT@ is the case's output folder, @DATA@ the data folder,
# @REPO@ the repository. Every case writes its JSON to @OUT@/result.json.
cases=(
  "recognize_pair|recognize --model @DATA@/milk.pcd --scene @DATA@/milk_pair.pcd --ground-truth @DATA@/milk_pair.gt.json"
  "recognize_pair_fovea|recognize --model @DATA@/milk.pcd --scene @DATA@/milk_pair.pcd --ground-truth @DATA@/milk_pair.gt.json --fovea @REPO@/examples/configs/milk_pair_two.json"
  "recognize_near_far|recognize --model @DATA@/milk.pcd --scene @DATA@/milk_near_far.pcd --ground-truth @DATA@/milk_near_far.gt.json"
  "recognize_tutorial|recognize --model @DATA@/milk.pcd --scene @DATA@/milk_pair.pcd --params @REPO@/examples/params/pcl_tutorial.json"
  "foveate_mfpc|foveate @DATA@/milk_pair.pcd -c @REPO@/examples/configs/milk_pair_two.json -o @OUT@/foveated.pcd --regions-dir @OUT@/regions"
  "foveate_raw|foveate @DATA@/milk_pair.pcd -c @REPO@/examples/configs/milk_pair_two.json -m raw -d uniform -o @OUT@/foveated.ply"
  "foveate_procedural|foveate --procedural --procedural-objects 3 -o @OUT@/foveated.pcd"
  "experiment|experiment --config @REPO@/examples/experiments/milk_pair.json -o @OUT@/report --runs 2 --no-charts"
  "demo|demo -o @OUT@/demo"
  "evaluate|evaluate --dataset @REPO@/examples/datasets/shared.json --data-dir @DATA@ --csv @OUT@/rows.csv"
)

# Keys whose values are measurements of this run rather than results; then the parameters that
# issue 28 moved from constants in verification.cpp into VerifyParams (echoed with the parameters
# after it, absent before; their defaults are the old constants).
strip='walk(if type == "object" then with_entries(select(.key | test("(^|_)ms(_per_run)?$|_percent$|_bytes$|^(timings_ms|time_ms|threads|peak_memory_reset|model_timings_ms)$") | not)) else . end)'
strip+=' | walk(if type == "object" and has("max_continuation") then del(.min_facing_cos, .prefilter_coverage, .flat_side, .rim_distance, .min_rim_probes, .settled_fitness) else . end)'

run_case() { # tool label name args
  local tool=$1 label=$2 name=$3 args=$4 out="$work/$2/$3"
  mkdir -p "$out"
  args=${args//@OUT@/$out}
  args=${args//@DATA@/$data}
  args=${args//@REPO@/$repo}
  # shellcheck disable=SC2086  # the case's arguments are split on purpose
  if ! (cd "$repo/examples/datasets" && "$tool" --threads 2 -q --json "$out/result.json" $args) \
      >"$out/stdout" 2>"$out/stderr"; then
    echo "compare-outputs: $label: $name failed:" >&2
    cat "$out/stderr" >&2
    return 1
  fi
}

status=0
for entry in "${cases[@]}"; do
  name=${entry%%|*}
  args=${entry#*|}
  before_status=$status
  run_case "$before" before "$name" "$args" || { status=1; continue; }
  run_case "$after" after "$name" "$args" || { status=1; continue; }
  # Paths differ between the two runs only by the label of their folder.
  while IFS= read -r -d '' file; do
    rel=${file#"$work/before/$name/"}
    other="$work/after/$name/$rel"
    case $rel in
      stdout | stderr | *.png | *.md | *.csv) continue ;;  # tables, pictures and reports carry timings
    esac
    if [[ ! -f $other ]]; then
      echo "compare-outputs: $name: $rel written before, not after" >&2
      status=1
    elif [[ $rel == *.json ]]; then
      if ! diff -u <(sed "s#$work/before#OUT#g" "$file" | jq -S "$strip") \
                  <(sed "s#$work/after#OUT#g" "$other" | jq -S "$strip") >"$work/diff"; then
        echo "compare-outputs: $name: $rel differs:" >&2
        head -40 "$work/diff" >&2
        status=1
      fi
    elif ! cmp -s "$file" "$other"; then
      echo "compare-outputs: $name: $rel differs (bytes)" >&2
      status=1
    fi
  done < <(find "$work/before/$name" -type f -print0 | sort -z)
  # Also every file written after must have been written before.
  while IFS= read -r -d '' file; do
    rel=${file#"$work/after/$name/"}
    [[ -f "$work/before/$name/$rel" ]] || { echo "compare-outputs: $name: $rel written after, not before" >&2; status=1; }
  done < <(find "$work/after/$name" -type f -print0)
  if ((status == before_status)); then echo "compare-outputs: $name: same"; fi
done
exit $status
