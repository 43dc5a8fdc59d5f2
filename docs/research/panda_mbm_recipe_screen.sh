#!/usr/bin/env bash
# Issue 42's screen of panda_mbm's recipe options: each option's networks trained on the first
# 210 scenes of the quick set (2,980 expert paths, the learning curve's middle size), then
# MPNet-NR (the paper's: dropout on, original replanning, no clipping) on the generated test
# split (68 seen + 70 unseen MBM-style queries; MotionBenchMaker's problems are not read), then
# the report. One run at a time; a finished run leaves DONE in its folder and is skipped.
#
#   RUNS=/work/runs/screen bash docs/research/panda_mbm_recipe_screen.sh [NAME ...]
#
# NAME: a variant below (default: all, in order), or report.
set -euo pipefail
RUNS=${RUNS:?RUNS=folder for the logs}
OUT=${OUT:-reports/panda_mbm_recipes}
mkdir -p "$RUNS"
COMMON=(+env=panda_mbm scale=quick scale.train.workspaces=210 +planner=mpnet_nr progress=false)
B=+planner.networks.bounded=true
DENSE=(+planner.networks.waypoint_step=0.5 +planner.networks.equal_steps=true)

declare -A VARIANT=(
  [base]=""
  [b]="$B"
  [bw]="$B ${DENSE[*]}"
  [bwD]="$B ${DENSE[*]} +planner.networks.dagger_rounds=1"
  [bwd]="$B ${DENSE[*]} +planner.networks.dropout=0.1"
  [bz]="planner.name=mpnet_nr_zeros planner.encoding=zeros $B"   # b's networks given a zero scene code
  [br]="planner.name=mpnet_nr_random planner.proposal=random"     # random proposals (no network)
)
ORDER=(b bw base bwD bwd bz br)

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
  for name in "${ORDER[@]}"; do dirs+=("$RUNS/$name"); done
  python -m harness.report "${dirs[@]}" --out "$OUT"
  python -m harness.recheck "${dirs[@]}" --out "$OUT"
}

[[ $# -gt 0 ]] || set -- "${ORDER[@]}" report
for stage in "$@"; do
  if [[ $stage == report ]]; then report; else run "$stage"; fi
done
