#!/usr/bin/env bash
# Installs what osw needs on a fresh Debian machine, skipping what is already there:
# Mesa's software Vulkan driver (lavapipe) and the Vulkan loader, which the renderer uses when
# no GPU is present, a font for the plots' and the overlay's text (DejaVu), iproute2 for the
# network-namespace cluster, and for the window: the X libraries winit loads at run time, Xvfb
# (an X server without a screen), xdotool and xwd (the window test's scripted input and
# screen grab). Needs root (or sudo) only when something is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
sudo_cmd=""
[ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
missing=()
for pkg in mesa-vulkan-drivers libvulkan1 fonts-dejavu-core iproute2 \
  libx11-6 libxcursor1 libxi6 libxrandr2 libxkbcommon-x11-0 xvfb xdotool x11-apps; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq "${missing[@]}" >/dev/null
fi
command -v cargo >/dev/null || { echo "setup: cargo not found: install Rust (rustup) first" >&2; exit 1; }
# Real models made by others for the tests, where ../shared/models/ (our machines and CI) is
# not beside the clone: Debian's assimp-testmodels holds glTF 2.0 models (a two-cylinder engine
# of repeated parts; textured boxes and texture transforms, kept aside in models/textured/ as
# they have nothing to cull) and a corpus of malformed or unsupported glTF that the tests use
# as bad input. Into models/ (git-ignored), once per version of this list; skipped where
# apt-get is not there.
if [[ ! -e models/.filled-2 ]] && command -v apt-get >/dev/null; then
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  if (cd "$tmp" && apt-get download -qq assimp-testmodels 2>/dev/null) ||
    { $sudo_cmd apt-get update -qq && (cd "$tmp" && apt-get download -qq assimp-testmodels 2>/dev/null); }; then
    dpkg-deb -x "$tmp"/assimp-testmodels_*.deb "$tmp/x"
    src="$tmp/x/usr/share/assimp/models/glTF2"
    rm -rf models/bad models/textured
    mkdir -p models/bad models/textured
    cp "$src/2CylinderEngine-glTF-Binary/2CylinderEngine.glb" models/
    for d in BoxTextured-glTF BoxTextured-glTF-Binary BoxTextured-glTF-Embedded BoxTexcoords-glTF textureTransform issue_3269 \
      BoxTextured-glTF-pbrSpecularGlossiness; do
      cp -r "$src/$d" models/textured/
    done
    for d in IndexOutOfRange IncorrectVertexArrays MissingBin SchemaFailures TestNoRootNode RecursiveNodes wrongTypes \
      BoxWithInfinites-glTF-Binary BoxTextured-glTF-techniqueWebGL draco; do
      cp -r "$src/$d" models/bad/
    done
    touch models/.filled-2
    echo "setup: real models for the tests in models/ ($(ls models/*.glb | wc -l) models, $(ls models/textured | wc -l) textured, $(find models/bad -name '*.gl*' | wc -l) malformed)" >&2
  else
    echo "setup: Debian's assimp-testmodels not found: the tests that need real models will say so" >&2
  fi
fi
