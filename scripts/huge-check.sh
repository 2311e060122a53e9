#!/usr/bin/env bash
# The checks of a huge scene that CI cannot afford (the 1B plant of `scripts/scale.sh --huge`):
# `osw info` (opening time and resident memory), and on a short walk the switch's frames
# against prev's at tau 1 and against vfc's at tau 0 (full detail: vfc is slow there, which is
# why the walk is short). Prints each comparison; exits non-zero when frames differ.
#
#   scripts/huge-check.sh --scene S.osw [--frames 10] [--size WxH] --out DIR
set -euo pipefail
scene="" out="" frames=10 size=1024x1024
while (($#)); do
  case "$1" in
    --scene) scene=$(realpath "$2"); shift 2 ;;
    --out) out=$(realpath -m "$2"); shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "huge-check: unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ -n $scene && -n $out ]] || { echo "huge-check: --scene and --out are required" >&2; exit 2; }
cd "$(dirname "$0")/.."
source scripts/tools.sh
mkdir -p "$out"
$osw info --scene "$scene" | tee "$out/info.txt"
walk="$out/walk-$frames.csv"
[[ -f $walk ]] || $osw path --scene "$scene" --kind walk --frames "$frames" --seed 1 -o "$walk"
fail=0
for tau in 1 0; do
  ref=prev
  [[ $tau == 0 ]] && ref=vfc
  # A first frame at full detail draws everything in the frustum: minutes at 1B on lavapipe.
  $osw run --scene "$scene" --path "$walk" --tau "$tau" --size "$size" --frame-timeout 1800 --out "$out/switch-tau$tau" > "$out/switch-tau$tau.log"
  $osw render --scene "$scene" --path "$walk" --mode "$ref" --tau "$tau" --size "$size" --out "$out/$ref-tau$tau" > "$out/$ref-tau$tau.log"
  $osw compare --a "$out/switch-tau$tau" --b "$out/$ref-tau$tau" --out "$out/compare-tau$tau" > /dev/null
  identical=$(sed -n 's/.*"identical_frames": \([0-9]*\).*/\1/p' "$out/compare-tau$tau/compare.json")
  : "${identical:?$out/compare-tau$tau/compare.json has no identical_frames}"
  echo "huge-check: tau $tau: switch against $ref: $identical of $frames frames identical"
  ((identical == frames)) || fail=1
done
exit $fail
