#!/usr/bin/env bash
# Issue 42's screen of panda_mbm's recipe options: each option's networks trained on the first
# 210 scenes of the quick set (2,980 expert paths, the learning curve's middle size), then
# MPNet-NR (the paper's: dropout on, original replanning, no clipping) on the generated test
# split (68 seen + 70 unseen MBM-style queries; MotionBenchMaker's problems are not read), then
# the report. One run at a time; a finished run leaves DONE in its folder and is skipped.
# Run at a revision with issue 42's order-free scene code (branch issue42-order and its
# descendants until the shipped networks are retrained): reports/archive/panda_mbm_recipes/ was made at
# cd42f39 (branch issue42-recipe).
#
#   RUNS=/work/runs/screen bash docs/research/panda_mbm_recipe_screen.sh [NAME ...]
#
# NAME: a variant below, or mbm_NAME (the same on MotionBenchMaker's 700), or report (default:
# all, in order).
set -euo pipefail
RUNS=${RUNS:?RUNS=folder for the logs}
OUT=${OUT:-reports/archive/panda_mbm_recipes}
mkdir -p "$RUNS"
COMMON=(+env=panda_mbm scale=quick scale.train.workspaces=210 +planner=mpnet_nr progress=false)
B=+planner.networks.bounded=true
DENSE=(+planner.networks.waypoint_step=0.5 +planner.networks.equal_steps=true)

MBM=${MBM:-data/mbm/problems}   # python -m harness.fetch_mbm data/mbm: test data, read only by the mbm_* runs
BW="$B ${DENSE[*]}"
declare -A VARIANT=(
  [base]=""                                                       # the recipe as it is (the order fix only)
  [b]="$B"                                                        # Pnet's output bounded
  [bw]="$BW"                                                      # ... on expert paths resampled at 0.5 rad
  [bwD]="$BW +planner.networks.dagger_rounds=1"                   # ... and one DAgger round
  [bz]="planner.name=mpnet_nr_zeros planner.encoding=zeros $B"   # b's networks given a zero scene code
  [br]="planner.name=mpnet_nr_random planner.proposal=random"     # random proposals (no network)
  [bwd]="$BW +planner.networks.dropout=0.1"                       # ... dropout 0.1 instead of 0.5
)
ORDER=(b bw base bwD bz br bwd)
# MotionBenchMaker's 700 for the recipe as it is, random proposals and every screened recipe
# (chosen on the generated split above; these only report how the choice fares on MBM)
for name in base bw br bwd b bwD; do VARIANT[mbm_$name]="${VARIANT[$name]} problems=$MBM"; done
MBM_ORDER=(mbm_base mbm_bw mbm_br mbm_bwd mbm_b mbm_bwD)

run() {  # run NAME: one logged run into $RUNS/NAME (its networks trained first), skipped once DONE
  local name=$1 dir="$RUNS/$1"
  [[ -e "$dir/DONE" ]] && return 0
  echo "$(date -u +%FT%TZ) $name" >&2
  # shellcheck disable=SC2086  # the variant's overrides are words
  python -m harness "${COMMON[@]}" ${VARIANT[$name]} hydra.run.dir="$dir" resume=true
  touch "$dir/DONE"
}

report() {
  local dirs=()
  for name in "${ORDER[@]}" "${MBM_ORDER[@]}"; do dirs+=("$RUNS/$name"); done
  python -m harness.report "${dirs[@]}" --out "$OUT"
  python -m harness.recheck "${dirs[@]}" --out "$OUT"
}

[[ $# -gt 0 ]] || set -- "${ORDER[@]}" "${MBM_ORDER[@]}" report
for stage in "$@"; do
  if [[ $stage == report ]]; then report; else run "$stage"; fi
done
