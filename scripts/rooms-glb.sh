#!/usr/bin/env bash
# A GLB of rooms that each hold the same three scanned meshes (dragon, bunny, teapot), each mesh
# stored once and used by a node per room, plain float32 positions and u32 indices: a model made
# of catalogue parts, for measuring what a scene stores of its repeats
# (scripts/fixtures/rooms.js). Fetches the meshes first when the cache lacks them.
# Usage: scripts/rooms-glb.sh [--rooms N] [OUT.glb]   (default 36 rooms, out/rooms-N.glb)
set -euo pipefail
cd "$(dirname "$0")/.."
rooms=36
[ "${1:-}" = "--rooms" ] && { rooms=$2; shift 2; }
out="${1:-out/rooms-$rooms.glb}"
cache="${OSW_MESH_CACHE:-$HOME/.cache/osw/meshes}"
command -v node >/dev/null || { echo "rooms-glb: 'node' is needed (apt-get install -y nodejs npm)" >&2; exit 1; }
[ -f "$cache/dragon.ply" ] && [ -f "$cache/bunny.ply" ] && [ -f "$cache/teapot.ply" ] || scripts/fetch-meshes.sh "$cache"
mkdir -p "$(dirname "$out")"
node scripts/fixtures/rooms.js "$cache" "$out" "$rooms"
