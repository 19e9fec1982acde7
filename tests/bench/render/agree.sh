#!/usr/bin/env bash
# Per-pixel agreement of a default `daystep render` of the sample office with brute-force
# rtrace (issue 29): tests/bench/render/agreement.py. Not part of `cargo test` or CI.
#
#     tests/bench/render/agree.sh [--every 10] [--width 640 --height 480]
#
# Installs pyradiance (tests/bench/radiance/venv.sh) and OpenEXR with numpy (to read the
# EXR's err channel) into target/radiance-venv the first time, builds daystep in release.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
cd "$root"
source "$root/tests/bench/radiance/venv.sh"
if ! "$venv/bin/python" -c "import OpenEXR, numpy" 2>/dev/null; then
    echo "installing OpenEXR and numpy into $venv (download from PyPI)" >&2
    "$venv/bin/python" -m pip install --quiet "OpenEXR>=3.3" numpy
fi
cargo build --release --quiet
exec "$venv/bin/python" "$here/agreement.py" --daystep "$root/target/release/daystep" "$@"
