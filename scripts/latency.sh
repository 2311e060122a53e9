#!/usr/bin/env bash
# Latency of the occlusion switch: one-way latency of each link (RVG → HC camera, HC → RVG and
# HC → OR end of frame) from wall-clock stamps corrected by NTP-style clock offsets, and camera
# sample to displayed frame; median, p95, max and a plot over the frames (osw latency).
#
#   scripts/latency.sh [--scene S --path P] [--tau PX] [--size WxH] [--netns]
#                      [--delays 0.2ms,1ms,5ms] [--tls] [--out DIR]
#
# --tls: on loopback, a second run with every link in mutual TLS (certificates from `osw
# certs` in DIR/certs), tabulated beside the first.
# --netns runs across three network namespaces (scripts/netns-cluster.sh, root) once per link
# delay in --delays, to show how latency grows with it (needs tc netem in the kernel; without
# it the links get the rate alone and the script says so); else once on loopback (osw run).
# Results in DIR (default out/latency): one directory per run, latency.json, latency.md (a
# table over the runs) and latency.png/.svg.
set -euo pipefail
scene="" path="" tau=5 size=1024x1024 netns=0 delays=0.2ms,1ms,5ms tls=0 out=out/latency
while (($#)); do
  case "$1" in
    --scene) scene=$2; shift 2 ;;
    --path) path=$2; shift 2 ;;
    --tau) tau=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --netns) netns=1; shift ;;
    --delays) delays=$2; shift 2 ;;
    --tls) tls=1; shift ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "latency: unknown argument $1" >&2; exit 2 ;;
  esac
done
source "$(dirname "$0")/walk-input.sh"
runs=()
if ((netns)); then
  IFS=, read -ra ds <<<"$delays"
  for d in "${ds[@]}"; do
    scripts/netns-cluster.sh --scene "$scene" --path "$path" --tau "$tau" --size "$size" --no-frames --delay "$d" --out "$out/delay-$d"
    runs+=("$out/delay-$d")
  done
else
  $osw run --scene "$scene" --path "$path" --tau "$tau" --size "$size" --no-frames --out "$out/loopback"
  runs+=("$out/loopback")
  if ((tls)); then
    $osw certs --out "$out/certs" >/dev/null
    $osw run --scene "$scene" --path "$path" --tau "$tau" --size "$size" --no-frames --tls "$out/certs" --out "$out/loopback-tls"
    runs+=("$out/loopback-tls")
  fi
fi
$osw latency --run "${runs[@]}" --out "$out"
cat "$out/latency.md"
