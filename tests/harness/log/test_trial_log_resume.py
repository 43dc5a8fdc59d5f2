"""The trial log's crash safety and resume (docs/reliability.md): a killed writer keeps every
finished query, an exception or exit finalises the file, a resume never duplicates and refuses
another run's log; the Rerun recording verifies and reads back."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader

from harness.log import TrialLog, read_log, scene_update_schema
from mpnet.envs.specs import SPECS
from tests.conftest import REPO_ROOT
from tests.harness.log._helpers import by_topic, is_rect, log_some, make_rec, make_run, make_ws, read_all, read_csv

REPO = REPO_ROOT  # the kill scripts run from outside pytest


# ------------------------------------------------------------------ crash safety

KILL_SCRIPT = textwrap.dedent("""
    import os, sys
    sys.path.insert(0, {repo!r})
    from tests.harness.log._helpers import make_run, make_ws, make_rec
    from harness.log import TrialLog
    from mpnet.envs.specs import SPECS
    log = TrialLog({run_dir!r}, make_run("s2d"), SPECS["s2d"], rerun={rerun})
    log.add_workspace(make_ws("s2d"))
    for i in range(3):
        log.add_query(make_rec("s2d", "ws0-%d" % i, success=i != 1))
    os.kill(os.getpid(), 9)
""")


def run_and_kill(run_dir: Path, rerun=False):
    script = KILL_SCRIPT.format(repo=str(REPO), run_dir=str(run_dir), rerun=rerun)
    p = subprocess.run([sys.executable, "-c", script], cwd=str(REPO), capture_output=True, text=True, timeout=120)
    assert p.returncode == -signal.SIGKILL, p.stderr
    return run_dir / "trials.mcap"


@pytest.mark.slow  # a subprocess
@pytest.mark.parametrize("rerun", [False, True])
def test_sigkill_leaves_every_finished_query(tmp_path, rerun):
    path = run_and_kill(tmp_path, rerun)
    # Not finalised: the indexed reader refuses it ...
    with pytest.raises(Exception):  # noqa: B017  (whatever the indexed reader raises)
        with open(path, "rb") as f:
            list(make_reader(f).iter_messages())
    # ... but mcap's StreamReader reads every finished query (as check_trials.py does).
    chans, got = {}, []
    with open(path, "rb") as f:
        try:
            for rec in StreamReader(f, skip_magic=False).records:
                if isinstance(rec, Channel):
                    chans[rec.id] = rec.topic
                elif isinstance(rec, Message):
                    got.append((chans[rec.channel_id], json.loads(rec.data)))
        except Exception:  # noqa: BLE001 - the stream ends without a footer
            pass
    assert [d["query_id"] for t, d in got if t == "/query"] == ["ws0-0", "ws0-1", "ws0-2"]
    assert len([d for t, d in got if t == "/run"]) == 1
    assert [d["workspace_id"] for t, d in got if t == "/workspace"] == ["ws0"]
    msgs, finalised = read_log(path)
    assert not finalised and len([m for m in msgs if m.topic == "/query"]) == 3
    rows = read_csv(tmp_path / "queries.csv")
    assert [r["query_id"] for r in rows] == ["ws0-0", "ws0-1", "ws0-2"]


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_exceptions_finalise_the_file(tmp_path, exc):
    with pytest.raises(exc):
        with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=True) as log:
            log.add_workspace(make_ws("s2d"))
            log.add_query(make_rec("s2d", "ws0-0"))
            raise exc()
    _, msgs = read_all(tmp_path / "trials.mcap")
    assert [d["query_id"] for d in by_topic(msgs, "/query")] == ["ws0-0"]
    assert read_log(tmp_path / "trials.mcap")[1] is True


def test_close_is_idempotent_and_closed_log_refuses(tmp_path):
    log = TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False)
    log.add_workspace(make_ws("s2d"))
    log.add_query(make_rec("s2d", "ws0-0"))
    log.close()
    log.close()
    with pytest.raises(ValueError):
        log.add_query(make_rec("s2d", "ws0-1"))
    assert len(by_topic(read_all(tmp_path / "trials.mcap")[1], "/query")) == 1


@pytest.mark.slow  # a subprocess
def test_unclosed_log_is_finalised_at_exit(tmp_path):
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(REPO)!r})
        from tests.harness.log._helpers import make_run, make_ws, make_rec
        from harness.log import TrialLog
        from mpnet.envs.specs import SPECS
        log = TrialLog({str(tmp_path)!r}, make_run("s2d"), SPECS["s2d"], rerun=True)
        log.add_workspace(make_ws("s2d"))
        log.add_query(make_rec("s2d", "ws0-0"))
    """)
    p = subprocess.run([sys.executable, "-c", script], cwd=str(REPO), capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert read_log(tmp_path / "trials.mcap")[1] is True
    from rerun.chunk import RrdReader

    rows = sum(
        c.num_rows for c in RrdReader(tmp_path / "trials.rrd").stream() if str(c.entity_path) == "/scene/world/path"
    )
    assert rows == 1  # the buffered query was sent before the recording closed


# ----------------------------------------------------------------------- resume


def check_resumed(tmp_path, expect_ids):
    schemas, msgs = read_all(tmp_path / "trials.mcap")
    assert len(by_topic(msgs, "/run")) == 1
    qs = by_topic(msgs, "/query")
    keys = [(q["split"], q["query_id"]) for q in qs]
    assert len(keys) == len(set(keys))
    assert sorted(q for _, q in keys) == sorted(expect_ids)
    assert len(by_topic(msgs, "/workspace")) == len(
        {(w["split"], w["workspace_id"]) for w in by_topic(msgs, "/workspace")}
    )
    for s in by_topic(msgs, "/scene"):
        jsonschema.validate(s, scene_update_schema())
    assert not list(tmp_path.glob("trials.mcap.resume-*"))  # moved-aside files are gone
    rows = read_csv(tmp_path / "queries.csv")
    assert sorted(r["query_id"] for r in rows) == sorted(expect_ids)
    return msgs


@pytest.mark.slow  # a subprocess
def test_resume_after_close_skips_done_and_never_duplicates(tmp_path):
    log_some(tmp_path, n=3)
    _, first = read_all(tmp_path / "trials.mcap")
    old_q = by_topic(first, "/query")
    with TrialLog(tmp_path, make_run(started_at="later"), SPECS["s2d"], rerun=True, resume=True) as log:
        assert log.done == {("seen", "ws0-0"), ("seen", "ws0-1"), ("seen", "ws0-2")}
        log.add_workspace(make_ws("s2d"))  # already there: no second /workspace
        for i in range(5):
            if ("seen", f"ws0-{i}") in log.done:
                with pytest.raises(ValueError):
                    log.add_query(make_rec("s2d", f"ws0-{i}"))
                continue
            log.add_query(make_rec("s2d", f"ws0-{i}"))
    msgs = check_resumed(tmp_path, [f"ws0-{i}" for i in range(5)])
    (run,) = by_topic(msgs, "/run")
    assert run["started_at"] == "later" and run["resumed_from"]["queries"] == 3
    assert by_topic(msgs, "/query")[:3] == old_q  # re-written unchanged
    assert (
        subprocess.run(
            rerun_cli() + ["rrd", "verify", str(tmp_path / "trials.rrd")], capture_output=True, timeout=120
        ).returncode
        == 0
    )


@pytest.mark.slow  # a subprocess
def test_resume_after_sigkill(tmp_path):
    run_and_kill(tmp_path)
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True) as log:
        assert log.done == {("seen", f"ws0-{i}") for i in range(3)}
        log.add_query(make_rec("s2d", "ws0-3"))
    check_resumed(tmp_path, [f"ws0-{i}" for i in range(4)])
    # and again, from the finalised resumed file
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True) as log:
        assert len(log.done) == 4
        log.add_query(make_rec("s2d", "ws0-4"))
    check_resumed(tmp_path, [f"ws0-{i}" for i in range(5)])


