#!/usr/bin/env bash
# Culling inside the visible nodes (issue 16): triangles drawn over triangles exactly visible,
# and frame time, in its two settings. The 2M plant's walk at tau 0 (prev) and the 5M plant's
# walk at tau 5 (vfc, prev and the switch), each compared with exact visibility at full detail
# (and at tau 5, `--exact-lod`, so that LOD error is not read as false culling).
#
#   scripts/clusters.sh [--frames N] [--size WxH] [--out DIR]
#
# Results in DIR (default out/clusters): each run's directory, exact/ references, cmp-*/
# (osw compare: compare.json has drawn_exact_triangles_ratio_mean per run and
# cluster_exact_triangles_ratio_mean, the floor of culling whole clusters), and clusters.md, a
# table of the figures. Scenes, walks and runs already in DIR are used again.
set -euo pipefail
frames=300 size=1024x1024 out=out/clusters
while (($#)); do
  case "$1" in
    --frames) frames=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "clusters: unknown argument $1" >&2; exit 2 ;;
  esac
done
out=$(realpath -m "$out")
cd "$(dirname "$0")/.."
scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
[[ -n ${OSW_BIN:-} ]] || cargo build --release --locked --bins
osw="${OSW_BIN:-target/release}/osw"
mkdir -p "$out"
once() { [[ -e $1 ]] || "${@:2}"; }
for n in 2 5; do
  once "$out/plant${n}m.osw" $osw build --gen plant --triangles "${n}000000" --seed 1 -o "$out/plant${n}m.osw"
  once "$out/walk${n}m.csv" $osw path --scene "$out/plant${n}m.osw" --kind walk --frames "$frames" --seed 1 -o "$out/walk${n}m.csv"
done
walk=(--size "$size" --no-frames)
# 2M, tau 0: prev against exact visibility.
s2=(--scene "$out/plant2m.osw" --path "$out/walk2m.csv")
once "$out/exact2m/exact.csv" $osw exact "${s2[@]}" --size "$size" --frustum-cut --out "$out/exact2m"
once "$out/prev2m/summary.json" $osw render "${s2[@]}" --mode prev --tau 0 "${walk[@]}" --out "$out/prev2m"
$osw compare --a "$out/prev2m" --b "$out/prev2m" --exact "$out/exact2m" --out "$out/cmp-prev2m"
# 5M, tau 5: vfc, prev and the switch.
s5=(--scene "$out/plant5m.osw" --path "$out/walk5m.csv")
once "$out/exact5m/exact.csv" $osw exact "${s5[@]}" --size "$size" --frustum-cut --out "$out/exact5m"
once "$out/exact5m-tau5/exact.csv" $osw exact "${s5[@]}" --size "$size" --frustum-cut --tau 5 --out "$out/exact5m-tau5"
for mode in vfc prev; do
  once "$out/${mode}5m/summary.json" $osw render "${s5[@]}" --mode $mode --tau 5 "${walk[@]}" --out "$out/${mode}5m"
done
once "$out/switch5m/summary.json" $osw run "${s5[@]}" --tau 5 "${walk[@]}" --out "$out/switch5m"
for run in prev5m switch5m; do
  $osw compare --a "$out/$run" --b "$out/vfc5m" --exact "$out/exact5m" --exact-lod "$out/exact5m-tau5" --out "$out/cmp-$run"
done
python3 - "$out" <<'EOF' | tee "$out/clusters.md"
import json, sys
out = sys.argv[1]
def j(p): return json.load(open(f"{out}/{p}"))
print("| setting | run | frame ms | OR ms | HC ms | RVG ms | triangles | drawn/exact | whole clusters, at least | speed-up over vfc |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for setting, run, cmp in [("2M tau 0", "prev2m", "cmp-prev2m"), ("5M tau 5", "prev5m", "cmp-prev5m"), ("5M tau 5", "switch5m", "cmp-switch5m")]:
    s, c = j(f"{run}/summary.json"), j(f"{cmp}/compare.json")
    stage = lambda k: s.get(k) if s.get(k) is not None else float("nan")
    orms = stage("or_ms_median") if "or_ms_median" in s else stage("node_a_or_ms_median")
    speed = f"{c['speedup_a_over_b']:.2f}x" if run != "prev2m" else "-"
    print(f"| {setting} | {run} | {s['frame_ms_median']:.1f} | {orms:.1f} | {stage('hc_ms_median'):.1f} | {stage('rvg_ms_median'):.1f} "
          f"| {s['triangles_drawn_mean']:.0f} | {c['culling_a']['drawn_exact_triangles_ratio_mean']:.1f} "
          f"| {c['cluster_exact_triangles_ratio_mean']:.1f} | {speed} |")
EOF
