"""MPNet (Qureshi et al., ICRA 2019) as a plain library: envs, motion primitives, planners."""
