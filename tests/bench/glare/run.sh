#!/usr/bin/env bash
# Glare bench: daystep's daylight glare probability and vertical illuminance against
# Radiance's evalglare on eight synthetic angular fisheye scenes (tests/bench/glare.rs).
#
# Run from anywhere (it changes to the repository root itself):
#
#     tests/bench/glare/run.sh                # 800×800 scenes
#     tests/bench/glare/run.sh --size 400     # quicker
#
# Like tests/bench/radiance/run.sh, it DOWNLOADS pyradiance from PyPI the first time:
# a virtual environment is made in target/radiance-venv (or $RADIANCE_VENV, to share an
# existing one) and `pip install pyradiance` brings Radiance's binaries, evalglare among
# them. Then `cargo bench --bench glare` builds daystep and prints markdown tables; the
# scene pictures go to target/glare-bench. Not part of `cargo test` or CI.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
cd "$root"

source "$root/tests/bench/radiance/venv.sh"

# The wheel's binaries and their lib folder, as validate.py sets them.
base="$("$venv/bin/python" -c 'import pathlib, pyradiance; print(pathlib.Path(pyradiance.__file__).resolve().parent)')"
if [[ ! -x "$base/bin/evalglare" ]]; then
    echo "no evalglare in $base/bin: is this the pyradiance wheel with binaries?" >&2
    exit 1
fi
export PATH="$base/bin:$PATH"
export RAYPATH=".:$base/lib"

exec cargo bench -j 1 --quiet --bench glare -- "$@"
