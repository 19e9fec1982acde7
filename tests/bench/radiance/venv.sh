# Sourced by the bench scripts (tests/bench/{radiance,render,glare}/run.sh): makes the
# virtual environment with pyradiance (Radiance's binaries come inside its wheel) the
# first time, downloading from PyPI. Sets $venv. Expects $root (the repository).
venv="${RADIANCE_VENV:-$root/target/radiance-venv}"
if [[ ! -x "$venv/bin/python" ]]; then
    echo "making $venv" >&2
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c "import pyradiance" 2>/dev/null; then
    echo "installing pyradiance into $venv (download from PyPI)" >&2
    "$venv/bin/python" -m pip install --quiet --upgrade pip
    "$venv/bin/python" -m pip install --quiet "pyradiance>=1.3"
fi
