#!/usr/bin/env bash
# Every model's pack from the bundled fixtures passes the Khronos glTF validator.
# Usage: gltf_test.sh MATFIT_BINARY SOURCE_DIR   (exit 77 = skipped: validator not installed)
set -u
bin=$1; src=$2
validator="$src/tools/gltf/validate.mjs"
if [ ! -d "$src/tools/gltf/node_modules/gltf-validator" ] || ! command -v node >/dev/null; then
  echo "gltf-validator not installed (scripts/install-node-tools.sh): skipping"
  exit 77
fi
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
pass=0; fail=0
for model in mean lambert lambert-robust heinrich ptm hsh2 hsh3 blinn-phong cook-torrance lafortune1 lafortune2; do
  "$bin" fit "$src/fixtures/plaster-bonn81" --model "$model" --out "$tmp/$model" --quiet >/dev/null || { fail=$((fail+1)); echo "FAIL: fit $model"; continue; }
  if out=$(node "$validator" "$tmp/$model/material.gltf"); then pass=$((pass+1)); else fail=$((fail+1)); echo "FAIL: $model"; fi
  echo "$model: $out" | tail -1
done
echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
