#!/usr/bin/env bash
# Makes the glTF fixtures of the import tests with the real tools, from the npm registry and run
# under node: gltfpack (quantized by default, -cc meshopt-compressed, -mi instanced, -vpn and
# -vpf other position encodings) and gltf-transform (Draco). The source model is written by
# scripts/fixtures/source-model.js; a small textured model by scripts/fixtures/textured-model.py. Writes into crates/osw/tests/fixtures/gltf/ (committed; run
# this again after changing the source or the tools' versions). With --meshes, also packs the
# real meshes scripts/fetch-meshes.sh put in the mesh cache (bunny, teapot, dragon: larger,
# for benchmarks and trying by hand) into out/fixtures/, which git ignores.
# Usage: scripts/make-fixtures.sh [--meshes] [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
meshes=0
[ "${1:-}" = "--meshes" ] && { meshes=1; shift; }
out="${1:-crates/osw/tests/fixtures/gltf}"
tools="${OSW_NPM_TOOLS:-$HOME/.cache/osw/npm-tools}"
for tool in npm node; do
  command -v "$tool" >/dev/null || { echo "make-fixtures: '$tool' is needed (apt-get install -y nodejs npm)" >&2; exit 1; }
done
if [ ! -x "$tools/node_modules/.bin/gltfpack" ] || [ ! -x "$tools/node_modules/.bin/gltf-transform" ]; then
  mkdir -p "$tools"
  npm install --silent --no-audit --no-fund --prefix "$tools" gltfpack@1.3.0 @gltf-transform/cli@4.5.1 >&2
fi
pack="$tools/node_modules/.bin/gltfpack"
transform="$tools/node_modules/.bin/gltf-transform"
mkdir -p "$out"
node scripts/fixtures/source-model.js "$out/source.gltf"
"$pack" -i "$out/source.gltf" -o "$out/packed.glb" >/dev/null
"$pack" -i "$out/source.gltf" -o "$out/packed-cc.glb" -cc >/dev/null
"$pack" -i "$out/source.gltf" -o "$out/packed-mi.glb" -mi >/dev/null
"$pack" -i "$out/source.gltf" -o "$out/packed-vpn-cc.glb" -vpn -cc >/dev/null
"$pack" -i "$out/source.gltf" -o "$out/packed-vpf-cc.glb" -vpf -cc >/dev/null
"$transform" draco "$out/source.gltf" "$out/draco.glb" >/dev/null
python3 scripts/fixtures/textured-model.py "$out/textured.glb"
ls -l "$out"
if ((meshes)); then
  cache="${OSW_MESH_CACHE:-$HOME/.cache/osw/meshes}"
  mkdir -p out/fixtures
  for m in bunny teapot dragon; do
    [ -f "$cache/$m.ply" ] || { echo "make-fixtures: $cache/$m.ply missing (scripts/fetch-meshes.sh)" >&2; continue; }
    node scripts/fixtures/ply-to-obj.js "$cache/$m.ply" "out/fixtures/$m.obj"
    "$pack" -i "out/fixtures/$m.obj" -o "out/fixtures/$m.glb" >/dev/null
    "$pack" -i "out/fixtures/$m.obj" -o "out/fixtures/$m-cc.glb" -cc >/dev/null
    "$transform" draco "out/fixtures/$m.glb" "out/fixtures/$m-draco.glb" >/dev/null
  done
  ls -l out/fixtures
fi
