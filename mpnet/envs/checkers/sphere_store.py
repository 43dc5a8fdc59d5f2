"""A sphere model kept on disk between processes, beside the compiled kernels.

Building an arm's SphereModel (its spheres grouped by k-means, whose scipy import alone is
~0.5 s, and its pair tables) cost every process that checks an arm ~1.4 s: each job of a
sweep, each worker of a data build, each command. The built model is stored under
`NUMBA_CACHE_DIR/sphere_models` (where the harness keeps its kernels; without the variable
nothing is stored) and loaded by the next process in milliseconds.

A stored model is used only when its key matches: the text of every module the model is
built from (mpnet.jit.reach_digest of mpnet.envs.checkers.spheres), numpy's and scipy's
versions (scipy's k-means makes the groups), and the bytes of every file the model reads (the
robot description, its URDF, its sphere set, the meshes of its exact pairs). A file that
does not hold a model of that key in full (damaged, cut short, another key's) is built
again and replaced, never used.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import uuid
from pathlib import Path

import numpy as np

from mpnet.envs.arm.model import ArmModel
from mpnet.jit import reach_digest

FOLDER = "sphere_models"  # under NUMBA_CACHE_DIR
SOURCE = Path(__file__).with_name("spheres.py")  # the module that builds the model (its reach: the key's code)
_MAGIC = b"mpnet-sphere-model-1\n"


def model_key(model: ArmModel, description: Path) -> str:
    """The key a stored model of `model` (read from the robot description file `description`)
    must carry (see the module docstring)."""
    import scipy

    h = hashlib.sha256()
    h.update(f"{reach_digest(SOURCE)}\0numpy {np.__version__}\0scipy {scipy.__version__}\0".encode())
    hulled = {name for pair in model.exact_pairs for name in pair}
    meshes = [s.path for s in model.kinematics.shapes if s.link in hulled and s.path is not None]
    files = [description, model.urdf_path, model.spheres_path, *sorted(meshes)]
    for f in files:
        h.update(hashlib.sha256(Path(f).read_bytes()).digest())
    return h.hexdigest()


def _place() -> Path | None:
    where = os.environ.get("NUMBA_CACHE_DIR")
    return Path(where) / FOLDER if where else None


def stored(model: ArmModel, build, description: Path):
    """build(model)'s SphereModel, loaded from the store when one of this model's key is
    there, else built and stored (when there is a store). description: the robot file the
    model was read from (its `name` need not be the file's)."""
    place = _place()
    if place is None:
        return build(model)
    key = model_key(model, description)
    path = place / f"{model.name}-{key[:20]}.pkl"
    found = _load(path, key)
    if found is not None:
        found.model = model
        return found
    built = build(model)
    _save(path, key, built)
    return built


def _load(path: Path, key: str):
    """The model stored at path under `key`, or None (absent, damaged, another key's)."""
    try:
        blob = path.read_bytes()
    except OSError:
        return None
    head = len(_MAGIC) + 64 + 32
    if len(blob) < head or not blob.startswith(_MAGIC):
        return None
    stored_key = blob[len(_MAGIC) : len(_MAGIC) + 64].decode("ascii", "replace")
    digest, payload = blob[len(_MAGIC) + 64 : head], blob[head:]
    if stored_key != key or hashlib.sha256(payload).digest() != digest:
        return None
    try:
        cls, state = pickle.loads(payload)
    except (pickle.UnpicklingError, AttributeError, ImportError, EOFError, TypeError, ValueError):  # built again
        return None
    model = cls.__new__(cls)
    model.__dict__.update(state)
    return model


def _save(path: Path, key: str, model) -> None:
    """Stored whole or not at all (a temporary file renamed into place); a store that cannot
    be written is skipped (the model was built)."""
    state = {k: v for k, v in vars(model).items() if k != "model"}  # the ArmModel: the caller's, loaded afresh
    payload = pickle.dumps((type(model), state), protocol=pickle.HIGHEST_PROTOCOL)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_bytes(_MAGIC + key.encode("ascii") + hashlib.sha256(payload).digest() + payload)
        os.replace(tmp, path)
    except OSError:
        tmp.unlink(missing_ok=True)
