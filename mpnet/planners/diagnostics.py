"""What Pnet proposed during one MPNet query, and how good it was: the figures behind
"why MPNet succeeds or fails". Computed after the query's time is taken, with a checker of
its own (exact boxes, no margin), so neither the time nor the collision counts of the
query change.

- proposals: every Pnet call, by stage (0: the first NeuralPlanner run; k: replanning
  round k), with the tree end it grew from; the states go into the log so that every
  share below can be recomputed from trials.mcap alone.
- in collision: the proposal is not a valid state (inside an obstacle or out of bounds;
  out of bounds also counted on its own); reachable: a free straight motion joins the
  tree end to it.
- first proposal: valid; visible from the start (the tree end it grew from); the goal
  visible from it.
- code sensitivity: how far Pnet's deterministic output (dropout off) at (start, goal)
  moves when the workspace code is swapped for another workspace's (the last other one
  this planner encoded; None for its first workspace), against the median distance of
  its dropout samples from that output (`dropout_spread`, DROPOUT_SAMPLES draws). Both
  in the env's metric.
"""

from __future__ import annotations

import numpy as np

DROPOUT_SAMPLES = 8


def query_diagnostics(planner, problem) -> dict:
    """The diagnostics of planner's last solve on problem (an MPNetPlanner)."""
    spec, ws = problem.spec, problem.workspace
    trace = planner.trace
    out: dict = {
        "proposals": len(trace),
        "proposals_first": sum(1 for stage, _, _ in trace if stage == 0),
    }
    out["proposals_replan"] = out["proposals"] - out["proposals_first"]
    if trace:
        checker = spec.make_checker(ws, margin=0.0)
        stages = [int(stage) for stage, _, _ in trace]
        src = np.array([np.asarray(x, float) for _, x, _ in trace])
        prop = np.array([np.asarray(p, float) for _, _, p in trace])
        valid = checker.states_valid(prop)
        reach = checker.motions_valid(src, prop)
        inside = np.array([spec.in_bounds(p) for p in prop])
        first = int(np.flatnonzero(np.array(stages) == 0)[0]) if 0 in stages else None
        out.update(
            proposals_in_collision=int((~valid).sum()),
            proposals_out_of_bounds=int((~inside).sum()),
            proposals_reachable=int(reach.sum()),
        )
        if first is not None:
            out.update(
                first_valid=bool(valid[first]),
                first_visible_from_start=bool(reach[first]),
                first_visible_to_goal=bool(checker.motion_valid(prop[first].tolist(), problem.goal.tolist())),
            )
        out["trace"] = {"stage": stages, "from": src.tolist(), "proposal": prop.tolist()}
    out.update(code_sensitivity(planner, problem))
    return out


def code_sensitivity(planner, problem) -> dict:
    """code_shift and dropout_spread at the query's (start, goal); remembers this
    workspace's code for the next query."""
    z = planner.last_code
    if z is None or planner.step is None:
        return {}
    ws_id = problem.workspace.id
    others = [k for k in planner.codes if k != ws_id]
    planner.codes.pop(ws_id, None)
    planner.codes[ws_id] = z  # most recent last
    spec = problem.spec
    start, goal = problem.start.astype(float), problem.goal.astype(float)
    mean = np.asarray(planner.step(z, start, goal, None), float)
    rng = np.random.default_rng(0)
    samples = [np.asarray(planner.step(z, start, goal, rng), float) for _ in range(DROPOUT_SAMPLES)]
    out = {"dropout_spread": float(np.median([spec.distance(mean, s) for s in samples]))}
    if others:
        other = np.asarray(planner.step(planner.codes[others[-1]], start, goal, None), float)
        out["code_shift"] = float(spec.distance(mean, other))
    return out
