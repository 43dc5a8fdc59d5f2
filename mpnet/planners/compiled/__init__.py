"""MPNet's planning loop compiled (planner.compiled, the default): the numba kernels that
inline the checkers' compiled form (mpnet.envs.checkers.compiled_env) and Pnet's step
(kernels), the planner built on them (planner), and batched planning (batched).

Deliberately empty: importing the package must not load numba's kernels."""
