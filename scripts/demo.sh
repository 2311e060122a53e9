#!/usr/bin/env bash
# The main job: builds the tools, generates the power plant, makes a walk through it, runs the
# occlusion switch on this host (node a, node b and the display as three processes on
# loopback, lavapipe when there is no GPU), then measures it against frustum-only rendering at
# the same tau: its speed-up, the image error of its frames, and its culling error against
# exact visibility of the scene as drawn at that tau (so LOD error, which both share, is not
# counted as culling error). It ends with a small `osw report` on the walk's first frames:
# vfc, prev, the switch and ovc (Bartz 1999, also with adaptive culling) at a few taus, each
# run in a line at a glance and the error-against-time plot with its Pareto front.
#
#   scripts/demo.sh [--triangles N] [--frames N] [--tau PX] [--size WxH] [--out DIR]
#
# Frames and the report land in out/demo. --triangles: the plant's size (default 20M: the
# smallest plant of `scripts/scale.sh` where the switch is clearly ahead of vfc, 3.1x at tau
# 1; at 2M it is 1.5x); --frames: the walk's length (default 300); --tau: pixels of error
# (default 1); --size: the image (default 1024x1024). The variables TRIANGLES, FRAMES, TAU,
# SIZE and OUT set the same.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${OUT:-out/demo}"
triangles="${TRIANGLES:-20000000}"
frames="${FRAMES:-300}"
tau="${TAU:-1}"
size="${SIZE:-1024x1024}"
while (($#)); do
  case "$1" in
    --triangles) triangles="$2"; shift 2 ;;
    --frames) frames="$2"; shift 2 ;;
    --tau) tau="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "demo: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
source scripts/tools.sh
mkdir -p "$out"
$osw build --gen plant --triangles "$triangles" --seed 1 -o "$out/plant.osw"
$osw path --scene "$out/plant.osw" --kind walk --frames "$frames" --seed 1 -o "$out/walk.csv"
{
  $osw run --scene "$out/plant.osw" --path "$out/walk.csv" --tau "$tau" --size "$size" --out "$out/switch"
  $osw exact --scene "$out/plant.osw" --path "$out/walk.csv" --size "$size" --tau "$tau" --out "$out/exact"
  $osw render --scene "$out/plant.osw" --path "$out/walk.csv" --mode vfc --tau "$tau" --size "$size" --out "$out/vfc"
  $osw compare --a "$out/switch" --b "$out/vfc" --exact "$out/exact" --out "$out/report"
  head -n $((${SMALL_FRAMES:-20} + 1)) "$out/walk.csv" > "$out/walk-small.csv"
  $osw report --scene "$out/plant.osw" --path "$out/walk-small.csv" --size "$size" --taus "0,$tau" \
    --modes vfc,prev,switch,ovc --adaptive "0,${ADAPTIVE:-1e-6}" --out "$out/small"
} | tee "$out/report.txt"
echo "demo: frames in $out/switch/frames, per-frame statistics in $out/switch/stats.csv, report in $out/report.txt and $out/report/"
echo "demo: error against time in $out/small/error_vs_time.png, tables in $out/small/report.md"
