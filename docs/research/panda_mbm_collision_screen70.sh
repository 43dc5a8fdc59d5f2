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
#   SCENES=735 CACHE=... RUNS=... OUT=reports/archive/panda_mbm_collision bash ... collision0.01 env ...  (the chosen weight, all 735)
#
# NAME: a variant below, or mbm_NAME, or report (default: all, in order).
set -euo pipefail
OUT=${OUT:-reports/archive/panda_mbm_collision70}
# shellcheck source=docs/research/screen_runs.sh
source "$(dirname "$0")/screen_runs.sh"

declare -A VARIANT=(
  [env]="+planner=mpnet_nr"                                                # the env's recipe
  [random]="+planner=mpnet_nr_random"                                      # random valid proposals (no network)
  [collision1]="+planner=mpnet_nr +planner.networks.collision_loss=1"      # + collision loss, weight 1
  [collision0.1]="+planner=mpnet_nr +planner.networks.collision_loss=0.1"  # + collision loss, weight 0.1
  [collision0.01]="+planner=mpnet_nr +planner.networks.collision_loss=0.01"  # + collision loss, weight 0.01
  [collision0.001]="+planner=mpnet_nr +planner.networks.collision_loss=0.001"  # + collision loss, weight 0.001
)
ORDER=(env collision1 collision0.1 collision0.01 collision0.001 random)
for name in "${ORDER[@]}"; do VARIANT[mbm_$name]="${VARIANT[$name]} problems=$MBM"; done
# How often the first NeuralPlanner run connects on MBM (MPNet-HR's premise): HR with RRT-Connect
# replanning, which closes every gap a first run leaves
VARIANT[mbm_hrc_env]="+planner=mpnet_hr_rrtc problems=$MBM"
VARIANT[mbm_hrc_collision0.01]="+planner=mpnet_hr_rrtc +planner.networks.collision_loss=0.01 problems=$MBM"
# MPNet-HR as the paper runs it (RRT* replanning) with the chosen weight's networks
VARIANT[mbm_hr_collision0.01]="+planner=mpnet_hr +planner.networks.collision_loss=0.01 problems=$MBM"

report() {  # the runs that exist (the 735-scene fit runs the chosen weight only)
  local dirs=()
  for name in "${ORDER[@]}" hrc_env hrc_collision0.01 hr_collision0.01; do
    for dir in "$RUNS/$name" "$RUNS/mbm_$name"; do [[ -e "$dir/DONE" ]] && dirs+=("$dir"); done
  done
  python -m harness.report "${dirs[@]}" --out "$OUT" --force
  python -m harness.recheck "${dirs[@]}" --jobs 2 --out "$OUT"
}

main "$@"
