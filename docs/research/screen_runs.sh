# Sourced by the 70-scene screens (panda_mbm_recipe_screen70.sh, panda_mbm_collision_screen70.sh,
# panda_mbm_motion_screen70.sh):
# `run NAME` makes one logged run of the caller's VARIANT[NAME] (with its COMMON overrides) into
# $RUNS/NAME, its networks trained first; a finished run leaves DONE in its folder and is skipped.
# `stages NAME...` runs each NAME, or the caller's report() for `report`; `main` with no NAME runs
# every variant of the caller's ORDER, then their mbm_ runs, then report. RUNS: the logs' folder;
# SCENES: training scenes (default 70; the quick set's 735 for a screen's winner); CACHE (default
# $RUNS/cache); MBM: MotionBenchMaker's problems (python -m harness.fetch_mbm data/mbm).

RUNS=${RUNS:?RUNS=folder for the logs}
CACHE=${CACHE:-$RUNS/cache}
MBM=${MBM:-data/mbm/problems}
mkdir -p "$RUNS"
COMMON=(+env=panda_mbm scale=quick "scale.train.workspaces=${SCENES:-70}" progress=false "cache_dir=$CACHE")

run() {  # run NAME: one logged run into $RUNS/NAME (its networks trained first), skipped once DONE
  local name=$1 dir="$RUNS/$1"
  [[ -e "$dir/DONE" ]] && return 0
  echo "$(date -u +%FT%TZ) $name" >&2
  # shellcheck disable=SC2086  # the variant's overrides are words
  python -m harness "${COMMON[@]}" ${VARIANT[$name]} seed=0 hydra.run.dir="$dir" resume=true
  touch "$dir/DONE"
}

main() {  # the caller's NAMEs, or every variant of ORDER, their mbm_ runs, then report
  if [[ $# -eq 0 ]]; then
    set -- "${ORDER[@]}"
    for name in "${ORDER[@]}"; do set -- "$@" "mbm_$name"; done
    set -- "$@" report
  fi
  stages "$@"
}

stages() {
  for stage in "$@"; do
    if [[ $stage == report ]]; then report; else run "$stage"; fi
  done
}
