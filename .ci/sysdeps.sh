#!/usr/bin/env bash
# System libraries for headless OpenGL (EGL + Mesa llvmpipe) and Blender's bpy module.
# Installs only what is missing, and only when we are root (CI and fresh machines are).
set -euo pipefail
need=()
for pkg in libegl1 libgl1-mesa-dri libgl1 libxrender1 libxxf86vm1 libxfixes3 libxi6 libxkbcommon0 libsm6 libice6; do
  dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done
if [ ${#need[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
  else
    echo "warning: missing system packages (run as root to install): ${need[*]}" >&2
  fi
fi
