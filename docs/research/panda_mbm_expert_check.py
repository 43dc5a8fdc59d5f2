"""Issue 26: panda_mbm's expert against RRT* for 500 iterations (arm7's expert, the paper's
kind) and BIT* given 1 s, on MBM-style queries of training scenes 0-27 (3 each), every cost
after lazy states contraction. Run it alone on an idle machine (BIT* is time-budgeted):

    python docs/research/panda_mbm_expert_check.py
"""

import itertools
import time

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from mpnet.data.expert_planners import rrt_connect_path, rrt_star_path
from mpnet.envs.ompl_space import make_problem
from mpnet.envs.specs import get_spec
from mpnet.motion import lazy_states_contraction, path_cost

SPEC = get_spec("panda_mbm")


def bit_star(checker, start, goal, seconds=1.0):
    si, pdef, to_tuple, keep = make_problem(SPEC, checker, start, goal)
    planner = og.BITstar(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    planner.solve(ob.timedPlannerTerminationCondition(seconds))
    if not pdef.hasExactSolution():
        return None
    return [list(to_tuple(x)) for x in pdef.getSolutionPath().getStates()]


def main() -> None:
    ou.setLogLevel(ou.LOG_WARN)
    ou.RNG.setSeed(1)
    rows = []
    for i in range(28):
        ws = SPEC.generator.make(i, "train", 0)
        checker = SPEC.make_checker(ws)
        for s, g in itertools.islice(SPEC.pairs(SPEC, ws, checker, np.random.default_rng([99, i])), 3):
            row = []
            for plan in (
                lambda c=checker, s=s, g=g: rrt_connect_path(SPEC, c, s, g, 3, 2.0),
                lambda c=checker, s=s, g=g: rrt_star_path(SPEC, c, s, g, 500, 5.0),
                lambda c=checker, s=s, g=g: bit_star(c, s, g),
            ):
                t = time.perf_counter()
                path = plan()
                seconds = time.perf_counter() - t
                row += [np.nan if path is None else path_cost(SPEC, lazy_states_contraction(checker, path)), seconds]
            rows.append(row)
    v = np.array(rows)
    expert, rrt_star, bit = v[:, 0], v[:, 2], v[:, 4]
    print(f"pairs {len(v)} (28 scenes, 4 per family)")
    solved = np.isfinite(expert).sum()
    print(f"expert (3 shortened RRT-Connect runs): solved {solved}, median {np.median(v[:, 1]):.3f} s")
    print(f"RRT* 500 iterations: solved {np.isfinite(rrt_star).sum()}, median {np.median(v[:, 3]):.3f} s")
    print(f"BIT* 1 s: solved {np.isfinite(bit).sum()}")
    for name, other in (("BIT*", bit), ("RRT*", rrt_star)):
        both = np.isfinite(expert) & np.isfinite(other)
        q = expert[both] / other[both]
        if both.any():
            print(
                f"expert / {name} cost on the {both.sum()} both solved: median {np.median(q):.3f}, "
                f"p10 {np.percentile(q, 10):.3f}, p90 {np.percentile(q, 90):.3f}, expert lower on {np.mean(q < 1):.0%}"
            )


if __name__ == "__main__":
    main()
