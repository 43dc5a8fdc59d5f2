"""Collision checkers: CollisionChecker's interface and the point, rigid-body, sphere and
pybullet (the arm's judge) checkers, their numba kernels, and their compiled form for the
compiled planner (compiled_env).

Deliberately empty: importing a checker module must not load the others, their kernels
(loaded with the first checker) or, through mpnet.jit's reach, widen a kernel's stamp."""
