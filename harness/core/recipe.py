"""The networks' recipe as one typed schema: the training options that a planner's `networks`
(and an env's `networks` and `paper_networks`, its default and the paper's) may set over the
scale's. Each option's name, type, bounds and meaning are written here once;
harness.core.config checks the YAML against it, and the options a recipe sets join the
models' cache key (an option left out keeps the key it had).
"""

from __future__ import annotations

from dataclasses import Field, dataclass, field, fields


def _option(kind: type, doc: str, *, minimum: float | None = None, below: float | None = None, dagger=None):
    """An option: unset (None) unless a recipe sets it; `kind` its type (list: layer widths);
    an integer's `minimum`; a number in [minimum, below) when `below` is given; `dagger`: its
    value when a recipe asks for DAgger's rounds and leaves it out."""
    meta = {"kind": kind, "doc": doc, "minimum": minimum, "below": below, "dagger": dagger}
    return field(default=None, metadata=meta)


@dataclass(frozen=True)
class Recipe:
    """A named recipe of the networks (conf/env/*.yaml `networks`, `paper_networks`;
    conf/planner/*.yaml `networks`). docs/mpnet.md says what each was measured to do."""

    waypoint_step: float | None = _option(
        float, "expert paths resampled so that consecutive states are at most this far apart"
    )
    min_waypoints: int | None = _option(
        int, "... and have at least this many states (MoveIt's interpolation: 10)", minimum=2
    )
    equal_steps: bool | None = _option(
        bool, "Pnet's epochs scaled by (the scale's pairs / these pairs): as many gradient steps as the scale's"
    )
    bounded: bool | None = _option(bool, "Pnet's output softsign-bounded inside the state bounds (centred normaliser)")
    bidirectional: bool | None = _option(
        bool, "false: each path forward only (the public code's pairs); true adds the reversed path"
    )
    dropout: float | None = _option(
        float, "Pnet's dropout rate (the scale's model.dropout otherwise), at training and planning", minimum=0, below=1
    )
    input_noise: float | None = _option(
        float, "each training state moved by Gaussian noise of this standard deviation (state units; DART-style)"
    )
    pnet_hidden: list | None = _option(list, "Pnet's layer widths (the scale's otherwise)")
    enet_hidden: list | None = _option(list, "Enet's layer widths (the scale's otherwise)")
    latent: int | None = _option(int, "the scene code's size (the scale's otherwise)", minimum=1)
    voxels: int | None = _option(
        int, "Enet reads an occupancy grid of this many cells a side (order-free; trains end to end)", minimum=2
    )
    dagger_rounds: int | None = _option(
        int, "rounds of DAgger (harness.artifacts.dagger): each rolls out the round before's networks", minimum=1
    )
    dagger_queries: int | None = _option(
        int, "expert queries rolled out per training scene a round", minimum=1, dagger=5
    )
    dagger_states: int | None = _option(
        int, "states of each first NeuralPlanner run that the expert plans from", minimum=1, dagger=3
    )
    dagger_budget_s: float | None = _option(float, "the expert's budget per visited state (s)", dagger=2.0)


OPTIONS: tuple[Field, ...] = fields(Recipe)
# DAgger's settings when a recipe asks for rounds and leaves them out (in the models key).
DAGGER_DEFAULTS = {f.name: f.metadata["dagger"] for f in OPTIONS if f.metadata["dagger"] is not None}
# A planner's `networks: {recipe: ...}`: the env's recipe (env.networks, the default) or the
# paper's for this env (env.paper_networks: the paper's arm recipe on the arm; the scale's own,
# which is the paper's, where an env has none).
RECIPES = {"env": "networks", "paper": "paper_networks"}
