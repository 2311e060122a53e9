#!/usr/bin/env bash
# A folder that runs osw on a machine with a GPU and no Rust: the stripped release binaries,
# the Vulkan loader and the C++ runtime for a machine that lacks them, a font for the plots, and
# run.sh. On an x86-64 Linux machine (glibc 2.35 or newer) with a GPU and its Vulkan driver,
# DIR/run.sh runs `osw info`, the 2M and 20M plant sweep of scripts/scale.sh (vfc, chc, prev
# and the switch at tau 1, 100-frame walks at 1024x1024) and a switch walk on the 20M plant,
# and writes its results and the adapter's name into one folder of at most 8 files. It
# refuses a CPU adapter (lavapipe) unless given --allow-cpu.
#
#   scripts/gpu-bundle.sh [--out DIR]                      (default out/gpu-bundle)
#   DIR/run.sh [--quick] [--allow-cpu] [--results DIR] [--work DIR]
#
# The folder holds at most 50 MiB (about 33 here); copy it over and run it. run.sh --quick runs
# a 200K plant with 10-frame walks at 256x256 (CI runs it on lavapipe with --allow-cpu).
# --results: where the files go (default ./osw-results); --work: scratch space for the scenes
# (default a temporary folder, removed; the 20M plant takes about 0.6 GB).
set -euo pipefail
out=out/gpu-bundle
while (($#)); do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "gpu-bundle: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
cd "$(dirname "$0")/.."
# OSW_BIN: a directory of built binaries to use as they are (the tests' smoke runs).
if [[ -z ${OSW_BIN:-} ]]; then
  scripts/setup.sh
  cargo build --release --locked --bins
fi
bin="${OSW_BIN:-target/release}"
rm -rf "$out"
mkdir -p "$out/bin" "$out/lib"
for b in osw osw-node osw-display; do
  strip -o "$out/bin/$b" "$bin/$b"
done
for lib in libvulkan.so.1 libstdc++.so.6; do
  src=$(ldconfig -p | awk -v l="$lib" '!found && $1 == l && /x86-64/ { print $NF; found = 1 }')
  [[ -n $src ]] || { echo "gpu-bundle: $lib not found on this machine (scripts/setup.sh installs it)" >&2; exit 1; }
  cp -L "$src" "$out/lib/$lib"
done
font=""
for f in /usr/share/fonts/truetype/dejavu/DejaVuSans.ttf /usr/share/fonts/dejavu/DejaVuSans.ttf; do
  [[ -f $f ]] && font=$f && break
done
[[ -n $font ]] || { echo "gpu-bundle: DejaVuSans.ttf not found (apt-get install fonts-dejavu-core)" >&2; exit 1; }
cp "$font" "$out/DejaVuSans.ttf"
cat > "$out/run.sh" <<'RUN'
#!/usr/bin/env bash
# osw on this machine's GPU: `osw info`, the 2M and 20M plant sweep (vfc, chc, prev and the
# switch at tau 1, 100-frame walks, 1024x1024) and a switch walk on the 20M plant. Writes
# adapter.txt, scale.json, scale.md, scale.png, switch-summary.json, switch-stats.csv and
# run.log into the results folder.
#
#   run.sh [--quick] [--allow-cpu] [--results DIR] [--work DIR]
#
# --quick: a 200K plant, 10-frame walks at 256x256. --allow-cpu: run on a CPU adapter
# (lavapipe) too. --results: default ./osw-results. --work: scratch space for the scenes
# (default a temporary folder, removed at the end).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
quick=0 allow_cpu=0 results=osw-results work=""
while (($#)); do
  case "$1" in
    --quick) quick=1; shift ;;
    --allow-cpu) allow_cpu=1; shift ;;
    --results) results="$2"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "run: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
if [[ -z $work ]]; then
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$results" "$work"
results=$(cd "$results" && pwd)
# The bundled loader and C++ runtime only where this machine has none.
if ! ldconfig -p 2>/dev/null | grep -q 'libvulkan.so.1 ' || ldd "$here/bin/osw" | grep -q 'not found'; then
  export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
fi
export OSW_FONT="$here/DejaVuSans.ttf" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
osw="$here/bin/osw"
log="$results/run.log"
: > "$log"
"$osw" info > "$results/adapter.txt" 2>> "$log" || { echo "run: no Vulkan adapter (see $log)" >&2; exit 1; }
cat "$results/adapter.txt"
if grep -q '^device_type: Cpu' "$results/adapter.txt" && ((!allow_cpu)); then
  echo "run: the adapter is a CPU, not a GPU (pass --allow-cpu to run on it anyway)" >&2
  exit 3
fi
if ((quick)); then sizes=200K big=200K frames=10 size=256x256; else sizes=2M,20M big=20M frames=100 size=1024x1024; fi
start=$SECONDS
echo "run: plant sweep $sizes, $frames-frame walks at $size (vfc, chc, prev, switch at tau 1)"
"$osw" scale --sizes "$sizes" --taus 1 --modes vfc,chc,prev,switch --frames "$frames" --size "$size" --out "$work/scale" >> "$log" 2>&1 \
  || { echo "run: the sweep failed (see $log)" >&2; exit 1; }
cp "$work/scale/scale.json" "$work/scale/scale.md" "$work/scale/scale.png" "$results/"
echo "run: a switch walk on the $big plant"
"$osw" run --scene "$work/scale/plant-$big.osw" --path "$work/scale/plant-$big-walk-$frames-seed1.csv" --tau 1 --size "$size" \
  --no-frames --out "$work/switch" >> "$log" 2>&1 || { echo "run: the switch walk failed (see $log)" >&2; exit 1; }
cp "$work/switch/summary.json" "$results/switch-summary.json"
cp "$work/switch/stats.csv" "$results/switch-stats.csv"
echo "run: done in $((SECONDS - start)) s; results in $results:"
cat "$results/scale.md"
RUN
chmod +x "$out/run.sh"
bytes=$(du -sb "$out" | cut -f1)
if ((bytes > 50 << 20)); then
  echo "gpu-bundle: $out holds $bytes bytes, over 50 MiB" >&2
  exit 1
fi
echo "gpu-bundle: $out ($((bytes >> 20)) MiB): copy it to a machine with a GPU and run $out/run.sh there"
