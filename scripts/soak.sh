#!/usr/bin/env bash
# Soak with faults: the switch plays a walk whose visible set changes every frame LAPS times
# over (each lap a display run of the whole path, the nodes running on), node a, node b and the
# display as processes of their own behind `osw link` relays (1 ms each way), while a schedule
# of faults runs: node a killed and restarted, node b killed and restarted, the link between
# the nodes cut and restored, the display killed and started again (it plays its path from the
# start), the nodes' link cut and made lossy (1%, 5 ms) for a lap, and the display's link to
# node a cut and restored (node a sends its last frames again). Laps 1 and 2 have no
# fault; from lap 3 on, each lap has the next fault of the schedule.
#
# Each lap is checked against prev's run of the same path: frames lost (cameras of the path
# never displayed), frames whose pixels differ from prev's, frames whose V(i) differs from prev's
# (those marked degraded excepted: made by one node alone, or recovering from a rejoin),
# exactly visible leaves culled (against `osw exact --frustum-cut`, beside prev's on the same
# reference); and reports ids a frame, residency evictions and each process's anonymous
# resident memory at the lap's end (not the mapped scene's pages), with a plot over the laps.
# Exits non-zero when a frame is lost or differs from prev's, when V(i) differs from prev's on
# a frame not marked degraded, when a lap culls an exactly visible leaf prev does not (at tau 0:
# any), or (over 4 laps or more) when a node's memory at a lap's end is more than 5% over its
# value at the end of lap 2.
#
#   scripts/soak.sh [--scene S --path P] [--laps N] [--size WxH] [--tau PX] [--short] [--out DIR]
#
# Defaults: the 20M plant's 1,000-frame walk (TRIANGLES, FRAMES), 20 laps at 512x512, tau 1,
# out/soak. --short: every fault once on a 200K plant's 60-frame walk at 128x128 (8 laps; what
# CI runs). Results in DIR: soak.csv (a line a lap), soak.png/.svg, soak.txt, lap-N/ (each lap's
# run, compare.json against prev), prev/, exact/.
set -euo pipefail
scene="" path="" laps=20 size=512x512 tau=1 out=out/soak short=0
while (($#)); do
  case "$1" in
    --scene) scene=$2; shift 2 ;;
    --path) path=$2; shift 2 ;;
    --laps) laps=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --tau) tau=$2; shift 2 ;;
    --short) short=1; shift ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
    *) echo "soak: unknown argument $1" >&2; exit 2 ;;
  esac
done
if ((short)); then
  laps=8 size=128x128
  export TRIANGLES=${TRIANGLES:-200000} FRAMES=${FRAMES:-60}
else
  export TRIANGLES=${TRIANGLES:-20000000} FRAMES=${FRAMES:-1000}
fi
source "$(dirname "$0")/walk-input.sh"
bin=$(dirname "$osw")
frames=$(($(wc -l <"$path") - 1))
say() { echo "soak: $*" | tee -a "$out/soak.txt"; }
: >"$out/soak.txt"

# The references: prev's frames and visible sets, and exact visibility, of the same path.
[[ -e $out/prev/summary.json ]] ||
  $osw render --scene "$scene" --path "$path" --mode prev --tau "$tau" --size "$size" --out "$out/prev" >/dev/null
[[ -e $out/exact/exact.csv ]] ||
  $osw exact --scene "$scene" --path "$path" --tau "$tau" --size "$size" --frustum-cut --out "$out/exact" >/dev/null
# prev's own culling error on that reference: at tau > 0, OR's occluders are V(i-1)'s LODs,
# picked for the previous camera, and may hide a pixel of a leaf the reference's cut shows.
$osw compare --a "$out/prev" --b "$out/prev" --exact "$out/exact" --out "$out/cmp-prev" >/dev/null

