#!/usr/bin/env bash
# A frame's cost against the model's size (osw scale): builds the generated plant at each size
# (seed 1), WALKS 100-frame walks through each (seeds 1..WALKS), runs every mode at every tau
# on every walk at 1024x1024 without frames, and writes DIR/scale.json, DIR/scale.md and
# DIR/scale.png/.svg (frame time and HC tests against scene triangles, log-log, one curve per
# mode; each figure per walk, its median over the walks and the worst walk's). Scenes and runs
# already in DIR are used again: an interrupted sweep resumes. Every mode culls every frame, as
# CHC's paper runs it; --cost-adaptive lets prev and the switch frustum cull only where culling
# did not pay.
#
#   scripts/scale.sh [--sizes 2M,20M,100M] [--huge] [--instanced] [--taus 1,5] [--walks N]
#                    [--modes vfc,chc,hzb,prev,switch] [--frames N] [--size WxH] [--cost-adaptive] --out DIR
#
# --huge adds the billion-triangle plant: 27.5 GB of disk (13 GB more while it builds, 3 GB of
# memory, about 9 minutes here); keep DIR under out/ (ignored by git). --instanced sweeps the
# plant of catalogue parts instead (each part's mesh stored once; sizes as drawn, up to 20B).
set -euo pipefail
args=() out=""
while (($#)); do
  case "$1" in
    --huge|--cost-adaptive|--instanced) args+=("$1"); shift ;;
    --sizes|--taus|--modes|--frames|--size|--walks) args+=("$1" "$2"); shift 2 ;;
    --out) out=$(realpath -m "$2"); shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "scale: unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ -n $out ]] || { echo "scale: --out DIR is required" >&2; exit 2; }
cd "$(dirname "$0")/.."
scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
# OSW_BIN: a directory of built binaries to use as they are (the tests' smoke runs).
[[ -n ${OSW_BIN:-} ]] || cargo build --release --locked --bins
"${OSW_BIN:-target/release}/osw" scale "${args[@]}" --out "$out"
