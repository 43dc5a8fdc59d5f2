"""Environments. On top, the vocabulary: state spaces (spaces), robots (robots), workspaces
(workspace, shapes), an env as one object (spec), the registry that binds them per env
(specs) and OMPL's view of them (ompl_space). Below, one folder per part: checkers/ (collision
checking, its numba kernels, its compiled form), arm/ (an arm as data: model, IK, sphere
covering), scenes/ (workspace generators, point clouds, the camera) and mbm/
(MotionBenchMaker). ARCHITECTURE.md lists every module."""

from mpnet.envs.spaces import EuclideanSpace, SE2Space, StateSpace, wrap_angle
from mpnet.envs.spec import EnvSpec, TestSet
from mpnet.envs.specs import SPECS, get_spec
from mpnet.envs.workspace import Query, Workspace

__all__ = [
    "SPECS",
    "get_spec",
    "EnvSpec",
    "TestSet",
    "Query",
    "Workspace",
    "StateSpace",
    "EuclideanSpace",
    "SE2Space",
    "wrap_angle",
]
