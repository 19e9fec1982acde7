#!/usr/bin/env bash
# Peer bench: daystep's LEED v4.1 Option 1 and EN 17037 metric code against
# honeybee-radiance-postprocess 0.5.25 on the same random-but-seeded hourly matrices
# (tests/bench/postprocess/peer.py lists the cases).
#
#     tests/bench/postprocess/run.sh
#
# It DOWNLOADS honeybee-radiance-postprocess from PyPI (the first time) into a virtual
# environment in target/hbpp-venv: its dependencies as pinned by the package except CuPy
# (GPU only; without it the package falls back to NumPy), so the package itself is
# installed with --no-deps after honeybee-radiance and numpy. Then:
#   1. peer.py make      writes the cases in honeybee's results layout (.npy per light
#                        path, state, result type and grid) under target/postprocess-bench;
#   2. peer.py honeybee  runs leed_option_one (shade transmittance 0.05) and en17037_compute;
#   3. cargo bench --bench postprocess_peer -- DIR   runs daystep's functions on the same files;
#   4. peer.py compare   prints a table and every difference (exit 1 if any).
# Not part of `cargo test` or CI. Needs python3 (with venv) and a Rust toolchain.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
cd "$root"

target="${CARGO_TARGET_DIR:-$root/target}"
source "$here/venv.sh"

dir="$target/postprocess-bench"
mkdir -p "$dir"
"$venv/bin/python" "$here/peer.py" make "$dir"
"$venv/bin/python" "$here/peer.py" honeybee "$dir"
cargo bench --locked --quiet --bench postprocess_peer -- "$dir"
exec "$venv/bin/python" "$here/peer.py" compare "$dir"
