#!/usr/bin/env bash
# The batch driver against a shell loop of `mfpc recognize`, on synthetic scenes the project makes:
# throughput at 1 and 2 threads, the loop at the same threads, peak memory from 20 to 200 scenes
# (and the first 20 ten times over), and 4 models in one batch against one (scene time, and the
# same instances as separate runs).
#
#   bench/batch_throughput.sh [MFPC] [SCENES=100] [WORK=/tmp/mfpc-batch-bench] [REPEATS=3]
#
# Prints medians of REPEATS runs and the ratios as it goes; writes nothing outside WORK. The four-model
# part runs on the first 20 scenes (its ratio is per scene).
set -euo pipefail
mfpc=$(realpath "${1:-build/release/tools/mfpc}")
count=${2:-100}
work=${3:-/tmp/mfpc-batch-bench}
repeats=${4:-3}
command -v jq >/dev/null || { echo "batch_throughput: needs jq (scripts/install-deps.sh)" >&2; exit 2; }
mkdir -p "$work"
set_dir="$work/set$count"
if [[ ! -f $set_dir/dataset.json ]]; then
  echo "making $count kinect scenes in $set_dir" >&2
  "$mfpc" --threads 2 -q synth-set --presets kinect --scenes "$count" -o "$set_dir" >/dev/null
fi
ls "$set_dir"/kinect_*/scene.pcd > "$work/scenes.txt"
model="$set_dir/models/kinect_carton.mfpcm"

median() { sort -g | awk '{v[NR]=$1} END {print (NR % 2) ? v[(NR+1)/2] : (v[NR/2] + v[NR/2+1]) / 2}'; }
seconds() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1 || true; t1=$(date +%s.%N); awk "BEGIN {print $t1 - $t0}"; }
ratio() { awk "BEGIN {print $1 / $2}"; }
batch() { # threads out [models...]
  local threads=$1 out=$2; shift 2
  rm -f "$out"
  local args=()
  for m in "$@"; do args+=(--model "$m"); done
  "$mfpc" --threads "$threads" -q --json "$out.summary.json" batch "${args[@]}" --scenes "$work/scenes.txt" -o "$out"
}
loop() { # threads
  while read -r scene; do "$mfpc" --threads "$1" -q recognize --model "$model" --scene "$scene"; done < "$work/scenes.txt"
}

declare -A t
printf 'scenes %d, medians of %d runs\n' "$count" "$repeats"
t[batch1]=$(for _ in $(seq "$repeats"); do seconds batch 1 "$work/b.jsonl" "$model"; done | median)
printf 'batch 1 thread     %8.2f s  %6.2f scenes/s\n' "${t[batch1]}" "$(ratio $count ${t[batch1]})"
t[batch2]=$(for _ in $(seq "$repeats"); do seconds batch 2 "$work/b.jsonl" "$model"; done | median)
printf 'batch 2 threads    %8.2f s  %6.2f scenes/s  (%.2fx the 1-thread batch)\n' "${t[batch2]}" \
  "$(ratio $count ${t[batch2]})" "$(ratio ${t[batch1]} ${t[batch2]})"
t[loop2]=$(for _ in $(seq "$repeats"); do seconds loop 2; done | median)
printf 'recognize loop, 2  %8.2f s  %6.2f scenes/s  (batch 2 threads: %.2fx)\n' "${t[loop2]}" \
  "$(ratio $count ${t[loop2]})" "$(ratio ${t[loop2]} ${t[batch2]})"

# Peak memory with 20 and 200 scenes (the set's scenes named again through links for 200).
mkdir -p "$work/links"
for i in $(seq 0 199); do
  src=$(sed -n "$(( i % count + 1 ))p" "$work/scenes.txt")
  ln -f "$src" "$work/links/scene_$(printf %03d "$i").pcd"
done
# The 200 hold scenes the first 20 do not, some larger: the same 20 ten times over (links again)
# tells growth with the batch's length from growth with what its scenes hold.
mkdir -p "$work/again"
for i in $(seq 0 199); do
  ln -f "$work/links/scene_$(printf %03d "$(( i % 20 ))").pcd" "$work/again/scene_$(printf %03d "$i").pcd"
done
ls "$work/again"/*.pcd > "$work/scenes20x10.txt"
for n in 20 200 20x10; do
  [[ $n == 20x10 ]] || ls "$work/links"/*.pcd | head -n "$n" > "$work/scenes$n.txt"
  rm -f "$work/m$n.jsonl"
  "$mfpc" --threads 2 -q --json "$work/m$n.json" batch --model "$model" --scenes "$work/scenes$n.txt" -o "$work/m$n.jsonl"
  printf 'peak memory, %-5s scenes: %6.1f MiB\n' "$n" "$(jq '.peak_memory_bytes / 1048576' "$work/m$n.json")"
done

# Four models in one batch against one model, and against four separate batches, on 20 scenes.
head -n 20 "$work/scenes.txt" > "$work/scenes_four.txt"
cp "$work/scenes.txt" "$work/scenes_all.txt"
cp "$work/scenes_four.txt" "$work/scenes.txt"
t1=$(for _ in $(seq "$repeats"); do seconds batch 2 "$work/one.jsonl" "$model"; done | median)
models=()
for shape in carton bottle box jug; do models+=("$set_dir/models/kinect_$shape.mfpcm"); done
t4=$(for _ in $(seq "$repeats"); do seconds batch 2 "$work/four.jsonl" "${models[@]}"; done | median)
printf '20 scenes, 2 threads: 1 model %.2f s, 4 models %.2f s (%.2fx)\n' "$t1" "$t4" "$(ratio $t4 $t1)"
same=yes
for i in 0 1 2 3; do
  batch 2 "$work/one$i.jsonl" "${models[$i]}"
  if ! diff -q <(jq -c "[.scene, (.models[0].instances | map(.transform))]" "$work/one$i.jsonl") \
               <(jq -c "[.scene, (.models[$i].instances | map(.transform))]" "$work/four.jsonl") >/dev/null; then
    same=no
    echo "model $i: instances differ between the 4-model batch and its own" >&2
  fi
done
echo "4 models: same instances as 4 separate batches: $same"
cp "$work/scenes_all.txt" "$work/scenes.txt"
