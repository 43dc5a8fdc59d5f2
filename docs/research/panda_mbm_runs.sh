#!/usr/bin/env bash
# Issue 26's runs, all of them, in the order they are needed: every log behind
# reports/panda_mbm_mbm/ (MotionBenchMaker's 700), reports/panda_mbm/ (the generated split) and
# reports/panda_mbm_learning_curve/, then the three reports. Resumable: a finished run leaves
# DONE in its folder and is skipped; a killed one continues with resume=true (the harness
# refuses a resume with another config). Run it alone on an idle machine (the figures are
# times); stages take minutes (MPNet-NR on the 700) to hours (Informed-RRT* on the 700).
#
#   RUNS=/work/runs/issue26 MBM=data/mbm/problems bash docs/research/panda_mbm_runs.sh [STAGE ...]
#
# STAGE: train, mbm, gen, lc, bit_star, dense, hr, informed_first10, informed, report (default: all,
# in order).
set -euo pipefail
RUNS=${RUNS:?RUNS=folder for the logs}
MBM=${MBM:?MBM=MotionBenchMaker problems folder (python -m harness.fetch_mbm DEST)}
FIRST10="$RUNS/problems_first10"   # the first 10 problems of each of the 7 sets (70)
mkdir -p "$RUNS"

run() {  # run NAME ARGS...: one logged harness run into $RUNS/NAME, skipped once DONE
  local name=$1 dir="$RUNS/$1"
  shift
  [[ -e "$dir/DONE" ]] && return 0
  echo "$(date -u +%FT%TZ) $name" >&2
  python -m harness +env=panda_mbm "$@" hydra.run.dir="$dir" resume=true progress=false
  touch "$dir/DONE"
}

sweep() {  # sweep NAME ARGS...: a multirun into $RUNS/NAME, skipped once DONE
  local name=$1 dir="$RUNS/$1"
  shift
  [[ -e "$dir/DONE" ]] && return 0
  echo "$(date -u +%FT%TZ) $name" >&2
  python -m harness "$@" hydra.sweep.dir="$dir" resume=true progress=false
  touch "$dir/DONE"
}

first10() {  # the first ten requests (and their scenes) of each set, linked
  [[ -e "$FIRST10" ]] && return 0
  local tmp="$FIRST10.tmp"
  rm -rf "$tmp"
  for set in "$MBM"/*/; do
    local s
    s=$(basename "$set")
    mkdir -p "$tmp/$s"
    for i in $(seq -f %04g 1 10); do
      ln -s "$(realpath "$set/request$i.yaml")" "$tmp/$s/request$i.yaml"
      ln -s "$(realpath "$set/scene$i.yaml")" "$tmp/$s/scene$i.yaml"
    done
  done
  mv "$tmp" "$FIRST10"
}

stage_train() {
  python -m harness.data +env=panda_mbm scale=quick progress=false
  python -m harness.train +env=panda_mbm scale=quick progress=false
}

stage_mbm() {  # MBM's 700: the quick MPNet planners, the baselines that cost minutes
  for p in mpnet_nr mpnet_nr_clip mpnet_nr_random mpnet_hr_rrtc mpnet_hr_rrtc_clip rrt_connect \
    bit_star_to_nr_x1.1 bit_star_to_nr_x1.4; do
    run "mbm_$p" +planner=$p problems="$MBM"
  done
}

stage_gen() {  # the generated split (70 seen + 70 unseen)
  for p in mpnet_nr mpnet_nr_clip mpnet_nr_random mpnet_hr_rrtc mpnet_hr_rrtc_clip rrt_connect \
    bit_star; do
    run "gen_$p" +planner=$p
  done
}

stage_lc() {  # the learning curve, on the generated split and on MBM's 700 (the sizes whose networks
  # exist: 3,570 scenes need their dataset and hours of training first)
  local sizes='scale.train.workspaces=70,210,735'
  sweep lc_gen +experiment=panda_mbm_learning_curve scale=quick "$sizes"
  sweep lc_mbm +experiment=panda_mbm_learning_curve scale=quick "$sizes" problems="$MBM"
}

stage_bit_star() {
  run mbm_bit_star +planner=bit_star problems="$MBM"
}

stage_dense() {  # the resampled-path networks (a long training), then their runs
  python -m harness.train +env=panda_mbm +planner=mpnet_nr_dense progress=false
  for p in mpnet_nr_dense mpnet_nr_dense_clip; do
    run "mbm_$p" +planner=$p problems="$MBM"
    run "gen_$p" +planner=$p
  done
}

stage_hr() {  # the paper's HR (RRT* replanning) on both; its clipped variant on the first 10 of each set
  first10
  run gen_mpnet_hr +planner=mpnet_hr
  run mbm_mpnet_hr +planner=mpnet_hr problems="$MBM"
  run mbm_mpnet_hr_clip_first10 +planner=mpnet_hr_clip problems="$FIRST10"
}

stage_informed_first10() {  # Informed-RRT* on the first 10 of each set (an hour less than all 700)
  first10
  for p in informed_rrt_star informed_rrt_star_to_nr_x1.1 informed_rrt_star_to_nr_x1.4; do
    run "mbm_${p}_first10" +planner=$p problems="$FIRST10"
  done
}

stage_informed() {  # Informed-RRT* on all 700 (each query runs the whole budget), and to NR's cost
  for p in informed_rrt_star informed_rrt_star_to_nr_x1.1 informed_rrt_star_to_nr_x1.4; do
    run "mbm_$p" +planner=$p problems="$MBM"
  done
}

stage_report() {
  local mbm=() gen=()
  for d in "$RUNS"/mbm_*/; do [[ -e "$d/DONE" && $d != *first10* ]] && mbm+=("$d"); done
  for d in "$RUNS"/mbm_*first10/; do [[ -e "$d/DONE" ]] && mbm+=(--label "first10=$d"); done
  for d in "$RUNS"/gen_*/; do [[ -e "$d/DONE" ]] && gen+=("$d"); done
  python -m harness.report "${mbm[@]}" --out reports/panda_mbm_mbm
  python -m harness.report "${gen[@]}" --out reports/panda_mbm
  python -m harness.report.learning_curve "$RUNS/lc_gen" "$RUNS/lc_mbm" --out reports/panda_mbm_learning_curve
}

stages=("$@")
[[ ${#stages[@]} -gt 0 ]] || stages=(train mbm gen lc bit_star dense hr informed_first10 informed report)
for s in "${stages[@]}"; do
  "stage_$s"
done
