#!/usr/bin/env bash
# daystep render against Radiance on the sample office (issue 15): region means against a
# brute-force rtrace reference per pixel, and times against rpict at -ab 5 and at
# Honeybee's image recipe settings. Not part of `cargo test` or CI.
#
#     tests/bench/render/run.sh [--only perez|overcast] [--width 100 --height 75] [--gather 64]
#
# It installs pyradiance into target/radiance-venv the first time (as
# tests/bench/radiance/run.sh does), builds daystep in release, and prints markdown tables.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
cd "$root"
source "$root/tests/bench/radiance/venv.sh"
cargo build --release --quiet
exec "$venv/bin/python" "$here/rpict.py" --daystep "$root/target/release/daystep" "$@"
