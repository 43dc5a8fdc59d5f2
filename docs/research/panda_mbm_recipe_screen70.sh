#!/usr/bin/env bash
# Issue 42's second screen of panda_mbm's recipe options, at the learning curve's smallest size
# (the first 70 scenes of the quick set, 997 expert paths: at 70, 210 and 735 scenes the env's
# recipe solves 231, 242 and 244 of MBM's 682 valid, so the smallest size screens as well as the
# largest, at a tenth of the fit): the env's recipe as shipped, and on top of it each option not
# screened before: start/goal pairs drawn uniformly in each scene (`env.expert.pairs=uniform`; with
# `blocked_only=true` as well, arm7's: only pairs whose straight line is blocked),
# forward-only pairs (`bidirectional=false`, the public code's), Gaussian input noise (`input_noise`,
# MpiNets'), waypoints every 0.25 rad, two rounds of DAgger, and the paper's arm recipe by name (`mpnet_nr_paper`: >= 10 waypoints a path, forward
# pairs, the 9-layer Pnet on a 60-d code, unbounded, dropout 0.5). MPNet-NR as the paper runs it on the
# generated test split (68 seen + 70 unseen MBM-style queries: where a recipe is chosen), then on
# MotionBenchMaker's 700 (test data: read only by the mbm_* runs). One run at a time; a finished run
# leaves DONE in its folder and is skipped.
#
#   RUNS=/work/runs/screen70 bash docs/research/panda_mbm_recipe_screen70.sh [NAME ...]
#
# NAME: a variant below, or mbm_NAME, or report (default: all, in order).
set -euo pipefail
OUT=${OUT:-reports/archive/panda_mbm_recipes70}
# shellcheck source=docs/research/screen_runs.sh
source "$(dirname "$0")/screen_runs.sh"

declare -A VARIANT=(
  [env]="+planner=mpnet_nr"                                              # the env's recipe (shipped at 735 scenes)
  [random]="+planner=mpnet_nr_random"                                    # random valid proposals (no network)
  [uniform]="+planner=mpnet_nr env.expert.pairs=uniform"                 # + uniform start/goal pairs
  [uniform_blocked]="+planner=mpnet_nr env.expert.pairs=uniform env.expert.blocked_only=true"  # ... blocked (arm7's)
  [forward]="+planner=mpnet_nr +planner.networks.bidirectional=false"    # + forward pairs only
  [noise]="+planner=mpnet_nr +planner.networks.input_noise=0.05"         # + input noise, 0.05 rad
  [paper]="+planner=mpnet_nr_paper"                                      # the paper's arm recipe
  [fine]="+planner=mpnet_nr +planner.networks.waypoint_step=0.25"        # waypoints every 0.25 rad, not 0.5
  [dagger2]="+planner=mpnet_nr +planner.networks.dagger_rounds=2"        # two rounds of DAgger
)
ORDER=(env random uniform uniform_blocked forward noise paper fine dagger2)
for name in "${ORDER[@]}"; do VARIANT[mbm_$name]="${VARIANT[$name]} problems=$MBM"; done
# How often the first NeuralPlanner run connects on MBM (MPNet-HR's premise), for the env's and the
# paper's recipe: HR with RRT-Connect replanning, which closes the gaps a first run leaves (MPNet-HR
# proper spends the budget on RRT*'s; it gives up when the first run does not connect)
VARIANT[mbm_hrc_env]="+planner=mpnet_hr_rrtc problems=$MBM"
VARIANT[mbm_hrc_paper]="+planner=mpnet_hr_rrtc +planner.networks.recipe=paper problems=$MBM"

report() {
  local dirs=() labels=()
  for name in "${ORDER[@]}"; do
    if [[ $name == uniform* ]]; then  # env knobs, not network options: labelled so they are never pooled
      labels+=(--label "pairs_$name=$RUNS/$name" --label "pairs_$name=$RUNS/mbm_$name")
    else
      dirs+=("$RUNS/$name" "$RUNS/mbm_$name")
    fi
  done
  dirs+=("$RUNS/mbm_hrc_env" "$RUNS/mbm_hrc_paper")
  python -m harness.report "${dirs[@]}" "${labels[@]}" --out "$OUT"
  python -m harness.recheck "${dirs[@]}" "$RUNS"/uniform* "$RUNS"/mbm_uniform* --out "$OUT"
}

if [[ $# -eq 0 ]]; then
  set -- "${ORDER[@]}"
  for name in "${ORDER[@]}"; do set -- "$@" "mbm_$name"; done
  set -- "$@" mbm_hrc_env mbm_hrc_paper report
fi
stages "$@"
