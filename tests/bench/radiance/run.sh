#!/usr/bin/env bash
# Validation bench: daystep against Radiance on the sample office (scenes/office), or on
# another scene with --scene (tests/bench/radiance/courtyard: outdoor, single-surface walls).
#
# Run from anywhere (it changes to the repository root itself):
#
#     tests/bench/radiance/run.sh            # the two instants (about 15 minutes on 2 cores)
#     tests/bench/radiance/run.sh --quick    # small reference (~8 min): checks the bench, validates nothing
#     tests/bench/radiance/run.sh --only perez
#     tests/bench/radiance/run.sh --annual   # adds a year, Radiance 2-phase vs daystep annual (~6 min)
#     tests/bench/radiance/run.sh --scene tests/bench/radiance/courtyard/scene.toml --only perez --nproc 1
#
# It DOWNLOADS pyradiance from PyPI (the first time): a virtual environment is made in
# target/radiance-venv and `pip install pyradiance` puts the Radiance suite there (the
# wheel ships rtrace, rcontrib, gendaylit, gensky, gendaymtx, dctimestep, … and their lib
# folder; validate.py sets PATH and RAYPATH to them). Then it builds daystep
# (`cargo build --release`) and runs validate.py with the venv's Python, which prints
# markdown tables; its scratch files go to target/radiance-bench.
#
# Not part of `cargo test` or CI. Needs python3 (with venv) and a Rust toolchain; the
# binary wheel used here was pyradiance 1.3.1 for CPython 3.11, manylinux x86_64.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
cd "$root"

source "$root/tests/bench/radiance/venv.sh"

cargo build --release --quiet

exec "$venv/bin/python" "$here/validate.py" --daystep "$root/target/release/daystep" "$@"
