#!/usr/bin/env bash
# Yoon 2003's cluster hierarchy (`osw build --lod clusters`) against the static chains, one
# scene built both ways: per tau, the triangles vfc draws, PSNR against the same scene at tau 0
# (the original everywhere), popping (`osw compare --popping`) and each mode's median frame;
# the hierarchy's triangles and popping at the chains' PSNR (free of what tau means to each);
# then paper 004's table 2 for the hierarchy: frustum culling alone (vfc) against occlusion
# culling (prev, and the switch when asked for).
#
#   scripts/cluster-lod.sh [--gen KIND] [--triangles N] [--kind walk|orbit] [--frames N]
#                          [--size WxH] [--taus LIST] [--modes LIST] [--out DIR]
#
# Defaults: the 20M plant's walk, 100 frames at 1024x1024, tau 0.5,1,2,4, modes vfc,prev
# (`switch` adds `osw run`). Results in DIR (default out/cluster-lod/KIND-N): chains.osw and
# clusters.osw with their build reports, the path (made on the chains' scene, used for both),
# LOD-MODE-tauT/ runs, cmp-*/ and cluster-lod.md, the tables. What is in DIR is used again.
set -euo pipefail
gen=plant triangles=20000000 kind=walk frames=100 size=1024x1024 taus=0.5,1,2,4 modes=vfc,prev out=
while (($#)); do
  case "$1" in
    --gen) gen=$2; shift 2 ;;
    --triangles) triangles=$2; shift 2 ;;
    --kind) kind=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --taus) taus=$2; shift 2 ;;
    --modes) modes=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "cluster-lod: unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ $modes == *vfc* ]] || { echo "cluster-lod: --modes $modes: vfc is the reference, it must be one" >&2; exit 2; }
out=$(realpath -m "${out:-out/cluster-lod/$gen-$triangles}")
cd "$(dirname "$0")/.."
source scripts/tools.sh
mkdir -p "$out"
once() { [[ -e $1 ]] || "${@:2}"; }
for lod in chains clusters; do
  once "$out/$lod.osw" $osw build --gen "$gen" --triangles "$triangles" --seed 1 --lod "$lod" -o "$out/$lod.osw"
done
once "$out/path.csv" $osw path --scene "$out/chains.osw" --kind "$kind" --frames "$frames" --seed 1 -o "$out/path.csv"
IFS=, read -ra tau_list <<<"$taus"
IFS=, read -ra mode_list <<<"$modes"
for lod in chains clusters; do
  walk=(--scene "$out/$lod.osw" --path "$out/path.csv" --size "$size")
  for tau in 0 "${tau_list[@]}"; do
    for mode in "${mode_list[@]}"; do
      [[ $tau == 0 && $mode != vfc ]] && continue
      run="$out/$lod-$mode-tau$tau"
      if [[ $mode == switch ]]; then
        once "$run/summary.json" $osw run "${walk[@]}" --tau "$tau" --always-cull --out "$run"
      else
        once "$run/summary.json" $osw render "${walk[@]}" --mode "$mode" --tau "$tau" --always-cull --out "$run"
      fi
    done
    [[ $tau == 0 ]] && continue
    once "$out/cmp-$lod-tau$tau/compare.json" $osw compare --a "$out/$lod-vfc-tau$tau" --b "$out/$lod-vfc-tau0" --popping --out "$out/cmp-$lod-tau$tau"
  done
done
python3 - "$out" "$taus" "$modes" <<'PY'
import json, sys
out, taus, modes = sys.argv[1], sys.argv[2].split(","), sys.argv[3].split(",")
load = lambda p: json.load(open(f"{out}/{p}"))
rows = ["| lod | tau | vfc triangles | PSNR median (dB) | popping px mean % | " + " | ".join(f"{m} ms" for m in modes) + " |",
        "| --- " * (5 + len(modes)) + "|"]
