# Sourced by the scripts that run osw, from the repository's root: installs what they need
# (scripts/setup.sh), builds the tools and sets $osw. OSW_BIN: a directory of built binaries to
# use as they are (the tests' smoke runs).
scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
[[ -n ${OSW_BIN:-} ]] || cargo build --release --locked --bins
osw="${OSW_BIN:-target/release}/osw"
