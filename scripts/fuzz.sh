#!/usr/bin/env bash
# Long fuzz runs of every decoder with cargo fuzz (libFuzzer): protocol frames, scene file
# header and tables, its texture table, camera path CSV, cluster config, and the glTF (with its meshopt decoders),
# OBJ and PLY readers. The targets are crates/fuzz/src; the seeds crates/fuzz/libfuzzer/seeds;
# each run's corpus grows in out/fuzz/corpus/TARGET.
#
#   scripts/fuzz.sh [--runs N] [TARGET...]     (default: 10000000 runs of each target)
#
# Installs cargo-fuzz from crates.io when missing. cargo fuzz needs nightly rustc flags: on a
# stable toolchain they are enabled with RUSTC_BOOTSTRAP=1. Prints executions, corpus size and
# time per target; a crash stops the script with libFuzzer's report and the input saved in
# crates/fuzz/libfuzzer/artifacts/TARGET.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=10000000 targets=()
while (($#)); do
  case "$1" in
    --runs) runs=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) targets+=("$1"); shift ;;
  esac
done
((${#targets[@]})) || targets=(wire_frame scene_tables texture_table path_csv config gltf_import obj_import ply_import)
command -v cargo-fuzz >/dev/null || cargo install --locked cargo-fuzz@0.13.2
rustc --version | grep -q nightly || export RUSTC_BOOTSTRAP=1
dir=crates/fuzz/libfuzzer
for t in "${targets[@]}"; do
  corpus="out/fuzz/corpus/$t"
  mkdir -p "$corpus"
  start=$(date +%s)
  cargo fuzz run --fuzz-dir "$dir" --release "$t" "$corpus" "$dir/seeds/$t" -- -runs="$runs" -print_final_stats=1 2>"out/fuzz/$t.log" \
    || { tail -n 40 "out/fuzz/$t.log" >&2; echo "fuzz: $t crashed; the input is in $dir/artifacts/$t" >&2; exit 1; }
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "out/fuzz/$t.log" | grep -o '[0-9]*$' || echo "?")
  echo "fuzz: $t: $execs executions, corpus $(ls "$corpus" | wc -l) inputs, $(($(date +%s) - start)) s"
done
