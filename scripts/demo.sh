#!/usr/bin/env bash
# The main job: builds the tools, generates the plant scene, makes a walk through it, and
# writes the results under out/demo (override with OUT=...). Sizes: TRIANGLES (default 5M),
# FRAMES (default 300).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
out="${OUT:-out/demo}"
triangles="${TRIANGLES:-5000000}"
frames="${FRAMES:-300}"
mkdir -p "$out"
cargo build --release --locked --bin osw
osw=target/release/osw
$osw build --gen plant --triangles "$triangles" --seed 1 -o "$out/plant.osw"
$osw path --scene "$out/plant.osw" --kind walk --frames "$frames" --seed 1 -o "$out/walk.csv"
$osw info --scene "$out/plant.osw" | tee "$out/scene-info.txt"
echo "demo: scene, build report, path and scene info in $out/"