def test_resume_killed_during_resume_keeps_everything(tmp_path):
    """A moved-aside file that is still there (the resumed run died too) is read again."""
    log_some(tmp_path, n=2)
    log = TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True)
    log.add_query(make_rec("s2d", "ws0-2"))
    log._finalizer.detach()  # simulate a crash: nothing finalised, nothing cleaned up
    log._f.flush()
    assert list(tmp_path.glob("trials.mcap.resume-*"))
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True) as log2:
        assert log2.done == {("seen", f"ws0-{i}") for i in range(3)}
    check_resumed(tmp_path, ["ws0-0", "ws0-1", "ws0-2"])
    log._f.close()
    log._csv.close()


def test_resume_without_previous_file_starts_fresh(tmp_path):
    with TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False, resume=True) as log:
        assert log.done == set()


def test_resume_refuses_another_runs_log(tmp_path):
    log_some(tmp_path)
    with pytest.raises(ValueError, match="seed"):
        TrialLog(tmp_path, make_run(seed=1), SPECS["s2d"], rerun=False, resume=True)
    assert (tmp_path / "trials.mcap").exists()  # left in place


# ------------------------------------------------------------------------ Rerun


def rerun_cli():
    exe = shutil.which("rerun")
    return [exe] if exe else [sys.executable, "-m", "rerun"]


@pytest.mark.slow  # a subprocess
@pytest.mark.parametrize("env", ["s2d", "rigid", "c3d"])
def test_rrd_verifies_and_reads_back(tmp_path, env):
    with TrialLog(tmp_path, make_run(env), SPECS[env], rerun=True, rerun_batch=2) as log:
        log.add_workspace(make_ws(env))
        log.add_workspace(make_ws(env, "ws1", "unseen"))
        for i in range(3):
            log.add_query(make_rec(env, f"ws0-{i}", success=i != 1))
        log.add_query(make_rec(env, "ws1-0", wid="ws1", split="unseen"))
    rrd = tmp_path / "trials.rrd"
    p = subprocess.run(rerun_cli() + ["rrd", "verify", str(rrd)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr

    from rerun.chunk import RrdReader

    reader = RrdReader(rrd)
    (store,) = reader.recordings()
    assert store.application_id == "mpnet_bench"
    assert reader.blueprints()  # the default blueprint travels with the recording
    chunks = [c for c in reader.stream() if not c.is_empty]  # a property in 0.41
    assert chunks
    paths = {str(c.entity_path) for c in chunks}
    for e in (
        "/scene/world/path",
        "/scene/world/endpoints",
        "/scene/world/obstacles",
        "/stats/time_s",
        "/stats/collision_checks",
        "/workspaces/seen/ws0/obstacles",
        "/workspaces/unseen/ws1/obstacles",
        "/legend",  # what the colours mean, with the planner and env
    ):
        assert e in paths, (e, paths)
    assert ("/scene/world/robot" in paths) == is_rect(SPECS[env])
    rows = {}
    for c in chunks:
        if str(c.entity_path) == "/scene/world/path":
            assert "query" in c.timeline_names
            rows["path"] = rows.get("path", 0) + c.num_rows
    assert rows["path"] == 4


def test_rerun_off_writes_no_rrd(tmp_path):
    log_some(tmp_path, rerun=False)
    assert not (tmp_path / "trials.rrd").exists()
