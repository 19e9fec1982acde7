# shellcheck shell=bash
# Sourced by run.sh and run-own.sh: the virtual environment with
# honeybee-radiance-postprocess 0.5.25 (downloaded from PyPI the first time) in $venv.
# Needs $root (the repository).
venv="${HBPP_VENV:-$root/target/hbpp-venv}"
if [[ ! -x "$venv/bin/python" ]]; then
    echo "making $venv" >&2
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c "import honeybee_radiance_postprocess" 2>/dev/null; then
    echo "installing honeybee-radiance-postprocess into $venv (download from PyPI)" >&2
    "$venv/bin/python" -m pip install --quiet --upgrade pip
    "$venv/bin/python" -m pip install --quiet "honeybee-radiance==1.66.299" "numpy==2.1.0"
    "$venv/bin/python" -m pip install --quiet --no-deps "honeybee-radiance-postprocess==0.5.25"
fi
