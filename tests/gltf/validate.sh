#!/usr/bin/env bash
# The Khronos glTF validator on daystep's .glb (issue 16): renders the sample office's
# 21 March at the weather file's hours with --gltf (or takes FILE.glb), installs the npm
# package gltf-validator into target/gltf-validator the first time, and prints the
# validator's counts and first messages. Exit 1 when it reports an error. Not part of
# `cargo test` or CI (it needs the npm registry).
#
#     tests/gltf/validate.sh [FILE.glb]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
cd "$root"
glb="${1:-}"
if [[ -z "$glb" ]]; then
    cargo build --release --quiet
    out="$root/target/gltf-validate"
    rm -rf "$out"
    ./target/release/daystep render scenes/office/scene.toml \
        --view "-vtv -vp 3 7.5 1.5 -vd 0 -1 -0.1 -vu 0 0 1 -vh 70 -vv 50" -x 64 -y 48 \
        --weather scenes/office/weather.epw --start 2021-03-21 --end 2021-03-21 \
        --out "$out" --gltf "$out/office.glb" --no-cache
    glb="$out/office.glb"
fi
v="$root/target/gltf-validator"
if [[ ! -d "$v/node_modules/gltf-validator" ]]; then
    mkdir -p "$v"
    (cd "$v" && npm init -y >/dev/null && npm install --silent gltf-validator)
fi
cat > "$v/validate.js" <<'JS'
const v = require('gltf-validator');
const fs = require('fs');
const data = new Uint8Array(fs.readFileSync(process.argv[2]));
v.validateBytes(data, { maxIssues: 1000 }).then((r) => {
  const i = r.issues;
  console.log(`${process.argv[2]}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints`);
  for (const m of i.messages.filter((m) => m.severity <= 1).slice(0, 20)) {
    console.log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer || ''}: ${m.message}`);
  }
  process.exit(i.numErrors > 0 ? 1 : 0);
});
JS
node "$v/validate.js" "$glb"
