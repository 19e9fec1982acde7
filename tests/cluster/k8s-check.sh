#!/usr/bin/env bash
# The Kubernetes files of docs/examples/cluster (issue 27): kubernetes-validate (PyPI; it ships
# Kubernetes' own schemas and runs offline) in strict mode against every Kubernetes version
# it ships from 1.26 (the first with the pod failure policy on by default), then
# tests/cluster/k8s_check.py for what a schema cannot check (completions = SHARDS, volume
# names, the commands against the Slurm scripts and the docs).
#
#   tests/cluster/k8s-check.sh
#
# The tool goes into a venv under the target folder (CARGO_TARGET_DIR or target/k8s-venv);
# DAYSTEP (a binary; default the release or debug build there) checks the Jobs' flags.
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
target=${CARGO_TARGET_DIR:-target}
[[ $target == /* ]] || target=$repo/$target
venv=$target/k8s-venv
version=1.37.0 # kubernetes-validate

if [[ ! -x $venv/bin/kubernetes-validate ]] ||
  [[ $("$venv"/bin/kubernetes-validate --version 2>/dev/null) != *"$version"* ]]; then
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv"/bin/pip install --quiet --disable-pip-version-check "kubernetes-validate==$version"
fi
cd "$repo"
yamls=(docs/examples/cluster/*.yaml)
schemas=$("$venv"/bin/python -c 'import kubernetes_validate, os; print(os.path.dirname(kubernetes_validate.__file__))')/kubernetes-json-schema
mapfile -t versions < <(find "$schemas" -maxdepth 1 -name 'v1.*.0-local-strict' -printf '%f\n' |
  sed 's/^v\(1\.[0-9]*\)\.0-local-strict$/\1/' | sort -t. -k2,2n | awk -F. '$2 >= 26')
((${#versions[@]})) || { echo "k8s-check: no schemas in $schemas" >&2; exit 1; }
for v in "${versions[@]}"; do
  "$venv"/bin/kubernetes-validate --strict --quiet -k "$v" "${yamls[@]}"
done
echo "k8s-check: ${yamls[*]}: valid (strict) against Kubernetes ${versions[0]} to ${versions[-1]} (kubernetes-validate $version)"

if [[ -z ${DAYSTEP:-} ]]; then
  for b in "$target"/release/daystep "$target"/debug/daystep; do
    if [[ -x $b ]]; then
      export DAYSTEP=$b
      break
    fi
  done
fi
"$venv"/bin/python tests/cluster/k8s_check.py
