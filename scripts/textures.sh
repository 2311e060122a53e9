#!/usr/bin/env bash
# What sampling textures costs each mode: on the textured models of ../shared/models/ (forza's
# circuit, OpenArena's ctf_inyard), a walk at tau 1 without frames, vfc, prev and the switch
# with textures sampled and with --no-textures (each texture's mean colour), in alternating
# pairs. Prints per model and mode the median frame time and the speed-up over vfc with
# textures and without, each the median of the pairs' ratios (a pair: vfc and the mode run one
# after the other under the same flag).
#
#   scripts/textures.sh [--frames N] [--size WxH] [--pairs N] [--out DIR]
#
# Defaults: 100 frames, 512x512, 3 pairs, out/textures. Results in DIR/textures.md.
set -euo pipefail
frames=100 size=512x512 pairs=3 out=out/textures
while (($#)); do
  case "$1" in
    --frames) frames=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --pairs) pairs=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "textures: unknown argument $1" >&2; exit 2 ;;
  esac
done
out=$(realpath -m "$out")
cd "$(dirname "$0")/.."
shared=${OSW_MODELS:-../shared/models}
source scripts/tools.sh
mkdir -p "$out"
for name in torcs-forza oa_ctf_inyard; do
  model=$shared/$name.glb dir=$out/$name
  [[ -e $model ]] || { echo "textures: $model not found" >&2; exit 2; }
  mkdir -p "$dir"
  [[ -e $dir/$name.osw ]] || "$osw" build "$model" -o "$dir/$name.osw" >"$dir/build.txt"
  [[ -e $dir/walk.csv ]] || "$osw" path --scene "$dir/$name.osw" --kind walk --frames "$frames" -o "$dir/walk.csv" >/dev/null
  walk=(--scene "$dir/$name.osw" --path "$dir/walk.csv" --size "$size" --tau 1 --no-frames)
  for p in $(seq "$pairs"); do
    for flag in "" --no-textures; do
      tag=${flag:+means}
      tag=${tag:-sampled}
      for mode in vfc prev switch; do
        run=$dir/$mode-$tag-$p
        if [[ $mode == switch ]]; then
          "$osw" run "${walk[@]}" $flag --out "$run" >/dev/null
        else
          "$osw" render "${walk[@]}" --mode $mode $flag --out "$run" >/dev/null
        fi
      done
    done
  done
done
python3 - "$out" "$pairs" >"$out/textures.md" <<'PY'
import json, statistics, sys
out, pairs = sys.argv[1], int(sys.argv[2])
ms = lambda d: json.load(open(f"{d}/summary.json"))["frame_ms_median"]
print("| model | mode | frame ms sampled | frame ms means | speed-up over vfc sampled | speed-up over vfc means | ratio |")
print("| --- | --- | --- | --- | --- | --- | --- |")
for name in ["torcs-forza", "oa_ctf_inyard"]:
    d = f"{out}/{name}"
    for mode in ["vfc", "prev", "switch"]:
        t = {tag: statistics.median(ms(f"{d}/{mode}-{tag}-{p}") for p in range(1, pairs + 1)) for tag in ["sampled", "means"]}
        up = {tag: statistics.median(ms(f"{d}/vfc-{tag}-{p}") / ms(f"{d}/{mode}-{tag}-{p}") for p in range(1, pairs + 1)) for tag in ["sampled", "means"]}
        print(f"| {name} | {mode} | {t['sampled']:.1f} | {t['means']:.1f} | {up['sampled']:.2f}x | {up['means']:.2f}x | {up['sampled'] / up['means']:.3f} |")
PY
cat "$out/textures.md"
