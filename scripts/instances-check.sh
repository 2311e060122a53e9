#!/usr/bin/env bash
# Equal frames on the instanced plants of a scale sweep (scripts/scale.sh --instanced --sizes
# ...,1B,10B --out DIR): on the first 10 frames of each walk, at 1024x1024 with frames written,
# the switch's frames against prev's at tau 1 on the 10B plant, and prev's and the switch's
# against vfc's at tau 0 on the 1B plant. Prints identical frames of 10 for each; exits 1 if a
# pair differs.
#
#   scripts/instances-check.sh DIR
set -euo pipefail
[[ $# -eq 1 && -d $1 ]] || { sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 2; }
dir=$(realpath "$1")
cd "$(dirname "$0")/.."
O=$PWD/target/release/osw
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cd "$dir"
rm -rf eq && mkdir eq
head -11 plant-instanced-10B-walk-100-seed1.csv > eq/10B.csv
head -11 plant-instanced-1B-walk-100-seed1.csv > eq/1B.csv
walk() { echo --scene "plant-instanced-$1.osw" --path "eq/$1.csv" --size 1024x1024 --tau "$2" --always-cull --out "eq/$1-$3"; }
"$O" render --mode prev $(walk 10B 1 prev) > eq/log 2>&1
"$O" run $(walk 10B 1 switch) >> eq/log 2>&1
for m in vfc prev; do "$O" render --mode $m $(walk 1B 0 $m) >> eq/log 2>&1; done
"$O" run $(walk 1B 0 switch) >> eq/log 2>&1
status=0
for pair in "10B-switch 10B-prev" "1B-prev 1B-vfc" "1B-switch 1B-vfc"; do
  set -- $pair
  "$O" compare --a "eq/$1" --b "eq/$2" --out "eq/cmp-$1" >> eq/log 2>&1
  same=$(python3 -c "import json; print(json.load(open('eq/cmp-$1/compare.json'))['identical_frames'])")
  echo "$1 against $2: $same of 10 frames identical"
  [[ $same == 10 ]] || status=1
done
exit $status
