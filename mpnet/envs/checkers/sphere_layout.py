"""The sphere model's packed layout, written once: the fields the kernels read (MODEL) and
the scratch they write (SCRATCH), in the order of the tuples the kernels index.

Why packed: the kernels take a model as two arrays (mi, int64; mf, float64) and its scratch
as one (two or three arguments dispatch from Python in well under a microsecond, a tuple
of 27 does not). From the tables follow the packing (`pack`, which also gives the scratch's
length), each field's index in the kernels' tuples (PARENT, ..., module constants: numba
freezes globals when it compiles) and the views (`unpack`, `unpack_buffers`). mi starts with
a header that gives each field its start, end and shape, so the views read the layout the
packing wrote; numba builds a tuple of views only from code that names each one, so the
view kernels are generated from the tables (as dataclasses writes `__init__`), under this
file's name: mpnet.jit's cache stamps them with its text.

A shape is a tuple of sizes: a number, or an expression in the model's counts (F frames,
L links, G groups, S spheres, P self-collision pairs, D joints, T pair tables, W entries of
the tables' summed counts, V hull vertices), each count read from the first MODEL field whose shape names it alone.
"""

from __future__ import annotations

from math import prod
from typing import NamedTuple

import numpy as np

from mpnet.jit import njit

QUEUE = 1 << 14  # motion intervals pending at once; a motion that needs more is called blocked
INTS, FLOATS, BUF = "mi", "mf", "buf"  # the packed arrays, by the kernels' argument names


class Field(NamedTuple):
    name: str  # SphereModel's attribute (MODEL), a scratch view's name (SCRATCH)
    packed: str  # INTS, FLOATS or BUF
    shape: tuple  # () for a number


MODEL: list[Field] = []
SCRATCH: list[Field] = []


def _field(table: list[Field], name: str, packed: str, *shape) -> int:
    """Appends a field; its index in the kernels' tuple."""
    table.append(Field(name, packed, shape))
    return len(table) - 1


# Frames in parent-before-child order; a three-level sphere tree: links (a bounding sphere,
# a range of groups), groups (a bounding sphere, a range of spheres), spheres; the pairs of
# links that may not touch; levers (how far a link's or group's centre moves per unit of
# each joint); the pair tables (SphereModel._build_tables); the pairs tested on their hulls
# and the hulls' vertices, link by link (SphereModel._hulls, hull_kernels). first: how many links (the first
# ones) never move (tested against obstacles once, SphereChecker._base_blocked).
PARENT = _field(MODEL, "parent", INTS, "F")
ORIGIN = _field(MODEL, "origin", FLOATS, "F", 3, 4)
KIND = _field(MODEL, "kind", INTS, "F")
AXIS = _field(MODEL, "axis", FLOATS, "F", 3)
COORD = _field(MODEL, "coord", INTS, "F")
LINK_FRAME = _field(MODEL, "link_frame", INTS, "L")
LINK_G0 = _field(MODEL, "link_g0", INTS, "L")
LINK_G1 = _field(MODEL, "link_g1", INTS, "L")
GROUP_FRAME = _field(MODEL, "group_frame", INTS, "G")
GROUP_S0 = _field(MODEL, "group_s0", INTS, "G")
GROUP_S1 = _field(MODEL, "group_s1", INTS, "G")
LOCAL = _field(MODEL, "local", FLOATS, "S", 3)
RADIUS = _field(MODEL, "radius", FLOATS, "S")
BLOCAL = _field(MODEL, "blocal", FLOATS, "L", 3)
BRADIUS = _field(MODEL, "bradius", FLOATS, "L")
GLOCAL = _field(MODEL, "glocal", FLOATS, "G", 3)
GRADIUS = _field(MODEL, "gradius", FLOATS, "G")
PAIR_A = _field(MODEL, "pair_a", INTS, "P")
PAIR_B = _field(MODEL, "pair_b", INTS, "P")
FIRST = _field(MODEL, "first", INTS)
LLEVER = _field(MODEL, "llever", FLOATS, "L", "D")
GLEVER = _field(MODEL, "glever", FLOATS, "G", "D")
PAIR_J0 = _field(MODEL, "pair_j0", INTS, "P")
PAIR_TABLE = _field(MODEL, "pair_table", INTS, "P")
TABLE_I = _field(MODEL, "table_i", INTS, "T", 5)
TABLE_F = _field(MODEL, "table_f", FLOATS, "T", 4)
TABLE_SUM = _field(MODEL, "table_sum", INTS, "W")
PAIR_EXACT = _field(MODEL, "pair_exact", INTS, "P")
LINK_H0 = _field(MODEL, "link_h0", INTS, "L")
LINK_H1 = _field(MODEL, "link_h1", INTS, "L")
LINK_HR = _field(MODEL, "link_hr", FLOATS, "L")
HULL = _field(MODEL, "hull", FLOATS, "V", 3)
LNJ = _field(MODEL, "lnj", INTS, "L")  # the joints that move a link's frame: coordinates 0 .. lnj - 1
GNJ = _field(MODEL, "gnj", INTS, "G")  # a group's
BOUND = _field(MODEL, "bound", INTS)  # the motion bound: sphere_bounds.LEVER or SWEPT

