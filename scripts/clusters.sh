#!/usr/bin/env bash
# Culling inside the visible nodes: triangles drawn over triangles exactly visible,
# and frame time, in its two settings. The small plant's walk at tau 0 (prev) and the large
# plant's walk at tau 5 (vfc, prev and the switch), each compared with exact visibility at full
# detail (and at tau 5, `--exact-lod`, so that LOD error is not read as false culling).
#
#   scripts/clusters.sh [--triangles SMALL,LARGE] [--frames N] [--size WxH] [--out DIR]
#
# The plants default to 2M and 5M triangles. Results in DIR (default out/clusters): each run's
# directory, exact-*/ references, cmp-*/ (osw compare: compare.json has
# drawn_exact_triangles_ratio_mean per run and cluster_exact_triangles_ratio_mean, the floor of
# culling whole clusters, and visible_draw_ms_median, RVG's floor: the ms that drawing only the
# exactly visible triangles takes, and visible_cluster_draw_ms_median, only their clusters), and clusters.md, a table of the figures. Each run's cpu.json holds
# the CPU and wall seconds of the whole run, its processes' together: on one host the switch's
# three processes share the cores, so its frame is at least its CPU a frame over the cores, and
# the table ends with the speed-up over vfc that allows. Scenes, walks and runs already in DIR
# are used again.
set -euo pipefail
triangles=2000000,5000000 frames=300 size=1024x1024 out=out/clusters
while (($#)); do
  case "$1" in
    --triangles) triangles=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "clusters: unknown argument $1" >&2; exit 2 ;;
  esac
done
IFS=, read -r small large <<<"$triangles"
[[ $small =~ ^[0-9]+$ && $large =~ ^[0-9]+$ ]] || { echo "clusters: --triangles $triangles: expected two counts, SMALL,LARGE" >&2; exit 2; }
out=$(realpath -m "$out")
cd "$(dirname "$0")/.."
source scripts/tools.sh
mkdir -p "$out"
once() { [[ -e $1 ]] || "${@:2}"; }
# timed DIR COMMAND...: runs COMMAND and writes DIR/cpu.json (CPU of it and every process it
# waited for, and wall seconds).
timed() {
  python3 - "$@" <<'PY'
import json, resource, subprocess, sys, time
out, cmd = sys.argv[1], sys.argv[2:]
start = time.monotonic()
if (code := subprocess.run(cmd).returncode) != 0:
    sys.exit(code)
r = resource.getrusage(resource.RUSAGE_CHILDREN)
json.dump({"cpu_s": r.ru_utime + r.ru_stime, "wall_s": time.monotonic() - start}, open(f"{out}/cpu.json", "w"))
PY
}
for plant in "small $small" "large $large"; do
  read -r name n <<<"$plant"
  once "$out/plant-$name.osw" $osw build --gen plant --triangles "$n" --seed 1 -o "$out/plant-$name.osw"
  once "$out/walk-$name.csv" $osw path --scene "$out/plant-$name.osw" --kind walk --frames "$frames" --seed 1 -o "$out/walk-$name.csv"
done
walk=(--size "$size" --no-frames)
# The small plant at tau 0: prev against exact visibility.
small_walk=(--scene "$out/plant-small.osw" --path "$out/walk-small.csv")
once "$out/exact-small/exact.csv" $osw exact "${small_walk[@]}" --size "$size" --frustum-cut --out "$out/exact-small"
once "$out/prev-small/summary.json" timed "$out/prev-small" $osw render "${small_walk[@]}" --mode prev --tau 0 "${walk[@]}" --out "$out/prev-small"
$osw compare --a "$out/prev-small" --b "$out/prev-small" --exact "$out/exact-small" --out "$out/cmp-prev-small"
# The large plant at tau 5: vfc, prev and the switch.
large_walk=(--scene "$out/plant-large.osw" --path "$out/walk-large.csv")
once "$out/exact-large/exact.csv" $osw exact "${large_walk[@]}" --size "$size" --frustum-cut --out "$out/exact-large"
once "$out/exact-large-tau5/exact.csv" $osw exact "${large_walk[@]}" --size "$size" --frustum-cut --tau 5 --out "$out/exact-large-tau5"
for mode in vfc prev; do
  once "$out/$mode-large/summary.json" timed "$out/$mode-large" $osw render "${large_walk[@]}" --mode $mode --tau 5 "${walk[@]}" --out "$out/$mode-large"
done
once "$out/switch-large/summary.json" timed "$out/switch-large" $osw run "${large_walk[@]}" --tau 5 "${walk[@]}" --out "$out/switch-large"
for run in vfc-large prev-large switch-large; do
  $osw compare --a "$out/$run" --b "$out/vfc-large" --exact "$out/exact-large" --exact-lod "$out/exact-large-tau5" --out "$out/cmp-$run"
done
python3 - "$out" "$small" "$large" <<'PY' | tee "$out/clusters.md"
import json, os, sys
out, small, large = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
def j(p): return json.load(open(f"{out}/{p}"))
print("| plant, tau | run | frame ms | OR ms | HC ms | RVG ms | RVG floor ms: visible, their clusters | triangles | drawn/exact | whole clusters, at least | speed-up over vfc | CPU ms a frame | cores busy |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
rows = [(f"{small:,}, 0", "prev-small")] + [(f"{large:,}, 5", f"{m}-large") for m in ("vfc", "prev", "switch")]
for setting, run in rows:
    s, c, t = j(f"{run}/summary.json"), j(f"cmp-{run}/compare.json"), j(f"{run}/cpu.json")
    # The switch's OR is its nodes' (node a's shown); vfc has none.
    orms = None if run.startswith("vfc") else s.get("or_ms_median", s.get("node_a_or_ms_median"))
    stage = lambda v: "-" if v is None else f"{v:.1f}"
    speed = "-" if run == "prev-small" else f"{c['speedup_a_over_b']:.2f}x"
    print(f"| {setting} | {run} | {s['frame_ms_median']:.1f} | {stage(orms)} | {stage(s.get('hc_ms_median'))} | {stage(s.get('rvg_ms_median'))} "
          f"| {stage(c.get('visible_draw_ms_median'))}, {stage(c.get('visible_cluster_draw_ms_median'))} "
          f"| {s['triangles_drawn_mean']:.0f} | {c['culling_a']['drawn_exact_triangles_ratio_mean']:.1f} "
          f"| {c['cluster_exact_triangles_ratio_mean']:.1f} | {speed} | {t['cpu_s'] * 1e3 / s['frames']:.1f} | {t['cpu_s'] / t['wall_s']:.2f} |")
# The switch's three processes share this host's cores: a frame takes at least its CPU a frame
# over them (start-up included, so a little more than the frames' own).
cores = os.cpu_count()
vfc, switch = j("vfc-large/summary.json"), j("switch-large/summary.json")
per_frame = j("switch-large/cpu.json")["cpu_s"] * 1e3 / switch["frames"]
print(f"\nOn {cores} cores the switch's {per_frame:.1f} ms of CPU a frame allows it at most "
      f"{vfc['frame_ms_median'] / (per_frame / cores):.2f}x vfc's frame ({vfc['frame_ms_median']:.1f} ms).")
print("The switch's RVG ms is the display's gather and submit: its draw goes on while it gathers the next frame.")
print("RVG floor: drawing only the triangles exact visibility finds visible at the run's tau, or their clusters, submit to done (osw exact).")
PY
