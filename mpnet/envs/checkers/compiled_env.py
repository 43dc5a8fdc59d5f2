"""A checker's compiled form: the `env` tuple a checker hands the compiled planners
(`CollisionChecker.compiled_env`), and the checks and state-space operations their kernels
call on it, each robot kind's own, so that the planners know no robot kind.

An env is one tuple whose last field is its kind's tag (`tag(name)`: an empty array of a
one-field record dtype named after the kind), so numba types each kind's env apart and a
kernel compiles once per kind. A kind is a module of this folder named `*_compiled.py` that
calls `register` with its checks (`boxes_compiled`: the point robot's and the rectangle's,
one compilation for both; `spheres_compiled`: the arm's sphere model); the modules are found
by name (DISCOVERS), so a robot kind of one's own is its checker and one such file, and
mpnet.jit's cache stamp reaches every one of them (an edit of a kind's file recompiles the
kernels that inline it). An env whose tag no module registers is refused when a kernel is
typed, by name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba.core.errors import TypingError
from numba.extending import overload

from mpnet.discover import import_named

DISCOVERS = "*_compiled.py"  # the kinds' modules, beside this one (mpnet.jit's stamp reads this too)
KINDS: dict[str, CompiledKind] = {}


@dataclass(frozen=True)
class CompiledKind:
    """A robot kind's compiled checks, each a numba function of (env, counts, ...): counts[2]
    gathers the configurations a sampled or certified check evaluates. canonical(env, q) and
    wrap_difference(env, d) write in place (a space with an angle wraps it); bounded_dims(env,
    n): how many leading coordinates of an n-D state have bounds. Left out: a Euclidean space.
    motion_free_known(env, counts, a, b, known): motion_free when the caller knows `known` of
    its ends are free (1: a; 2: a and b), which need not be checked again; left out: motion_free."""

    name: str
    state_free: Callable
    motion_free: Callable
    motions_free: Callable
    canonical: Callable | None = None
    wrap_difference: Callable | None = None
    bounded_dims: Callable | None = None
    motion_free_known: Callable | None = None


def register(kind: CompiledKind) -> None:
    KINDS[kind.name] = kind


def tag(name: str) -> np.ndarray:
    """The last field of a `name` env: numba types it by its record's field name."""
    return np.zeros(0, np.dtype([(name, np.int8)]))


def _kind(env) -> CompiledKind:
    """The registered kind of an env's numba type (typing time)."""
    fields = getattr(getattr(env.types[-1], "dtype", None), "fields", None) if hasattr(env, "types") else None
    name = next(iter(fields)) if fields else None
    if name not in KINDS:  # every kind module of this folder imported (each registers its kind)
        import_named(__name__.rpartition(".")[0], DISCOVERS.removeprefix("*").removesuffix(".py"))
    if name not in KINDS:
        raise TypingError(f"compiled_env: an env of kind {name!r}, which no *_compiled.py module registers")
    return KINDS[name]


def state_free(env, counts, q):
    """Whether the state is free; typed by the overload below."""
    raise NotImplementedError("compiled only")


def motion_free(env, counts, a, b):
    """Whether the motion is free; typed by the overload below."""
    raise NotImplementedError("compiled only")


def motions_free(env, counts, A, B, out):
    """out[i]: whether motion i is free; typed by the overload below."""
    raise NotImplementedError("compiled only")


def motion_free_known(env, counts, a, b, known):
    """Whether the motion is free, `known` of its ends (1: a; 2: a and b) known to be free
    already (a tree's states: not checked again); typed by the overload below."""
    raise NotImplementedError("compiled only")


def canonical(env, x):
    """The state space's wrap of a state x (SE2: the angle into [-pi, pi)), in place."""
    raise NotImplementedError("compiled only")


def wrap_difference(env, x):
    """A difference x of states along the shorter way (SE2: the angle's into [-pi, pi)), in place."""
    raise NotImplementedError("compiled only")


def bounded_dims(env, x):
    """How many leading coordinates of an x-D state have bounds to clip into (SE2: x and y)."""
    raise NotImplementedError("compiled only")


# Borrowed (mpnet.jit), as the checks they call; motions_free counts references: a kind's batch
# may allocate its answers.
@overload(state_free, jit_options={"_nrt": False})
def _state_typed(env, counts, q):
    check = _kind(env).state_free
    return lambda env, counts, q: check(env, counts, q)


@overload(motion_free, jit_options={"_nrt": False})
def _motion_typed(env, counts, a, b):
    check = _kind(env).motion_free
    return lambda env, counts, a, b: check(env, counts, a, b)


@overload(motion_free_known, jit_options={"_nrt": False})
def _motion_known_typed(env, counts, a, b, known):
    own = _kind(env).motion_free_known
    if own is None:  # the kind checks the whole motion
        check = _kind(env).motion_free
        return lambda env, counts, a, b, known: check(env, counts, a, b)
    return lambda env, counts, a, b, known: own(env, counts, a, b, known)


@overload(motions_free, jit_options={"_nrt": True})
def _motions_typed(env, counts, A, B, out):
    check = _kind(env).motions_free
    return lambda env, counts, A, B, out: check(env, counts, A, B, out)


def _overload_optional(stub, field: str, default) -> None:
    """stub(env, x) typed to the kind's own function, or `default` where the kind has none."""

    @overload(stub, jit_options={"_nrt": False})
    def typed(env, x):
        own = getattr(_kind(env), field)
        return default if own is None else (lambda env, x: own(env, x))


_overload_optional(canonical, "canonical", lambda env, x: None)  # a Euclidean space: nothing to wrap
_overload_optional(wrap_difference, "wrap_difference", lambda env, x: None)
_overload_optional(bounded_dims, "bounded_dims", lambda env, x: x)  # every coordinate bounded
