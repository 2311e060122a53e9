#!/usr/bin/env bash
# Installs what osw needs on a fresh Debian machine, skipping what is already there:
# Mesa's software Vulkan driver (lavapipe) and the Vulkan loader, which the renderer uses when
# no GPU is present, a font for the plots' and the overlay's text (DejaVu), iproute2 for the
# network-namespace cluster, and for the window: the X libraries winit loads at run time, Xvfb
# (an X server without a screen), xdotool and xwd (the window test's scripted input and
# screen grab). Needs root (or sudo) only when something is missing.
set -euo pipefail
missing=()
for pkg in mesa-vulkan-drivers libvulkan1 fonts-dejavu-core iproute2 \
  libx11-6 libxcursor1 libxi6 libxrandr2 libxkbcommon-x11-0 xvfb xdotool x11-apps; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq "${missing[@]}" >/dev/null
fi
command -v cargo >/dev/null || { echo "setup: cargo not found: install Rust (rustup) first" >&2; exit 1; }
