#!/usr/bin/env bash
# The occlusion switch on three "machines" on this host: three network namespaces (node a,
# node b, the display) joined pairwise by veth links, each link shaped with tc (the paper's
# 100 Mb/s Ethernet by default), running the three-machine configuration
# (configs/three-hosts.toml: the nodes listen on all interfaces and are reached by host name,
# which each namespace resolves to the address on its own link).
#
#   scripts/netns-cluster.sh --scene S --path P --out DIR [--tau PX] [--size WxH] [--no-frames]
#       [--full] [--rate 100mbit] [--delay 0.2ms] [--loss 0] [--bin target/release]
#
# Writes DIR/ as `osw run` does (frames/, stats.csv, pvs.txt, summary.json, node-a.csv,
# node-b.csv, logs) plus DIR/links.txt (addresses and shaping of each link). Removes every
# namespace, link and file it made when it ends, also on failure or Ctrl-C. Needs root.
#
# Shaping: rate, delay and loss with tc netem; a kernel without netem (sch_netem) gets the
# rate from tbf and the delay from `osw link` relays, one per connection in the namespace that
# dials it (the loss is then left out), and says so (in links.txt too).
set -euo pipefail

scene="" path="" out="" tau=1 size=1024x1024 rate=100mbit delay=0.2ms loss=0 extra_display=() extra_node=()
bin="$(cd "$(dirname "$0")/.." && pwd)/target/release"
config="$(cd "$(dirname "$0")/.." && pwd)/configs/three-hosts.toml"
usage() { sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit "${1:-2}"; }
while (($#)); do
  case "$1" in
    --scene) scene=$2; shift 2 ;;
    --path) path=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --tau) tau=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --rate) rate=$2; shift 2 ;;
    --delay) delay=$2; shift 2 ;;
    --loss) loss=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    --no-frames) extra_display+=(--no-frames); shift ;;
    --full) extra_node+=(--full); shift ;;
    -h|--help) usage 0 ;;
    *) echo "netns-cluster: unknown argument $1" >&2; usage ;;
  esac
done
[[ -n $scene && -n $path && -n $out ]] || { echo "netns-cluster: --scene, --path and --out are required" >&2; usage; }
for f in "$scene" "$path" "$bin/osw-node" "$bin/osw-display"; do
  [[ -e $f ]] || { echo "netns-cluster: $f not found (build with: cargo build --release)" >&2; exit 1; }
done
if [[ $(id -u) -ne 0 ]]; then
  echo "netns-cluster: needs root to make network namespaces (ip netns); run it with sudo" >&2
  exit 77
fi
command -v ip >/dev/null && command -v tc >/dev/null || { echo "netns-cluster: needs ip and tc (apt-get install iproute2)" >&2; exit 1; }

