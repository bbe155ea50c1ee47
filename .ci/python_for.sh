#!/usr/bin/env bash
# Print the path of a Python interpreter that the PyPI bpy of one Blender version needs:
# 3.11 for Blender 4.5 and 5.0, 3.13 for 5.2 and 5.3. Usage: .ci/python_for.sh 5.2
# Debian 12 packages no Python 3.13; this machine kind's image carries one under pyenv.
set -euo pipefail
case "${1:?usage: python_for.sh BLENDER_VERSION}" in
  4.5|5.0) want=3.11 ;;
  5.2|5.3) want=3.13 ;;
  *) echo "error: no known Python for Blender $1 (supported: 4.5 5.0 5.2 5.3)" >&2; exit 2 ;;
esac
candidates=("python$want")
root=$(pyenv root 2>/dev/null || echo "$HOME/.pyenv")
for d in "$root"/versions/"$want"*/bin/python"$want"; do candidates+=("$d"); done
candidates+=("/usr/local/bin/python$want" "/usr/bin/python$want")
for c in "${candidates[@]}"; do
  # A pyenv shim exists for every version but fails for one that is not selected: run it.
  if command -v "$c" >/dev/null 2>&1 && "$c" -c 'import venv, ensurepip' >/dev/null 2>&1; then
    command -v "$c"
    exit 0
  fi
done
echo "error: Blender $1 needs Python $want with venv and ensurepip; none found (looked for: ${candidates[*]})" >&2
exit 1
