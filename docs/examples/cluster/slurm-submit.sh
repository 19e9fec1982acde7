#!/bin/bash
# Queues one daystep study on Slurm: an array of SHARDS shard tasks, then the merge, which
# waits for every task to succeed (afterok).
#
#   usage: slurm-submit.sh STUDY WEATHER_FILE [SHARDS]
#
# Many studies over one geometry: call it once per weather file or site; every study gets
# its own runs/STUDY folder and all of them share the cache folder.
#
#   for epw in /shared/daystep/weather/*.epw; do
#     ./slurm-submit.sh "$(basename "$epw" .epw)" "$epw" 8
#   done
#
# ROOT, SCENE, CACHE, QUALITY, ANNUAL_ARGS, STEP and MERGE_ARGS are passed on to the jobs
# from the environment (see slurm-annual.sbatch and slurm-merge.sbatch). DEPENDENCY, if set,
# is the shard array's sbatch --dependency, e.g. DEPENDENCY=afterany:1234 to start after the
# job that primes the cache (sbatch itself reads no environment variable for it).

set -euo pipefail

if (($# < 2)); then
  echo "usage: $0 STUDY WEATHER_FILE [SHARDS]" >&2
  exit 1
fi
study=$1
weather=$2
shards=${3:-8}
here=$(dirname "$0")

vars="ALL,STUDY=$study,WEATHER=$weather,SHARDS=$shards"
after=()
if [[ -n ${DEPENDENCY:-} ]]; then
  after=(--dependency="$DEPENDENCY")
fi
array=$(sbatch --parsable ${after[@]+"${after[@]}"} --array=1-"$shards" --job-name="daystep-$study" \
  --export="$vars" "$here/slurm-annual.sbatch")
array=${array%%;*} # --parsable prints "jobid" or "jobid;cluster"
merge=$(sbatch --parsable --dependency=afterok:"$array" --job-name="daystep-$study-merge" \
  --export="$vars" "$here/slurm-merge.sbatch")
echo "study $study: shards in job $array (1-$shards), merge in job ${merge%%;*}"