scene=$(realpath "$scene") path=$(realpath "$path")
mkdir -p "$out"; out=$(realpath "$out")
id="osw$$"
ns=("$id-a" "$id-b" "$id-d")
pids=() relay_pids=()
cleanup() {
  local rc=$?
  for p in "${pids[@]}" "${relay_pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  for n in "${ns[@]}"; do ip netns del "$n" 2>/dev/null || true; rm -rf "/etc/netns/$n"; done
  # Links made here but not yet moved into a namespace (deleting a namespace took the rest).
  for l in "${id}p" "${id}x1" "${id}x2" "${id}x3"; do ip link del "$l" 2>/dev/null || true; done
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

for n in "${ns[@]}"; do
  ip netns add "$n"
  ip -n "$n" link set lo up
done

# Shaping: netem when the kernel has it, else tbf for the rate alone.
probe="${id}p"
ip link add "$probe" type veth peer name "${probe}q"
if tc qdisc add dev "$probe" root netem delay 1ms 2>/dev/null; then shaper=netem; else shaper=tbf; fi
ip link del "$probe"
# The delay in milliseconds (netem's units: us, ms, s).
delay_ms=$(awk -v d="$delay" 'BEGIN { v = d + 0; if (d ~ /us$/) v /= 1000; else if (d !~ /ms$/ && d ~ /s$/) v *= 1000; print v }')
relays=0
if [[ $shaper == tbf ]]; then
  awk -v d="$delay_ms" 'BEGIN { exit !(d > 0) }' && relays=1
  echo "netns-cluster: this kernel has no tc netem (sch_netem): links get --rate $rate with tbf$( ((relays)) && echo " and --delay $delay through osw link relays"), no --loss" >&2
fi
shape() { # namespace device
  if [[ $shaper == netem ]]; then
    ip netns exec "$1" tc qdisc add dev "$2" root netem rate "$rate" delay "$delay" loss "$loss%"
  else
    ip netns exec "$1" tc qdisc add dev "$2" root tbf rate "$rate" burst 32kbit latency 50ms
  fi
}

# Links: a-b 198.18.1.0/24, a-d 198.18.2.0/24, b-d 198.18.3.0/24 (RFC 2544 benchmark range,
# only inside these namespaces).
: >"$out/links.txt"
link() { # k nsX nsY
  local k=$1 x=$2 y=$3 dx="${id}x$1" dy="${id}y$1"
  ip link add "$dx" type veth peer name "$dy"
  ip link set "$dx" netns "$x"
  ip link set "$dy" netns "$y"
  ip -n "$x" addr add "198.18.$k.1/24" dev "$dx"
  ip -n "$y" addr add "198.18.$k.2/24" dev "$dy"
  ip -n "$x" link set "$dx" up
  ip -n "$y" link set "$dy" up
  shape "$x" "$dx"
  shape "$y" "$dy"
  echo "$x 198.18.$k.1 <-> $y 198.18.$k.2: $shaper rate $rate$([[ $shaper == netem ]] && echo " delay $delay loss $loss%")$( ((relays)) && echo " delay $delay (osw link relays)")" >>"$out/links.txt"
}
link 1 "${ns[0]}" "${ns[1]}"
link 2 "${ns[0]}" "${ns[2]}"
link 3 "${ns[1]}" "${ns[2]}"
# Host names of the three-machine configuration, per namespace: the address on its own link,
# or a relay's on loopback that adds the delay on the way there and back.
mkdir -p "/etc/netns/${ns[1]}" "/etc/netns/${ns[2]}"
relay() { # namespace local-address link-address port
  ip netns exec "$1" "$bin/osw" link --listen "$2:$4" --to "$3:$4" --delay-ms "$delay_ms" >/dev/null 2>>"$out/relays.log" &
  relay_pids+=($!)
}
a_from_b=198.18.1.1 a_from_d=198.18.2.1 b_from_d=198.18.3.1
if ((relays)); then
  relay "${ns[1]}" 127.0.0.2 "$a_from_b" 7101
  relay "${ns[2]}" 127.0.0.2 "$a_from_d" 7101
  relay "${ns[2]}" 127.0.0.3 "$b_from_d" 7102
  a_from_b=127.0.0.2 a_from_d=127.0.0.2 b_from_d=127.0.0.3
fi
printf '127.0.0.1 localhost\n%s osw-node-a\n' "$a_from_b" >"/etc/netns/${ns[1]}/hosts"
printf '127.0.0.1 localhost\n%s osw-node-a\n%s osw-node-b\n' "$a_from_d" "$b_from_d" >"/etc/netns/${ns[2]}/hosts"

token=$(head -c 16 /dev/urandom | od -An -tx1 | tr -d ' \n')
common=(--config "$config" --scene "$scene" --tau "$tau" --size "$size" --token "$token")
ip netns exec "${ns[0]}" "$bin/osw-node" --name a "${common[@]}" "${extra_node[@]}" --stats "$out/node-a.csv" >/dev/null 2>"$out/node-a.log" &
pids+=($!)
ip netns exec "${ns[1]}" "$bin/osw-node" --name b "${common[@]}" "${extra_node[@]}" --stats "$out/node-b.csv" >/dev/null 2>"$out/node-b.log" &
pids+=($!)
frames=$(($(wc -l <"$path") - 1))
echo "netns-cluster: $frames frames across ${ns[*]} ($shaper, $rate)" >&2
# In the background and waited for, so that a signal is handled at once, not after the walk.
ip netns exec "${ns[2]}" "$bin/osw-display" "${common[@]}" --path "$path" --out "$out" "${extra_display[@]}" >/dev/null 2>"$out/display.log" &
pids+=($!)
if ! wait "${pids[2]}"; then
  echo "netns-cluster: the display failed: $(tail -n 1 "$out/display.log")" >&2
  exit 1
fi
for k in 0 1; do
  if ! wait "${pids[$k]}"; then
    echo "netns-cluster: node $([[ $k == 0 ]] && echo a || echo b) failed: $(tail -n 1 "$out/node-$([[ $k == 0 ]] && echo a || echo b).log")" >&2
    exit 1
  fi
done
pids=()
echo "netns-cluster: done → $out" >&2
