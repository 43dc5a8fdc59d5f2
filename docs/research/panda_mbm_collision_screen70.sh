#!/usr/bin/env bash
# Issue 42: a collision loss (`networks.collision_loss`, MπNets'), screened at 70 scenes as the other
# recipe options were (docs/research/panda_mbm_recipe_screen70.sh): the env's recipe as shipped and
# the same with Pnet's loss plus a weight times its proposals' depth in the scene's obstacles
# (the sphere model posed in torch, mpnet.models.clearance), trained on the first 70 generated scenes
# of panda_mbm's quick set (the iteration-budget dataset). MPNet-NR as the paper runs it on the
# generated test split (where a recipe is chosen), then on MotionBenchMaker's 700 (test data: read only
# by the mbm_* runs). One run at a time; a finished run leaves DONE in its folder and is skipped.
#
#   RUNS=/work/runs/coll70 bash docs/research/panda_mbm_collision_screen70.sh [NAME ...]
#
# NAME: a variant below, or mbm_NAME, or report (default: all, in order).
set -euo pipefail
RUNS=${RUNS:?RUNS=folder for the logs}
OUT=${OUT:-reports/panda_mbm_collision70}
CACHE=${CACHE:-$RUNS/cache}
MBM=${MBM:-data/mbm/problems}   # python -m harness.fetch_mbm data/mbm
mkdir -p "$RUNS"
COMMON=(+env=panda_mbm scale=quick scale.train.workspaces=70 progress=false "cache_dir=$CACHE")

declare -A VARIANT=(
  [env]="+planner=mpnet_nr"                                                # the env's recipe
  [random]="+planner=mpnet_nr_random"                                      # random valid proposals (no network)
  [collision1]="+planner=mpnet_nr +planner.networks.collision_loss=1"      # + collision loss, weight 1
  [collision0.1]="+planner=mpnet_nr +planner.networks.collision_loss=0.1"  # + collision loss, weight 0.1
  [collision0.01]="+planner=mpnet_nr +planner.networks.collision_loss=0.01"  # + collision loss, weight 0.01
)
ORDER=(env collision1 collision0.1 collision0.01 random)
for name in "${ORDER[@]}"; do VARIANT[mbm_$name]="${VARIANT[$name]} problems=$MBM"; done

run() {  # run NAME: one logged run into $RUNS/NAME (its networks trained first), skipped once DONE
  local name=$1 dir="$RUNS/$1"
  [[ -e "$dir/DONE" ]] && return 0
  echo "$(date -u +%FT%TZ) $name" >&2
  # shellcheck disable=SC2086  # the variant's overrides are words
  python -m harness "${COMMON[@]}" ${VARIANT[$name]} seed=0 hydra.run.dir="$dir" resume=true
  touch "$dir/DONE"
}

report() {
  local dirs=()
  for name in "${ORDER[@]}"; do dirs+=("$RUNS/$name" "$RUNS/mbm_$name"); done
  python -m harness.report "${dirs[@]}" --out "$OUT" --force
  python -m harness.recheck "${dirs[@]}" --jobs 2 --out "$OUT"
}

if [[ $# -eq 0 ]]; then
  set -- "${ORDER[@]}"
  for name in "${ORDER[@]}"; do set -- "$@" "mbm_$name"; done
  set -- "$@" report
fi
for stage in "$@"; do
  if [[ $stage == report ]]; then report; else run "$stage"; fi
done
