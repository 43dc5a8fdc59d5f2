"""Read a checkpoint that ``torch.save`` wrote (its zip format) into numpy arrays, without torch.

A planning run needs only the networks' weights, and importing torch costs it ~1.5 s. The
format is small and stable: ``<name>/data.pkl`` pickles the object, each tensor as
``torch._utils._rebuild_tensor_v2(storage, offset, size, stride, ...)`` whose storage is the
raw little-endian bytes of ``<name>/data/<key>``. Written by hand because no library reads it
without torch; like ``torch.load(weights_only=True)`` it builds nothing but containers and
tensors (any other global is refused), and the tests check it against torch.load on every
checkpoint kind we write.
"""

from __future__ import annotations

import collections
import os
import pickle
import zipfile

import numpy as np

# torch's storage classes -> numpy dtypes (the ones a float/int checkpoint can hold)
_DTYPES = {
    "FloatStorage": np.float32,
    "DoubleStorage": np.float64,
    "HalfStorage": np.float16,
    "LongStorage": np.int64,
    "IntStorage": np.int32,
    "ShortStorage": np.int16,
    "CharStorage": np.int8,
    "ByteStorage": np.uint8,
    "BoolStorage": np.bool_,
}


class _Storage:
    def __init__(self, dtype):
        self.dtype = dtype


def _rebuild_tensor(storage: np.ndarray, offset: int, size, stride, *_ignored) -> np.ndarray:
    """The tensor's elements as a C-contiguous array of their own."""
    if not size:
        return np.array(storage[offset])
    item = storage.itemsize
    view = np.lib.stride_tricks.as_strided(
        storage[offset:], shape=tuple(size), strides=tuple(s * item for s in stride), writeable=False
    )
    return np.ascontiguousarray(view)


class _Unpickler(pickle.Unpickler):
    def __init__(self, file, archive: zipfile.ZipFile, prefix: str):
        super().__init__(file)
        self._archive, self._prefix, self._storages = archive, prefix, {}

    def find_class(self, module: str, name: str):
        if (module, name) == ("collections", "OrderedDict"):
            return collections.OrderedDict
        if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
            return _rebuild_tensor
        if module == "torch" and name in _DTYPES:
            return _Storage(_DTYPES[name])
        raise pickle.UnpicklingError(f"global {module}.{name} is not a tensor or container")

    def persistent_load(self, pid):
        kind, storage, key, _location, numel = pid
        if kind != "storage" or not isinstance(storage, _Storage):
            raise pickle.UnpicklingError(f"unsupported persistent id {pid[:2]!r}")
        if key not in self._storages:
            raw = self._archive.read(f"{self._prefix}data/{key}")
            arr = np.frombuffer(raw, dtype=np.dtype(storage.dtype).newbyteorder("<"))
            if arr.size < numel:
                raise ValueError(f"storage {key} holds {arr.size} elements, {numel} expected")
            self._storages[key] = arr.astype(storage.dtype, copy=False)
        return self._storages[key]


def load(path: str | os.PathLike) -> object:
    """The object a zip-format ``torch.save`` wrote, tensors as numpy arrays. Raises what a
    damaged file raises (OSError, zipfile.BadZipFile, KeyError, ValueError, EOFError,
    pickle.UnpicklingError)."""
    with zipfile.ZipFile(path) as archive:
        pkl = next((n for n in archive.namelist() if n.endswith("/data.pkl") and n.count("/") == 1), None)
        if pkl is None:
            raise KeyError("data.pkl")
        prefix = pkl[: -len("data.pkl")]
        if prefix + "byteorder" in archive.namelist() and archive.read(prefix + "byteorder") != b"little":
            raise ValueError("a big-endian checkpoint")
        with archive.open(pkl) as f:
            return _Unpickler(f, archive, prefix).load()
