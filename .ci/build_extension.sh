#!/usr/bin/env bash
# Build one zip per platform, dist/splatline-<version>-<platform>.zip, with Blender's own
# extension builder, after fetching the wheels the manifest names; then validate each zip with
# that builder too. Usage: .ci/build_extension.sh [PYTHON] [OUTPUT_DIR]
set -euo pipefail
py=$(realpath -s "${1:-.venv/bin/python}")  # -s: keep the venv symlink
out=$(realpath -m "${2:-dist}")
cd "$(dirname "$0")/.."
mkdir -p wheels "$out"
# The manifest is the single list of bundled wheels: fetch exactly those files. wheels/ is a
# cache (gitignored): a wheel already there is not fetched again.
mapfile -t wheels < <(sed -n 's|^ *"\./wheels/\([^"]*\.whl\)".*|\1|p' blender_manifest.toml)
for w in "${wheels[@]}"; do
  [ -f "wheels/$w" ] && continue
  # name-version-pythontag-abitag-platformtag.whl: ask pip for that one file's tags.
  IFS=- read -r name version pytag _abi plat <<<"${w%.whl}"
  args=(--platform "${plat##*.}")  # a compressed tag set (a.b.c): any one of them selects the file
  [[ $pytag == cp3* ]] && args+=(--python-version "3.${pytag#cp3}")
  # into a private folder, then one rename: parallel builds (pytest -n 2) never see half a file
  tmp=$(mktemp -d wheels/.fetch.XXXXXX)
  "$py" -m pip download --quiet --no-deps --only-binary=:all: "${args[@]}" -d "$tmp" "$name==$version"
  [ -f "$tmp/$w" ] || { echo "error: pip did not produce $w" >&2; rm -rf "$tmp"; exit 1; }
  mv -f "$tmp/$w" "wheels/$w" && rm -rf "$tmp"
done
# The builder packs every file in wheels/: a wheel the manifest no longer names (plyfile, dropped
# from the zip) must not ride along from an older cache.
for f in wheels/*.whl; do
  [ -e "$f" ] || continue
  [[ " ${wheels[*]} " == *" ${f#wheels/} "* ]] || rm -f "$f"
done
# bpy may log to stdout before the path (e.g. when OCIO is set): keep the last line
ext=$("$py" -c 'import bpy, os; print(os.path.join(bpy.utils.system_resource("SCRIPTS"), "addons_core/bl_pkg/cli/blender_ext.py"))' | tail -n 1)
rm -f "$out"/splatline-*.zip  # zips of an older version or platform list would linger
# --split-platforms: one zip per manifest platform, each with only the wheels for that platform
# (all Python versions; Blender installs the ones matching its own Python).
"$py" "$ext" build --split-platforms --source-dir . --output-dir "$out"
for z in "$out"/splatline-*.zip; do "$py" "$ext" validate "$z"; done
ls -l "$out"/splatline-*.zip