free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
declare -A pid port
for p in a b ab da db; do port[$p]=$(free_port); done
trap 'kill -9 "${pid[@]}" 2>/dev/null || true' EXIT
# Waits until a log's first line says the process listens (a poll with a deadline).
listening() {
  local t=0
  until grep -q "^listening" "$1" 2>/dev/null; do
    sleep 0.05
    t=$((t + 1))
    ((t < 600)) || { echo "soak: $1: not listening after 30 s" >&2; exit 1; }
  done
}
start_node() { # name, port, [peer port]
  local peer=(); [[ -n ${3:-} ]] && peer=(--peer "127.0.0.1:$3")
  "$bin/osw-node" --name "$1" --scene "$scene" --size "$size" --tau "$tau" --listen "127.0.0.1:$2" "${peer[@]}" \
    >"$out/node-$1.out" 2>>"$out/node-$1.log" &
  pid[$1]=$!
  listening "$out/node-$1.out"
}
start_link() { # name, listen port, to port, [delay ms], [loss]
  "$osw" link --listen "127.0.0.1:$2" --to "127.0.0.1:$3" --delay-ms "${4:-1}" --loss "${5:-0}" >"$out/link-$1.out" 2>&1 &
  pid[$1]=$!
  listening "$out/link-$1.out"
}
kill_one() { kill -9 "${pid[$1]}" 2>/dev/null || true; wait "${pid[$1]}" 2>/dev/null || true; }
start_node a "${port[a]}"
start_link ab "${port[ab]}" "${port[a]}"
start_link da "${port[da]}" "${port[a]}"
start_node b "${port[b]}" "${port[ab]}"
start_link db "${port[db]}" "${port[b]}"

# Waits until the display's lap log shows frame $2 (or the display is gone).
at_frame() {
  until grep -q "^frame $2\$" "$1/display.out" 2>/dev/null || ! kill -0 "${pid[display]}" 2>/dev/null; do sleep 0.02; done
}
start_display() { # lap dir, [last lap: the nodes stop after it]
  rm -rf "$1" && mkdir -p "$1"
  local stay=(--leave-running); [[ -n ${2:-} ]] && stay=()
  "$bin/osw-display" --scene "$scene" --path "$path" --nodes "127.0.0.1:${port[da]},127.0.0.1:${port[db]}" \
    --size "$size" --tau "$tau" "${stay[@]}" --out "$1" >"$1/display.out" 2>"$1/display.log" &
  pid[display]=$!
}
faults=("node a killed and restarted" "node b killed and restarted" "the nodes' link cut and restored"
  "the display killed and started again" "the nodes' link lossy for the lap" "the display's link to node a cut and restored")
