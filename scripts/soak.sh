#!/usr/bin/env bash
# Soak: a long walk (FRAMES, default 10000) of the switch on a small generated scene, three
# processes on loopback; prints each process's resident memory early (frame 100) and at the
# end, from the rss_kb columns the display (stats.csv) and the nodes (node-a.csv, node-b.csv)
# write. Flat memory means nothing grows per frame.
#
#   scripts/soak.sh [--out DIR]    (default out/soak)
set -euo pipefail
out=out/soak
while (($#)); do
  case "$1" in
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "soak: unknown argument $1" >&2; exit 2 ;;
  esac
done
out=$(realpath -m "$out")
cd "$(dirname "$0")/.."
source scripts/tools.sh
frames="${FRAMES:-10000}"
mkdir -p "$out"
$osw build --gen city --triangles 50000 --seed 1 -o "$out/city.osw" >/dev/null
$osw path --scene "$out/city.osw" --kind orbit --frames "$frames" -o "$out/orbit.csv" >/dev/null
start=$(date +%s)
$osw run --scene "$out/city.osw" --path "$out/orbit.csv" --size 128x128 --tau 1 --no-frames --out "$out/run"
# rss_kb at frame 100 and at the last frame of a CSV (its columns frame and rss_kb, by name).
rss() { awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) { if ($i == "rss_kb") c = i; if ($i == "frame") f = i }
                           if (!c || !f) { print FILENAME ": no frame or rss_kb column" > "/dev/stderr"; exit 1 }; next }
                 $f == 100 { early = $c } { last = $c } END { printf "%.1f MiB at frame 100, %.1f MiB at the end", early / 1024, last / 1024 }' "$1"; }
{
  echo "soak: $frames frames in $(($(date +%s) - start)) s"
  echo "display: $(rss "$out/run/stats.csv")"
  echo "node a: $(rss "$out/run/node-a.csv")"
  echo "node b: $(rss "$out/run/node-b.csv")"
} | tee "$out/soak.txt"
