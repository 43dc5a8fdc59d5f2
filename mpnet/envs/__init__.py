"""Workspaces, their generators and collision checking."""
from mpnet.envs.specs import SPECS, get_spec
from mpnet.envs.workspace import EnvSpec, Query, TestSet, Workspace, wrap_angle

__all__ = ["SPECS", "get_spec", "EnvSpec", "Query", "TestSet", "Workspace", "wrap_angle"]