# Runs fault $2 during the lap in $1, at a third of its frames ($3: the last lap).
fault() {
  local at=$((frames / 3))
  at_frame "$1" "$at"
  case $2 in
    # The display's link and the peer's come back together: either may reach the node first.
    0) kill_one a; kill_one da; sleep 1; start_node a "${port[a]}"; start_link da "${port[da]}" "${port[a]}" ;;
    1) kill_one b; kill_one db; sleep 1; start_node b "${port[b]}" "${port[ab]}"; start_link db "${port[db]}" "${port[b]}" ;;
    2) kill_one ab; sleep 1; start_link ab "${port[ab]}" "${port[a]}" ;;
    3) kill_one display; start_display "$1" "$3" ;;
    4) kill_one ab; start_link ab "${port[ab]}" "${port[a]}" 5 0.01 ;;
    5) kill_one da; sleep 1; start_link da "${port[da]}" "${port[a]}" ;;
  esac
}
anon_kb() { awk '/^RssAnon:/ { print $2 }' "/proc/$1/status" 2>/dev/null || echo 0; }
echo "lap,fault,frames_lost,frames_differing,vi_differing,false_culled_leaves,false_culled_beyond_prev,degraded_frames,ids_mean,evictions,node_a_anon_kb,node_b_anon_kb,display_anon_kb" >"$out/soak.csv"
bad=0
for ((lap = 1; lap <= laps; lap++)); do
  dir="$out/lap-$lap" last=""
  ((lap == laps)) && last=1
  start_display "$dir" "$last"
  f=-1 name="none"
  if ((lap >= 3)); then
    f=$(((lap - 3) % ${#faults[@]})) name=${faults[$f]}
    fault "$dir" "$f" "$last"
  fi
  # The nodes' memory as the display shows the lap's last frame but one (mid-lap in the last
  # lap, after which they stop), the display's as it wrote it for its last frame.
  at_frame "$dir" $((last ? frames / 2 : frames - 2))
  a_kb=$(anon_kb "${pid[a]}") b_kb=$(anon_kb "${pid[b]}")
  wait "${pid[display]}" || { say "lap $lap: the display failed: $(tail -1 "$dir/display.log")"; bad=1; continue; }
  d_kb=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "anon_kb") c = i; next } { v = $c } END { print v + 0 }' "$dir/stats.csv")
  [[ $f == 4 ]] && { kill_one ab; start_link ab "${port[ab]}" "${port[a]}"; }
  $osw compare --a "$dir" --b "$out/prev" --exact "$out/exact" --out "$dir/cmp" >/dev/null
  rm -rf "$dir/frames"
  shown=$(($(wc -l <"$dir/stats.csv") - 1))
  differing=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "differing_fraction") c = i; next } $c > 0' "$dir/cmp/compare.csv" | wc -l)
  # V(i) against prev's, on the frames not marked degraded.
  vi=$(paste -d'|' "$dir/pvs.txt" "$out/prev/pvs.txt" | awk -F'|' -v deg="$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "degraded") c = i; next } { printf "%s ", $c }' "$dir/stats.csv")" \
    'BEGIN { n = split(deg, d, " ") } $1 != $2 && d[NR] != 1' | wc -l)
  json() { grep -o "\"$1\": *[0-9.e+-]*" "$2" | head -1 | awk '{ print $2 }' || true; }
  culled=$(json false_culled_leaves_total "$dir/cmp/compare.json")
  # Frame by frame, the leaves culled beyond prev's.
  col() { awk -F, -v name="$1" 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == name) c = i; next } { print $c + 0 }' "$2"; }
  beyond=$(paste -d, <(col a_false_culled "$dir/cmp/compare.csv") <(col a_false_culled "$out/cmp-prev/compare.csv") |
    awk -F, '$1 > $2 { n += $1 - $2 } END { print n + 0 }')
  degraded=$(json degraded_frames "$dir/summary.json")
  ids=$(json ids_sent_mean "$dir/summary.json")
  evictions=$(json evictions "$dir/summary.json")
  lost=$((frames - shown))
  echo "$lap,$name,$lost,$differing,$vi,$culled,$beyond,$degraded,$ids,$evictions,$a_kb,$b_kb,$d_kb" >>"$out/soak.csv"
  say "lap $lap ($name): $lost frames lost, $differing differing from prev's, V(i) differing on $vi, $culled visible leaves culled ($beyond beyond prev's), $degraded degraded; $ids ids a frame, $evictions evictions; anonymous memory: node a $((a_kb / 1024)) MiB, node b $((b_kb / 1024)) MiB, display $((d_kb / 1024)) MiB"
  ((lost == 0 && differing == 0 && vi == 0 && beyond == 0)) || bad=1
done
$osw plot --csv "$out/soak.csv" --x lap --y node_a_anon_kb,node_b_anon_kb,display_anon_kb \
  --title "Anonymous resident memory at each lap's end" --y-label "KiB" --out "$out/soak" >/dev/null
# Each node's memory against its value at the end of lap 2.
if ((laps >= 4)); then
  grew=$(awk -F, 'NR == 3 { a = $11; b = $12 } NR > 3 && ($11 > a * 1.05 || $12 > b * 1.05) { print "lap " $1 }' "$out/soak.csv")
  [[ -z $grew ]] || { say "node memory more than 5% over lap 2's at: $grew"; bad=1; }
fi
say "$laps laps of $frames frames, $((laps >= 3 ? laps - 2 : 0)) faults → $out/soak.csv, $out/soak.png"
exit $bad
