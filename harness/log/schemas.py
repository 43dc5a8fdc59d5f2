"""The JSON Schemas of the trial log's topics, written with each channel of `trials.mcap`.

The `/scene` topic carries Foxglove `foxglove.SceneUpdate` messages. Their schema,
`harness/schemas/foxglove.SceneUpdate.json`, is our own description of Foxglove's documented
SceneUpdate message, written from Foxglove's message-schema docs
(https://docs.foxglove.dev/docs/visualization/message-schemas/scene-update/ and the pages it
links); its field names are Foxglove's. Foxglove recognises the data by the schema name
`foxglove.SceneUpdate`. The file shares types through `$defs`; the copy written into the MCAP
file has every `$ref` inlined, since Foxglove's JSON Schema reader expects each field to give
its own `type`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

FORMAT = "mpnet-bench/trials@1"
SCHEMA_DIR = Path(__file__).resolve().parent.parent / "schemas"

RUN_FIELDS = ("env", "planner", "seed", "split", "config", "git_rev", "versions", "host", "started_at")
QUERY_FIELDS = (
    "query_id",
    "workspace_id",
    "split",
    "start",
    "goal",
    "success",
    "failure",
    "path",
    "time_s",
    "cpu_s",
    "path_cost",
    "collision_checks",
)

SEGMENT_FIELDS = ("git_rev", "host", "started_at")


def run_segments(run: dict) -> list[dict]:
    """Every session that planned some of a run's queries, oldest first, each {git_rev, host,
    started_at}: those a resume recorded in `resumed_from.runs`, then the run's own. A resumed
    log's /run is its last session's, so provenance read off it alone would name one revision for
    queries that several planned."""
    resumed = run.get("resumed_from")
    earlier = resumed.get("runs") if isinstance(resumed, dict) else None
    segs = (
        [{k: e.get(k) for k in SEGMENT_FIELDS} for e in earlier if isinstance(e, dict)]
        if isinstance(earlier, list)
        else []
    )
    return segs + [{k: run.get(k) for k in SEGMENT_FIELDS}]


_NUM = {"type": "number"}
_VEC = {"type": "array", "items": _NUM}
_STATE_LIST = {"type": "array", "items": _VEC}

RUN_SCHEMA = {
    "$schema": "http://json-schema.org/draft-07/schema#",
    "title": "mpnet_bench.Run",
    "description": "One bench run: what was run, with which code and config.",
    "type": "object",
    "properties": {
        "format": {"type": "string", "description": "Log format version, e.g. " + FORMAT},
        "env": {"type": "string"},
        "planner": {"type": "string"},
        "seed": {"type": "integer"},
        "split": {"type": "string", "description": "seen, unseen, file or seen+unseen"},
        "config": {"type": "string", "description": "Resolved config as YAML text"},
        "git_rev": {"type": ["string", "null"]},
        "versions": {"type": "object", "description": "Package name to version"},
        "host": {"type": "string"},
        "started_at": {"type": ["string", "number"]},
        "resumed_from": {
            "type": "object",
            "description": "Set when the run resumed an earlier log: the files and queries it took over, and "
            "`runs`, every earlier session that planned some of them ({git_rev, host, started_at}, oldest first)",
        },
        "settings": {
            "type": "object",
            "description": "Every config value that decides the results, by dotted key (the problem file by "
            "its sha256): a resumed run must have the same",
        },
        "queries_expected": {"type": "integer", "description": "Queries in the run's test set or problem file"},
        "overrides": {
            "type": "array",
            "items": {"type": "string"},
            "description": "The job's command-line overrides as Hydra recorded them (`+env=s2d`, `seed=0`, ...): "
            "what `python -m harness` was given, so the report can say how to run it again",
        },
        "threads": {
            "type": "array",
            "items": {"type": "object"},
            "description": "The process's thread pools once its kernels were loaded, before the first query "
            "(harness/core/threads.py): each {api, library, file, threads}; a timed run has one thread in each",
        },
        "facts": {
            "type": "object",
            "description": "What the report needs to know, computed once from the config (harness/log/facts.py): "
            "the planner's kind (base, variant, algorithm, cost target and factor), budget_s, the training set's "
            "size, the expert and reference settings, the workspace dimension and the robot",
        },
    },
    "required": list(RUN_FIELDS),
}
WORKSPACE_SCHEMA = {
    "$schema": "http://json-schema.org/draft-07/schema#",
    "title": "mpnet_bench.Workspace",
    "description": "A workspace used by the run: bounds, obstacles (axis-aligned boxes, or posed boxes, "
    "cylinders and spheres: size is the extent in the primitive's frame), robot.",
    "type": "object",
    "properties": {
        "workspace_id": {"type": "string"},
        "split": {"type": "string", "description": "seen, unseen or file"},
        "bounds": {
            "type": "array",
            "items": {"type": "array", "items": _NUM, "minItems": 2, "maxItems": 2},
            "description": "[lo, hi] per state dimension",
        },
        "obstacles": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "center": _VEC,
                    "size": _VEC,
                    "type": {"enum": ["box", "cylinder", "sphere"], "description": "problems@2; absent: a box"},
                    "orientation": {
                        "type": "array",
                        "items": _NUM,
                        "minItems": 4,
                        "maxItems": 4,
                        "description": "quaternion [x, y, z, w] (problems@2); absent: axis-aligned",
                    },
                },
                "required": ["center", "size"],
            },
        },
        "robot": {
            "type": ["object", "string"],
            "description": '{"kind": "point"}, {"kind": "rectangle", "size": [w, h]} or '
            '{"kind": "arm", "name": <model>, "urdf": ..., "fingers": ...}',
        },
    },
    "required": ["workspace_id", "split", "bounds", "obstacles", "robot"],
}
QUERY_SCHEMA = {
    "$schema": "http://json-schema.org/draft-07/schema#",
    "title": "mpnet_bench.Query",
    "description": "One finished query; extra keys are the planner's own statistics.",
    "type": "object",
    "properties": {
        "query_id": {"type": "string"},
        "workspace_id": {"type": "string"},
        "split": {"type": "string"},
        "start": _VEC,
        "goal": _VEC,
        "success": {"type": "boolean"},
        "failure": {"type": ["string", "null"], "description": "null on success, else the reason"},
        "path": _STATE_LIST,
        "partial": {
            "type": ["object", "null"],
            "additionalProperties": _STATE_LIST,
            "description": "A failed query's partial paths, what the planner had when it stopped "
            "(mpnet.planners.base.Result.partial), by kind: forward and backward (MPNet: the last "
            "NeuralPlanner run's paths from its start and from its goal), last_path (MPNet: the last coarse "
            "or replanned path, not feasible), approximate (OMPL: the approximate solution); at most 200 "
            "states each. null or absent for a success",
        },
        "time_s": {"type": ["number", "null"], "description": "Wall-clock planning time (null if not finite)"},
        "plan_s": {"type": ["number", "null"], "description": "time_s less MPNet's encoding (encode_s)"},
        "cpu_s": {"type": ["number", "null"]},
        "path_cost": {"type": ["number", "null"]},
        "collision_checks": {"type": ["integer", "null"]},
        "state_checks": {"type": ["integer", "null"]},
        "motion_checks": {"type": ["integer", "null"]},
        "pnet_calls": {"type": ["integer", "null"]},
        "replans": {"type": ["integer", "null"]},
        "restarts": {"type": ["integer", "null"], "description": "MPNet anytime: the paper's loop restarted"},
        "fallback_used": {"type": ["boolean", "null"]},
        "reference_cost": {"type": ["number", "null"], "description": "the test set's reference path cost"},
        "target_planner": {"type": ["string", "null"], "description": "time to equal quality: the target's planner"},
        "target_cost": {"type": ["number", "null"], "description": "time to equal quality: the cost to reach"},
        "target_time_s": {"type": ["number", "null"], "description": "time to equal quality: the target's time"},
        "configurations_checked": {"type": ["integer", "null"], "description": "the arm: sphere-model evaluations"},
        "encode_s": {"type": ["number", "null"], "description": "MPNet: the workspace's encoding (cloud, Enet)"},
        "pnet_s": {"type": ["number", "null"], "description": "MPNet: NeuralPlanner runs (Pnet and steerTo)"},
        "fallback_s": {"type": ["number", "null"], "description": "MPNet-HR: the classical planner's time"},
        "planner_status": {"type": ["string", "null"]},
        "best_cost": {"type": ["number", "null"], "description": "OMPL's optimizing planners: the best cost found"},
        "progress": {
            "type": "array",
            "items": {"type": "array", "items": _NUM, "minItems": 2, "maxItems": 2},
            "description": "OMPL's optimizing planners (BIT*, Informed-RRT*, RRT*): [seconds since the solve "
            "began, best cost] at each improvement, in time order (mpnet.planners.classical.BestCostWatch)",
        },
        "diagnostics": {
            "type": "object",
            "description": "MPNet only: Pnet's proposals (trace: stage, tree end, proposal) and their shares "
            "in collision / reachable, the first proposal's validity and visibility, code sensitivity "
            "(mpnet.planners.diagnostics)",
        },
    },
    "required": list(QUERY_FIELDS),
}


SCALAR_TYPES = frozenset(("string", "number", "integer", "boolean"))


def query_columns(*types: str) -> tuple[str, ...]:
    """The /query fields of these JSON types (null aside; none given: every scalar type), in the
    schema's order: the one list the CSV, the report's frame and the Planner Arena export read."""
    want = frozenset(types) or SCALAR_TYPES
    out = []
    for name, prop in QUERY_SCHEMA["properties"].items():
        t = prop.get("type")
        kinds = ({t} if isinstance(t, str) else set(t or ())) - {"null"}
        if kinds and kinds <= want:
            out.append(name)
    return tuple(out)


def scene_update_schema(inline: bool = False) -> dict:
    """Our JSON Schema for Foxglove's foxglove.SceneUpdate (see module docstring).

    inline=True: every `$ref` replaced by its definition and `$defs` dropped, the form
    written to MCAP (Foxglove's reader does not follow `$ref`).
    """
    schema = json.loads((SCHEMA_DIR / "foxglove.SceneUpdate.json").read_text())
    return _inline_refs(schema, schema.get("$defs", {})) if inline else schema


def _inline_refs(node: Any, defs: dict) -> Any:
    """`node` with each {"$ref": "#/$defs/<name>", ...} replaced by that definition
    (recursively inlined, sibling keys kept) and any `$defs` dropped."""
    if isinstance(node, list):
        return [_inline_refs(x, defs) for x in node]
    if not isinstance(node, dict):
        return node
    out = {}
    ref = node.get("$ref")
    if ref is not None:
        prefix = "#/$defs/"
        if not ref.startswith(prefix) or ref[len(prefix) :] not in defs:
            raise ValueError(f"unsupported $ref {ref!r}")
        out.update(_inline_refs(defs[ref[len(prefix) :]], defs))
    for k, v in node.items():
        if k not in ("$ref", "$defs"):
            out[k] = _inline_refs(v, defs)
    return out


def schema_bytes(schema: dict) -> bytes:
    return json.dumps(schema, separators=(",", ":")).encode()


_SCENE_SCHEMA_CACHE: list[bytes] = []


def scene_schema_bytes() -> bytes:
    """The inlined SceneUpdate schema as written to MCAP (read and inlined once per process)."""
    if not _SCENE_SCHEMA_CACHE:
        _SCENE_SCHEMA_CACHE.append(schema_bytes(scene_update_schema(inline=True)))
    return _SCENE_SCHEMA_CACHE[0]


def topic_schemas() -> tuple[tuple[str, str, bytes], ...]:
    """(topic, schema name, schema) of every channel, in the order the writer registers them."""
    return (
        ("/run", "mpnet_bench.Run", schema_bytes(RUN_SCHEMA)),
        ("/workspace", "mpnet_bench.Workspace", schema_bytes(WORKSPACE_SCHEMA)),
        ("/query", "mpnet_bench.Query", schema_bytes(QUERY_SCHEMA)),
        ("/scene", "foxglove.SceneUpdate", scene_schema_bytes()),
    )
