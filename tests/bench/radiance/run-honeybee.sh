#!/usr/bin/env bash
# Model-import bench: the Honeybee sample model (scenes/honeybee) through daystep from its
# HBJSON, its millimetre copy and honeybee's .rad files, against Radiance run on the
# honeybee-written .rad and .pts (honeybee.py). About 10 minutes on 2 cores. DOWNLOADS
# pyradiance from PyPI the first time (venv.sh). Not part of `cargo test` or CI.
#
#     tests/bench/radiance/run-honeybee.sh [--quick] [--only perez|overcast] [--ways hbjson,mm,rad] [--nproc N]
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
cd "$root"

source "$root/tests/bench/radiance/venv.sh"

cargo build --release --quiet

exec "$venv/bin/python" "$here/honeybee.py" --daystep "$root/target/release/daystep" "$@"