# Scratch: poses (pose[F] is forward's spare); sphere, link and group centres; link and group
# placed flags; link and group growth; a joint vector and the motion's joint steps; the
# joints' axes (points, directions, prismatic flags); the largest growth; the motion queue's
# interval ends; a pair's groups' growth; the bounds' terms (sphere_bounds): LEVER's second
# order and each link's and group's speed per joint in the current interval (which
# growth_from reads back), SWEPT's signed steps, second order and growth per first joint.
POSE = _field(SCRATCH, "pose", BUF, "F + 1", 3, 4)
CENTRES = _field(SCRATCH, "centres", BUF, "S", 3)
LCENTRES = _field(SCRATCH, "lcentres", BUF, "L", 3)
GCENTRES = _field(SCRATCH, "gcentres", BUF, "G", 3)
LPLACED = _field(SCRATCH, "lplaced", BUF, "L")
GPLACED = _field(SCRATCH, "gplaced", BUF, "G")
LEXTRA = _field(SCRATCH, "lextra", BUF, "L")
GEXTRA = _field(SCRATCH, "gextra", BUF, "G")
QVEC = _field(SCRATCH, "q", BUF, "D")
DQ = _field(SCRATCH, "dq", BUF, "D")
AXPOINT = _field(SCRATCH, "ap", BUF, "D", 3)
AXDIR = _field(SCRATCH, "au", BUF, "D", 3)
PRIS = _field(SCRATCH, "pris", BUF, "D")
TOP = _field(SCRATCH, "top", BUF, 1)
T0S = _field(SCRATCH, "t0s", BUF, QUEUE)
T1S = _field(SCRATCH, "t1s", BUF, QUEUE)
PG = _field(SCRATCH, "pg", BUF, "G")
LB = _field(SCRATCH, "lb", BUF, "L")
GB = _field(SCRATCH, "gb", BUF, "G")
LSPEED = _field(SCRATCH, "lspeed", BUF, "L", "D")
GSPEED = _field(SCRATCH, "gspeed", BUF, "G", "D")
SDQ = _field(SCRATCH, "sdq", BUF, "D")
LA = _field(SCRATCH, "la", BUF, "L", "D")
GA = _field(SCRATCH, "ga", BUF, "G", "D")
# SWEPT's growth from each joint on: column j0 < nj written by each growing verdict; the others,
# column D too (a pair with no joint between its links), are never written and stay 0
LREL = _field(SCRATCH, "lrel", BUF, "L", "D + 1")
GREL = _field(SCRATCH, "grel", BUF, "G", "D + 1")

