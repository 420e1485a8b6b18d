#!/usr/bin/env bash
# Nightly fleetdyn run as a Slurm job array: array task i processes shard i/N.
#
#   sbatch deploy/slurm-nightly-array.sh                # N = the array size below
#   sbatch --dependency=afterany:<jobid> --wrap 'fleetdyn run pipelines/nightly.toml --output /scratch/fleet'
#                                                       # reduce: writes the fleet report
#
# Shards split the inputs by a hash of their path (every task lists the same inputs, takes a
# disjoint share); all tasks write into one dataset on the shared file system, each file
# atomically. A requeued or re-submitted task reuses the drives it had finished. The reduce step
# processes nothing new and writes the fleet report over all drives.
#SBATCH --job-name=fleetdyn-nightly
#SBATCH --array=0-7
#SBATCH --cpus-per-task=2
#SBATCH --mem=4G
#SBATCH --time=02:00:00
#SBATCH --output=logs/fleetdyn-%A_%a.log
set -euo pipefail
: "${SLURM_ARRAY_TASK_ID:?run through sbatch}"
SHARDS=${SLURM_ARRAY_TASK_COUNT:-8}
exec fleetdyn run pipelines/nightly.toml \
  --output /scratch/fleet \
  --shard "${SLURM_ARRAY_TASK_ID}/${SHARDS}" \
  --jobs "${SLURM_CPUS_PER_TASK:-2}"
