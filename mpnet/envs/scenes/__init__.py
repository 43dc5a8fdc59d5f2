"""Workspaces made and seen: the workspace generators (the planar and 3D layouts, arm7's
scenes) and what the networks see of a workspace (point clouds, a depth camera's view).

Deliberately empty: a module here is imported by its own name."""
