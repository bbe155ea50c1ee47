#!/usr/bin/env bash
# Install the peers, the outside tools that peer tests check Splatline against, pinned and
# outside the repository, in $SPLATLINE_PEERS (default ~/.cache/splatline-peers):
#   npm/     @playcanvas/splat-transform 3.7.0, gsplat 1.2.9 and @mkkellogg/gaussian-splats-3d
#            0.4.7 with three 0.187.0 (.ci/peers/package-lock.json)
#   openjd/  a venv with openjd-cli 0.8.0 (.ci/peers/openjd.txt)
# fourdgs, a Python library the tests import, is pinned in requirements/blender-*.txt instead.
# The Makefile passes the peers' paths to the tests when this folder holds them; for a shell,
#   eval "$(bash .ci/peers.sh)"
# prints the same variables (testing/peers.py names them). Installs only what changed.
# Needs node and npm (node 20 or later); a root on a machine without them gets Debian's.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
peers="${SPLATLINE_PEERS:-$HOME/.cache/splatline-peers}"
mkdir -p "$peers/npm"

if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  if [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm >/dev/null
  else
    echo "error: the peers need node and npm (run as root to install Debian's)" >&2; exit 1
  fi
fi

# npm ci installs exactly the lock file's versions; webgpu's install script only matters on macOS.
if ! cmp -s "$here/peers/package-lock.json" "$peers/npm/package-lock.json" \
   || [ ! -x "$peers/npm/node_modules/.bin/splat-transform" ]; then
  echo "peers: npm ci in $peers/npm" >&2
  cp "$here/peers/package.json" "$here/peers/package-lock.json" "$peers/npm/"
  (cd "$peers/npm" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error >&2)
fi

if ! cmp -s "$here/peers/openjd.txt" "$peers/openjd/requirements.txt"; then
  echo "peers: openjd-cli venv in $peers/openjd" >&2
  rm -rf "$peers/openjd"
  "$(bash "$here/python_for.sh" 5.0)" -m venv "$peers/openjd"
  "$peers/openjd/bin/python" -m pip install --quiet --disable-pip-version-check -r "$here/peers/openjd.txt" >&2
  cp "$here/peers/openjd.txt" "$peers/openjd/requirements.txt"
fi

# A peer that is installed but does not run (a node too old for it, say) fails here, not in a test.
"$peers/npm/node_modules/.bin/splat-transform" --version >/dev/null
"$peers/openjd/bin/openjd" --version >/dev/null
echo "export SPLATLINE_SPLAT_TRANSFORM=$peers/npm/node_modules/.bin/splat-transform"
echo "export SPLATLINE_GSPLAT_JS=$peers/npm/node_modules"
echo "export SPLATLINE_GS3D_JS=$peers/npm/node_modules"
echo "export SPLATLINE_OPENJD=$peers/openjd/bin/openjd"
