"""A sphere model kept on disk between processes, beside the compiled kernels.

Building an arm's SphereModel (its spheres grouped by k-means, whose scipy import alone is
~0.5 s, and its pair tables) cost every process that checks an arm ~1.4 s: each job of a
sweep, each worker of a data build, each command. The built model is stored under
`NUMBA_CACHE_DIR/sphere_models` (where the harness keeps its kernels; without the variable
nothing is stored) and loaded by the next process in milliseconds.

A stored model is used only when its key matches what this build would read: the text of
every module it is built from (mpnet.jit.reach_digest of mpnet.envs.checkers.spheres), numpy's,
scipy's and numba's versions, the arm model as parsed (every field, its kinematics' arrays),
and the bytes of its sphere set and of its exact pairs' meshes (the sphere set is read once,
for the key and the build). A process whose copy of those modules may differ from the files
(one changed since the process imported them) neither loads nor stores. A file that does not
hold a model of its key in full (damaged, cut short, another key's) is built again and
replaced, never used.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import pickle
import re
import time
import uuid
from pathlib import Path

import numpy as np

from mpnet.envs.arm.model import ArmModel
from mpnet.jit import reach, reach_digest

FOLDER = "sphere_models"  # under NUMBA_CACHE_DIR
SOURCE = Path(__file__).with_name("spheres.py")  # the module that builds the model (its reach: the key's code)
_MAGIC = b"mpnet-sphere-model-2\n"
# when this module was imported (with spheres.py, which imports it first thing): a module of
# SOURCE's reach changed after it (less a second of margin) may not be the code that runs
_IMPORTED = time.time() - 1.0


def _canonical(x, h) -> None:
    """Feed x's content to hash h, the same for the same content in any process (sets and
    dicts in sorted order, arrays by dtype, shape and bytes, floats by their exact repr)."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        h.update(f"<{type(x).__name__}".encode())
        for f in dataclasses.fields(x):
            h.update(f"{f.name}=".encode())
            _canonical(getattr(x, f.name), h)
        h.update(b">")
    elif isinstance(x, np.ndarray):
        h.update(f"array {x.dtype} {x.shape}".encode() + np.ascontiguousarray(x).tobytes())
    elif isinstance(x, dict):
        h.update(f"dict {len(x)}".encode())
        for k in sorted(x, key=repr):
            _canonical(k, h)
            _canonical(x[k], h)
    elif isinstance(x, (set, frozenset)):
        h.update(f"set {len(x)}".encode())
        for v in sorted(x, key=repr):
            _canonical(v, h)
    elif isinstance(x, (list, tuple)):
        h.update(f"seq {len(x)}".encode())
        for v in x:
            _canonical(v, h)
    elif isinstance(x, (str, int, float, bool, type(None), Path, np.generic)):
        h.update(f"{type(x).__name__} {x!r};".encode())
    else:
        raise TypeError(f"no canonical form for {type(x).__name__}")


def model_key(model: ArmModel, spheres: bytes) -> str:
    """The key a stored model of `model` with this sphere set (its file's bytes) must carry."""
    import numba
    import scipy

    h = hashlib.sha256()
    h.update(f"{reach_digest(SOURCE)}\0{np.__version__}\0{scipy.__version__}\0{numba.__version__}\0".encode())
    _canonical(model, h)
    h.update(hashlib.sha256(spheres).digest())
    hulled = {name for pair in model.exact_pairs for name in pair}
    for path in sorted(str(s.path) for s in model.kinematics.shapes if s.link in hulled and s.path is not None):
        h.update(hashlib.sha256(Path(path).read_bytes()).digest())
    return h.hexdigest()


def _code_changed() -> bool:
    """Has a module the model is built from changed since this process imported it?"""
    for p in reach(SOURCE):
        st = p.stat()
        if max(st.st_mtime, st.st_ctime) > _IMPORTED:
            return True
    return False


def stored(model: ArmModel, build):
    """build(model, doc)'s SphereModel (doc: the sphere set's JSON), loaded from the store when
    one of its key is there, else built and stored (when there is a store, and the code that
    runs is the code on disk). Without a sphere set, build(model, None) says what is missing."""
    where = os.environ.get("NUMBA_CACHE_DIR")
    path = model.spheres_path
    if not where or path is None:
        return build(model, None)
    if _code_changed():
        return build(model, None)
    spheres = path.read_bytes()
    doc = json.loads(spheres.decode("utf-8"))
    key = model_key(model, spheres)
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", model.name)
    file = Path(where) / FOLDER / f"{name}-{key[:20]}.pkl"
    found = _load(file, key)
    if found is not None:
        found.model = model
        return found
    built = build(model, doc)
    _save(file, key, built)
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
