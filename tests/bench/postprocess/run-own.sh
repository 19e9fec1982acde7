#!/usr/bin/env bash
# daystep's own `annual --leed --en17037` output against honeybee-radiance-postprocess
# 0.5.25 on the same hourly values (tests/bench/postprocess/own.py says what is compared).
#
#     tests/bench/postprocess/run-own.sh ANNUAL_DIR EPW
#
# ANNUAL_DIR: a whole-year hourly `daystep annual … --leed --en17037 --out ANNUAL_DIR`,
# EPW its weather file. Installs the package as run.sh does (target/hbpp-venv). Exit 1 on
# any difference. Not part of `cargo test` or CI.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
[[ $# -eq 2 ]] || { echo "usage: $0 ANNUAL_DIR EPW" >&2; exit 2; }
annual="$(realpath "$1")"
epw="$(realpath "$2")"
cd "$root"
source "$here/venv.sh"
case_dir="${CARGO_TARGET_DIR:-$root/target}/postprocess-own"
rm -rf "$case_dir"
mkdir -p "$case_dir"
exec "$venv/bin/python" "$here/own.py" "$annual" "$epw" "$case_dir"