# vfc's (PSNR against tau 0, triangles drawn, popping) of one representation at one tau.
def point(lod, tau):
    c, v = load(f"cmp-{lod}-tau{tau}/compare.json"), load(f"{lod}-vfc-tau{tau}/summary.json")
    return c["psnr_db_median"] or float("inf"), v["triangles_drawn_mean"], c["popping_a"]["fraction_mean"]
for lod in ("chains", "clusters"):
    for tau in taus:
        db, tris, pop = point(lod, tau)
        ms = " | ".join(f"{load(f'{lod}-{m}-tau{tau}/summary.json')['frame_ms_median']:.1f}" for m in modes)
        rows.append(f"| {lod} | {tau} | {tris:,.0f} | {db:.1f} | {100 * pop:.4f} | {ms} |")
# The same comparison free of what tau means to each representation (their errors are bounds of
# different tightness): at each of the chains' PSNRs, the hierarchy's triangles and popping
# interpolated along its own points (linear in dB; "-" outside the taus measured).
curve = sorted(point("clusters", t) for t in taus)
equal = ["| chains' tau | PSNR (dB) | chains' triangles | hierarchy's triangles | ratio | chains' popping % | hierarchy's popping % | ratio |", "| --- " * 8 + "|"]
for tau in taus:
    db, tris, pop = point("chains", tau)
    at = next(((a, b) for a, b in zip(curve, curve[1:]) if a[0] <= db <= b[0]), None)
    if at is None:
        equal.append(f"| {tau} | {db:.1f} | {tris:,.0f} | - | - | {100 * pop:.4f} | - | - |")
        continue
    (d0, t0, p0), (d1, t1, p1) = at
    f = (db - d0) / (d1 - d0) if d1 > d0 else 0.0
    t, q = t0 + f * (t1 - t0), p0 + f * (p1 - p0)
    equal.append(f"| {tau} | {db:.1f} | {tris:,.0f} | {t:,.0f} | {t / tris:.2f}x | {100 * pop:.4f} | {100 * q:.4f} | {q / pop if pop else float('inf'):.2f}x |")
rows += [""] + equal
build = ["| lod | build s | input triangles / s | stored triangles | file MB | peak memory GB |", "| --- " * 6 + "|"]
for lod in ("chains", "clusters"):
    b = load(f"{lod}.build.json")
    build.append(f"| {lod} | {b['seconds']:.1f} | {b['input_triangles_per_second'] / 1e6:.2f}M | {b['stored_triangles']:,} | {b['output_bytes'] / 1e6:.1f} | {b['peak_rss_kb'] / 1e6 * 1.024:.2f} |")
# Paper 004's table 2, for the hierarchy: frustum culling alone against occlusion culling.
table2 = ["| tau | mode | frames / s | PVS nodes | cut clusters drawn | frustum-culled clusters | HC tests | OR + HC ms | RVG ms | speed-up over vfc |",
          "| --- " * 10 + "|"]
for tau in taus:
    vfc = load(f"clusters-vfc-tau{tau}/summary.json")
    for m in modes:
        s = load(f"clusters-{m}-tau{tau}/summary.json")
        cull = (s.get("hc_ms_median") or 0) + (s.get("or_ms_median") or 0)
        render = s.get("rvg_ms_median") or s["frame_ms_median"]
        table2.append(f"| {tau} | {m} | {1000 / s['frame_ms_median']:.1f} | {s['pvs_nodes_mean']:.0f} | {s.get('clusters_mean', 0):,.0f} | "
                      f"{100 * s.get('clusters_frustum_culled_fraction', 0):.1f}% | {s.get('tests_mean', 0):.0f} | {cull:.1f} | {render:.1f} | {vfc['frame_ms_median'] / s['frame_ms_median']:.2f}x |")
open(f"{out}/cluster-lod.md", "w").write("\n".join(build + [""] + rows + [""] + table2) + "\n")
print("\n".join(build + [""] + rows + [""] + table2))
PY
echo "cluster-lod: $out/cluster-lod.md"
