#!/usr/bin/env bash
# Headless-Chromium test of the .glb viewer (assets/viewer.html) on the sample day: the
# office (scenes/office) on 2021-03-21, exported by `daystep annual --gltf` and served by
# `daystep view` on 127.0.0.1. Run by .ci/run; it installs what it needs: Debian's chromium
# (apt-get, when /usr/bin/chromium is missing) and npm playwright-core into
# tests/browser/node_modules.
#
#     tests/browser/run.sh [--docs]
#
# Screenshots go to target/browser-test/; --docs also copies the first view's two (luminance
# and falsecolor illuminance) to docs/img/, where docs/viewer.md shows them.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="$root/target/browser-test"
docs=0
while [[ $# -gt 0 ]]; do
    case "$1" in
        --docs) docs=1; shift ;;
        *) echo "usage: $0 [--docs]" >&2; exit 2 ;;
    esac
done
mkdir -p "$out"

if [[ ! -x /usr/bin/chromium ]]; then
    sudo_=()
    if [[ $(id -u) -ne 0 ]]; then sudo_=(sudo); fi
    export DEBIAN_FRONTEND=noninteractive
    "${sudo_[@]}" apt-get install -y -qq --no-install-recommends chromium >/dev/null ||
        { "${sudo_[@]}" apt-get update -qq &&
            "${sudo_[@]}" apt-get install -y -qq --no-install-recommends chromium >/dev/null; }
fi
if [[ ! -d "$here/node_modules/playwright-core" ]]; then
    (cd "$here" && npm ci --no-audit --no-fund --silent)
fi

cd "$root"
cargo build --quiet --bin daystep
daystep="$root/target/debug/daystep"
day=2021-03-21
glb="$out/office-$day.glb"
"$daystep" annual scenes/office/scene.toml --weather scenes/office/weather.epw \
    --start "$day" --end "$day" --gltf-day "$day" --gltf "$glb" --out "$out/annual" >/dev/null

# A stale url.txt would be read before the new server's shell truncates it.
rm -f "$out/url.txt"
"$daystep" view "$glb" --port 0 >"$out/url.txt" 2>"$out/server.log" &
server=$!
trap 'kill "$server" 2>/dev/null || true' EXIT
for _ in $(seq 50); do
    [[ -s "$out/url.txt" ]] && break
    sleep 0.1
done
url="$(head -n1 "$out/url.txt")"
[[ -n "$url" ]] || { cat "$out/server.log" >&2; exit 1; }
echo "serving: $url"
node "$here/test.mjs" "$url" "$glb" "$out" "$root/assets/viewer.html" scenes/office/scene.toml
if ((docs)); then
    mkdir -p docs/img
    cp "$out/first-view.png" docs/img/viewer-first-view.png
    cp "$out/first-view-falsecolor.png" docs/img/viewer-first-view-falsecolor.png
fi
