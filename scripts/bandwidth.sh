#!/usr/bin/env bash
# Bandwidth of the occlusion switch: runs the walk twice, sending deltas and then the whole
# visible set every frame (--full), and compares bytes and ids per frame on each link with
# occlusion switch's model 8n + nh/b + 3(72 + h) (osw bandwidth). Plots over the frames as in the
# paper's fig. 3.
#
#   scripts/bandwidth.sh [--scene S --path P] [--tau PX] [--size WxH] [--netns] [--tls] [--out DIR]
#
# --tls: on loopback, the deltas' run again with every link in mutual TLS (certificates from
# `osw certs` in DIR/certs), and the bytes both wrote to their sockets a frame.
# --netns runs across three network namespaces with 100 Mb/s links (scripts/netns-cluster.sh,
# root); else three processes on loopback (osw run). Without --scene, the generated plant
# (TRIANGLES, FRAMES as in scripts/demo.sh). Results in DIR (default out/bandwidth):
# bandwidth.json, bandwidth.csv, bandwidth_ids.png/.svg, bandwidth_bytes.png/.svg, and exact/
# (osw exact of the same walk: the leaves entering and leaving exact visibility, the walk's own
# churn). A scene left in DIR by an earlier run is used again (scripts/walk-input.sh).
set -euo pipefail
scene="" path="" tau=5 size=1024x1024 netns=0 tls=0 out=out/bandwidth
while (($#)); do
  case "$1" in
    --scene) scene=$2; shift 2 ;;
    --path) path=$2; shift 2 ;;
    --tau) tau=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --netns) netns=1; shift ;;
    --tls) tls=1; shift ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "bandwidth: unknown argument $1" >&2; exit 2 ;;
  esac
done
source "$(dirname "$0")/walk-input.sh"
for kind in deltas full; do
  flag=(); [[ $kind == full ]] && flag=(--full)
  if ((netns)); then
    scripts/netns-cluster.sh --scene "$scene" --path "$path" --tau "$tau" --size "$size" --no-frames "${flag[@]}" --out "$out/$kind"
  else
    $osw run --scene "$scene" --path "$path" --tau "$tau" --size "$size" --no-frames "${flag[@]}" --out "$out/$kind"
  fi
done
# Exact visibility of the same walk at the same tau: the saving a tight PVS could reach.
$osw exact --scene "$scene" --path "$path" --tau "$tau" --size "$size" --out "$out/exact"
$osw bandwidth --run "$out/deltas" --full "$out/full" --exact "$out/exact" --out "$out"
if ((tls)) && ((!netns)); then
  $osw certs --out "$out/certs" >/dev/null
  $osw run --scene "$scene" --path "$path" --tau "$tau" --size "$size" --no-frames --tls "$out/certs" --out "$out/deltas-tls"
  wire() { grep -o '"wire_bytes_per_frame_mean": *[0-9.e+]*' "$1/summary.json" | awk '{print $2}'; }
  awk -v p="$(wire "$out/deltas")" -v t="$(wire "$out/deltas-tls")" \
    'BEGIN { printf "bandwidth: %.0f bytes a frame on the sockets, %.0f over TLS (%+.1f%%)\n", p, t, (t / p - 1) * 100 }' |
    tee "$out/tls.txt"
fi
