#!/usr/bin/env bash
# System libraries for headless OpenGL (EGL + Mesa llvmpipe) and Blender's bpy module, and
# Vulkan (the loader and Mesa's lavapipe): Blender 5.3's default GPU backend is Vulkan, and
# without a Vulkan driver bpy 5.3 falls back to OpenGL, which would leave its Vulkan path
# untested (tests/project/test_gpu_backend.py fails the run then).
# Installs only what is missing, and only when we are root (CI and fresh machines are).
set -euo pipefail
need=()
for pkg in libegl1 libgl1-mesa-dri libgl1 libxrender1 libxxf86vm1 libxfixes3 libxi6 libxkbcommon0 libsm6 libice6 \
           libvulkan1 mesa-vulkan-drivers; do
  dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done
if [ ${#need[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
  else
    echo "warning: missing system packages (run as root to install): ${need[*]}" >&2
  fi
fi
