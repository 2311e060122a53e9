#!/usr/bin/env bash
# Runs every test of the workspace (release build: one target dir shared with the tools, and
# the scene tests work at real sizes). Exits non-zero when any test fails.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# README's length, and measured figures in docs/measurements/ rather than in code comments.
scripts/check-shape.sh
# No loop of imports between the files of a crate (each loop kept is named in the check).
python3 scripts/check-imports.py
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
# Where ../shared/models is (our machines and CI), every test of real models must run.
[[ -d ../shared/models ]] && export OSW_REQUIRE_MODELS=1
# The switch tests start the node and display binaries: build every binary first.
cargo build --release --workspace --locked --bins
# The criterion benches at least compile (running them is for measurements, not CI).
cargo bench --workspace --locked --no-run
# The wire core builds alone, without a runtime or a command line (tokio, clap and toml come
# with the binaries' features).
cargo check --release --locked -p osw-wire
if cargo tree --locked -p osw-wire -e normal --prefix none | grep -E "^(tokio|clap|toml) "; then
  echo "test: osw-wire's core depends on tokio, clap or toml" >&2
  exit 1
fi
cargo test --release --workspace --locked
