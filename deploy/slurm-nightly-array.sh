#!/usr/bin/env bash
# Nightly fleetdyn run as a Slurm job array: array task i processes shard i/N.
#
#   mkdir -p logs                                       # Slurm opens the logs before the script runs
#   jobid=$(sbatch --parsable deploy/slurm-nightly-array.sh)
#   sbatch --dependency=afterany:$jobid --wrap 'fleetdyn run pipelines/nightly.toml --output /scratch/fleet'
#                                                       # reduce: writes the fleet report
#
# Environment (defaults in brackets), read by every task:
#   FLEETDYN_PIPELINE  the pipeline file [pipelines/nightly.toml]; its relative paths resolve
#                      against its own folder, so the job can be submitted from anywhere
#   FLEETDYN_OUTPUT    the dataset's root on the shared file system [/scratch/fleet]
#   FLEETDYN           the fleetdyn binary [fleetdyn, from PATH]
#
# Shards split the inputs by a hash of their path (every task lists the same inputs, takes a
# disjoint share); all tasks write into one dataset on the shared file system, each file
# atomically. A requeued or re-submitted task reuses the drives it had finished. The reduce step
# processes nothing new and writes the fleet report over all drives. deploy/test/slurm.sh runs
# this script unchanged on a single-node cluster and checks all of it against an unsharded run.
#SBATCH --job-name=fleetdyn-nightly
#SBATCH --array=0-7
#SBATCH --cpus-per-task=2
#SBATCH --mem=4G
#SBATCH --time=02:00:00
#SBATCH --output=logs/fleetdyn-%A_%a.log
#SBATCH --requeue
set -euo pipefail
: "${SLURM_ARRAY_TASK_ID:?run through sbatch}"
SHARDS=${SLURM_ARRAY_TASK_COUNT:-8}
exec "${FLEETDYN:-fleetdyn}" run "${FLEETDYN_PIPELINE:-pipelines/nightly.toml}" \
  --output "${FLEETDYN_OUTPUT:-/scratch/fleet}" \
  --shard "${SLURM_ARRAY_TASK_ID}/${SHARDS}" \
  --jobs "${SLURM_CPUS_PER_TASK:-2}"
