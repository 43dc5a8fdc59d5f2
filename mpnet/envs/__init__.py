"""Environments: state spaces, robots, workspaces and their generators, point clouds,
collision checking, and the registry that binds them per env."""

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
