#!/usr/bin/env bash
# Issue 42: the collision loss along Pnet's step (`networks.collision_motion`), screened at 70 scenes as
# the collision loss was (docs/research/panda_mbm_collision_screen70.sh). NeuralPlanner appends each
# proposal without checking the step to it, so with the shipped networks most failures on MBM are paths
# that stay infeasible through every replanning round (reports/panda_mbm_mbm/diagnostics.md); the
# option measures the loss's depth at m states along the step from the pair's state to the proposal.
# On top of the env's recipe (collision loss 0.01), trained on the first 70 generated scenes of
# panda_mbm's quick set; MPNet-NR as the paper runs it on the generated test split (where a recipe is
# chosen), then on MotionBenchMaker's 700 (test data: read only by the mbm_* runs). One run at a time;
# a finished run leaves DONE in its folder and is skipped.
#
#   RUNS=/work/runs/motion70 bash docs/research/panda_mbm_motion_screen70.sh [NAME ...]
#
# Its winner at the full 735 scenes (reports/archive/panda_mbm_motion/; chosen, it became the env's recipe):
#   SCENES=735 OUT=reports/archive/panda_mbm_motion RUNS=... bash docs/research/panda_mbm_motion_screen70.sh \
#     env motion4w0.04 mbm_env mbm_motion4w0.04 report
#
# NAME: a variant below, or mbm_NAME, or report (default: all, in order).
set -euo pipefail
OUT=${OUT:-reports/archive/panda_mbm_motion70}
# shellcheck source=docs/research/screen_runs.sh
source "$(dirname "$0")/screen_runs.sh"

declare -A VARIANT=(
  [env]="+planner=mpnet_nr ~env.networks.collision_motion env.networks.collision_loss=0.01"  # the env's recipe before (loss 0.01 at the proposal)
  [motion4]="+planner=mpnet_nr env.networks.collision_loss=0.01 +planner.networks.collision_motion=4"  # + its depth at 4 states along each step
  [motion4w0.04]="+planner=mpnet_nr +planner.networks.collision_motion=4 +planner.networks.collision_loss=0.04"  # the same, 4x the weight (the 4 states' sum)
)
ORDER=(env motion4 motion4w0.04)
for name in "${ORDER[@]}"; do VARIANT[mbm_$name]="${VARIANT[$name]} problems=$MBM"; done

report() {
  local dirs=()
  for name in "${ORDER[@]}"; do
    for dir in "$RUNS/$name" "$RUNS/mbm_$name"; do [[ -e "$dir/DONE" ]] && dirs+=("$dir"); done
  done
  python -m harness.report "${dirs[@]}" --out "$OUT" --force
  python -m harness.recheck "${dirs[@]}" --jobs 2 --out "$OUT"
}

main "$@"