# mi's header: each field's start, end and sizes, MODEL's then SCRATCH's
_SLOTS = np.cumsum([0] + [2 + len(f.shape) for f in MODEL + SCRATCH]).tolist()
HEAD = _SLOTS[-1]


def _counts(model) -> dict[str, int]:
    """The model's counts, each read off the first field that names it as a size (pack then
    checks every other field against it)."""
    counts: dict[str, int] = {}
    for f in MODEL:
        for size, n in zip(f.shape, np.shape(getattr(model, f.name))):
            if isinstance(size, str) and size.isidentifier():
                counts.setdefault(size, n)
    return counts


def _size(size: int | str, counts: dict[str, int]) -> int:
    """A size of the table (a number, or an expression in the counts such as "F + 1")."""
    return size if isinstance(size, int) else int(eval(size, {"__builtins__": {}}, counts))


def pack(model) -> tuple[np.ndarray, np.ndarray, int]:
    """(mi, mf, the scratch's length) of a model whose attributes MODEL names; a field whose
    shape disagrees with the table (or with another field's count) is a ValueError."""
    counts = _counts(model)
    head: list[int] = []
    parts: dict[str, list[np.ndarray]] = {INTS: [], FLOATS: [], BUF: []}
    at = {INTS: HEAD, FLOATS: 0, BUF: 0}
    for f in MODEL + SCRATCH:
        shape = tuple(_size(s, counts) for s in f.shape)
        if f.packed != BUF:
            a = np.asarray(getattr(model, f.name))
            if a.shape != shape:
                raise ValueError(f"sphere model field {f.name}: shape {a.shape}, the layout says {shape}")
            parts[f.packed].append(a.ravel())
        head += [at[f.packed], at[f.packed] + prod(shape), *shape]
        at[f.packed] += prod(shape)
    mi = np.concatenate([np.array(head), *parts[INTS]]).astype(np.int64)
    return mi, np.concatenate(parts[FLOATS]).astype(np.float64), at[BUF]


def _view(f: Field, slot: int) -> str:
    """The source of one field's view: its slice of the packed array, shaped."""
    if not f.shape:
        return f"{f.packed}[mi[{slot}]]"
    flat = f"{f.packed}[mi[{slot}] : mi[{slot + 1}]]"
    if len(f.shape) == 1:
        return flat
    return f"{flat}.reshape(({', '.join(f'mi[{slot + 2 + i}]' for i in range(len(f.shape)))}))"


def _views(name: str, args: str, fields: list[Field], slots: list[int], doc: str, borrowed: bool):
    """A kernel returning the tuple of `fields`' views, generated from the table."""
    body = ",\n        ".join(_view(f, s) for f, s in zip(fields, slots))
    namespace = {"__name__": __name__}
    exec(compile(f"def {name}({args}):\n    return (\n        {body},\n    )\n", __file__, "exec"), namespace)
    func = namespace[name]
    func.__doc__ = doc
    return njit(cache=True, borrowed=borrowed)(func)


# The kernels' views are borrowed (mpnet.jit: no reference counts), so only borrowed kernels
# may call them; Python and counting kernels read the same views through the *_views twins.
_MODEL_SLOTS, _SCRATCH_SLOTS = _SLOTS[: len(MODEL)], _SLOTS[len(MODEL) : -1]
unpack = _views("unpack", "mi, mf", MODEL, _MODEL_SLOTS, "The model's fields (MODEL) as views of mi and mf.", True)
unpack_buffers = _views(
    "unpack_buffers", "mi, buf", SCRATCH, _SCRATCH_SLOTS, "The scratch's fields (SCRATCH) as views of buf.", True
)
model_views = _views("model_views", "mi, mf", MODEL, _MODEL_SLOTS, "unpack, for Python and counting kernels.", False)
scratch_views = _views(
    "scratch_views", "mi, buf", SCRATCH, _SCRATCH_SLOTS, "unpack_buffers, for Python and counting kernels.", False
)
