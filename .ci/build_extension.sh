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
  # the wheel's own tag picks the Python to fetch for: cp313 -> 3.13, cp311 or py3 -> 3.11
  pyver=$(echo "$w" | awk -F- '{t=$3; if (t ~ /^cp3[0-9]+$/) print "3." substr(t, 4); else print "3.11"}')
  # into a private folder, then one rename: parallel builds (pytest -n 2) never see half a file
  tmp=$(mktemp -d wheels/.fetch.XXXXXX)
  "$py" -m pip download --quiet --no-deps --only-binary=:all: --python-version "$pyver" \
    --platform manylinux2014_x86_64 -d "$tmp" "$spec"
  [ -f "$tmp/$w" ] || { echo "error: pip did not produce $w" >&2; rm -rf "$tmp"; exit 1; }
  mv -f "$tmp/$w" "wheels/$w" && rm -rf "$tmp"
done
ext=$("$py" -c 'import bpy, os; print(os.path.join(bpy.utils.system_resource("SCRIPTS"), "addons_core/bl_pkg/cli/blender_ext.py"))' | tail -n 1)  # bpy may log to stdout first (OCIO set)
"$py" "$ext" build --source-dir . --output-dir "$out"
ls -l "$out"/*.zip
