#!/usr/bin/env bash
# Headless-Chromium test of the .glb viewer (assets/viewer.html) served by `daystep view`.
# Not part of `cargo test` or CI: it installs Debian's chromium (apt-get, when
# /usr/bin/chromium is missing) and npm playwright-core into tests/browser/node_modules.
#
#     tests/browser/run.sh [--glb FILE.glb [--frame K]]   (K: the frame the checks start from)
#
# Without --glb it writes the test room (make_test_glb.py). With --glb it checks FILE against
# the layout and runs the same assertions, which assume a room with its window at the
# largest glTF z (north = 0), as daystep's export of a room with a north-0 window is.
# Screenshots go to target/browser-test/.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="$root/target/browser-test"
glb=""
while [[ $# -gt 0 ]]; do
    case "$1" in
        --glb) glb="$(realpath "$2")"; shift 2 ;;
        --frame) export BASE_FRAME="$2"; shift 2 ;;
        *) echo "usage: $0 [--glb FILE.glb [--frame K]]" >&2; exit 2 ;;
    esac
done
mkdir -p "$out"

if [[ ! -x /usr/bin/chromium ]]; then
    sudo_=""; [[ $(id -u) -ne 0 ]] && sudo_="sudo"
    $sudo_ apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_ apt-get install -y -qq chromium >/dev/null
fi
if [[ ! -d "$here/node_modules/playwright-core" ]]; then
    (cd "$here" && npm ci --no-audit --no-fund --silent)
fi

if [[ -z "$glb" ]]; then
    glb="$out/room.glb"
    python3 "$here/make_test_glb.py" "$glb"
else
    python3 "$here/make_test_glb.py" --glb "$glb"
fi

cd "$root"
cargo build -j 1 --quiet --bin daystep
"$root/target/debug/daystep" view "$glb" --port 0 >"$out/url.txt" 2>"$out/server.log" &
server=$!
trap 'kill "$server" 2>/dev/null || true' EXIT
for _ in $(seq 50); do
    [[ -s "$out/url.txt" ]] && break
    sleep 0.1
done
url="$(head -n1 "$out/url.txt")"
[[ -n "$url" ]] || { cat "$out/server.log" >&2; exit 1; }
echo "serving: $url"
node "$here/test.mjs" "$url" "$glb" "$out" "$root/assets/viewer.html"
