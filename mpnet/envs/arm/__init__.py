"""An arm as data: its model (URDF tree, limits, kinematics), inverse kinematics and its
compiled inner loop, and the sphere covering of its collision meshes.

Deliberately empty: a module here is imported by its own name."""
