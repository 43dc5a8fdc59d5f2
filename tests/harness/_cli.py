"""The end-to-end CLI tests' readers: a run's trial log read back, its successes re-checked, the
artifact folder a command printed."""

import json
from pathlib import Path

from mcap.reader import make_reader

from mpnet.envs import get_spec
from mpnet.envs.workspace import Workspace
from mpnet.motion import verify_path


def printed_folder(stdout: str) -> Path:
    """The artifact folder harness.train or harness.data printed (`trained: F`, `built: F` or
    `cached: F`, its one such line)."""
    (line,) = [x for x in stdout.splitlines() if x.startswith(("trained: ", "built: ", "cached: "))]
    return Path(line.split(": ", 1)[1].split()[0])


def read_mcap(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        schemas = {s.name for s in summary.schemas.values()}
        msgs = [(c.topic, json.loads(m.data)) for _, c, m in reader.iter_messages()]
    return schemas, msgs


def recheck(msgs):
    """Every logged success passes verify_path against the logged obstacles."""
    run_msg = next(m for t, m in msgs if t == "/run")
    spec = get_spec(run_msg["env"])
    wss = {(m["split"], m["workspace_id"]): m for t, m in msgs if t == "/workspace"}
    n = 0
    for t, q in msgs:
        if t == "/query" and q["success"]:
            w = wss[(q["split"], q["workspace_id"])]
            ws = Workspace.from_json(w["workspace_id"], w["split"], w["obstacles"], spec.workspace_dim)
            assert verify_path(spec, ws, q["path"], q["start"], q["goal"], min(0.01, spec.validation_step)) is None
            n += 1
    return n
