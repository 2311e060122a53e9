#!/usr/bin/env bash
# The main job: builds the tools, generates the power plant, makes a walk through it, renders
# the walk with the occlusion switch's per-frame algorithm on one GPU (prev) and with frustum
# culling only (vfc, the reference image), computes exact visibility, and compares them.
# Frames and the report land in out/demo (OUT=...). Sizes: TRIANGLES (default 2M), FRAMES
# (default 300), TAU (pixels of error, default 1), SIZE (default 1024x1024).
# (The three-process switch arrives with `osw run`; this runs its algorithm in one process.)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
out="${OUT:-out/demo}"
triangles="${TRIANGLES:-2000000}"
frames="${FRAMES:-300}"
tau="${TAU:-1}"
size="${SIZE:-1024x1024}"
mkdir -p "$out"
cargo build --release --locked --bin osw
osw=target/release/osw
$osw build --gen plant --triangles "$triangles" --seed 1 -o "$out/plant.osw"
$osw path --scene "$out/plant.osw" --kind walk --frames "$frames" --seed 1 -o "$out/walk.csv"
$osw exact --scene "$out/plant.osw" --path "$out/walk.csv" --size "$size" --out "$out/exact"
{
  $osw render --scene "$out/plant.osw" --path "$out/walk.csv" --mode vfc --tau 0 --size "$size" --out "$out/vfc"
  $osw render --scene "$out/plant.osw" --path "$out/walk.csv" --mode prev --tau "$tau" --size "$size" --out "$out/prev"
  $osw compare --a "$out/prev" --b "$out/vfc" --exact "$out/exact" --out "$out/report"
} | tee "$out/report.txt"
echo "demo: frames in $out/prev/frames, statistics in $out/prev/stats.csv, report in $out/report.txt and $out/report/"
