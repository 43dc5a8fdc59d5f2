"""Classical search compiled on an env's compiled checks (numba): RRT-Connect, which the
named planner `rrt_connect_compiled` and the compiled expert both run. Below mpnet.data (the
expert plans with it) and above mpnet.envs (it calls the checkers' compiled forms)."""
