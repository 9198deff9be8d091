#!/usr/bin/env bash
# Installs the npm tools the tests use (the Khronos glTF validator; three.js, which renders the
# packs' glTF in headless Chromium) into tools/gltf/node_modules, from the committed
# package-lock.json. Fast when already installed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dir="$root/tools/gltf"
if [ -f "$dir/node_modules/gltf-validator/package.json" ] &&
   [ -f "$dir/node_modules/three/package.json" ]; then
  echo "install-node-tools: gltf-validator and three.js already installed"
  exit 0
fi
command -v npm >/dev/null || { echo "install-node-tools: npm not found" >&2; exit 1; }
npm ci --prefix "$dir" --no-audit --no-fund --loglevel=error
