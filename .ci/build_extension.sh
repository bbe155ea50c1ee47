#!/usr/bin/env bash
# Build dist/splatline-<version>.zip with Blender's own extension builder (it validates the
# manifest), after fetching the wheels the manifest names. Usage: .ci/build_extension.sh PYTHON
set -euo pipefail
py=$(realpath -s "${1:-.venv/bin/python}")  # -s: keep the venv symlink
out=$(realpath -m "${2:-dist}")
cd "$(dirname "$0")/.."
mkdir -p wheels "$out"
# The manifest is the single list of bundled wheels: fetch exactly those files.
mapfile -t wheels < <(sed -n 's|^ *"\./wheels/\([^"]*\.whl\)".*|\1|p' blender_manifest.toml)
for w in "${wheels[@]}"; do
  [ -f "wheels/$w" ] && continue
  spec=$(echo "$w" | awk -F- '{print $1"=="$2}')
  "$py" -m pip download --quiet --no-deps --only-binary=:all: --python-version 3.11 \
    --platform manylinux2014_x86_64 -d wheels "$spec"
  [ -f "wheels/$w" ] || { echo "error: pip did not produce wheels/$w" >&2; exit 1; }
done
ext=$("$py" -c 'import bpy, os; print(os.path.join(bpy.utils.system_resource("SCRIPTS"), "addons_core/bl_pkg/cli/blender_ext.py"))')
"$py" "$ext" build --source-dir . --output-dir "$out"
ls -l "$out"/*.zip
