"""Trial logs that were cut short or damaged: every readable query kept, nothing overwritten,
resume held to the settings that produced the log, and `harness.repair` for other readers."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader

from harness.log import ResumeRefused, TrialLog, read_log
from harness.log.recover import scan_log
from harness.repair import main as repair_main
from harness.repair import repair_file
from mpnet.envs.specs import SPECS
from tests.harness.log._helpers import make_rec, make_run, make_ws

N = 40
SETTINGS = {"budget_s": 10.0, "planner.stop": "first", "scale.name": "quick", "problems": None}


def write_log(run_dir, n=N, finalise=True, **run_kw):
    log = TrialLog(run_dir, make_run(settings=SETTINGS, **run_kw), SPECS["s2d"], rerun=False)
    log.add_workspace(make_ws("s2d"))
    for i in range(n):
        log.add_query(make_rec("s2d", f"ws0-{i}"))
    if finalise:
        log.close()
    else:  # as a kill -9 leaves it: flushed chunks, no summary
        log._finalizer.detach()
        log._f.flush()
        log._f.close()
        log._csv.close()
    return run_dir / "trials.mcap"


def stock_queries(path):
    """Query ids as the `mcap` package's indexed reader reads them (raises if it cannot)."""
    with open(path, "rb") as f:
        return [json.loads(m.data)["query_id"] for _, c, m in make_reader(f).iter_messages() if c.topic == "/query"]


def query_ids(scan):
    return [d["query_id"] for t, d, *_ in scan.messages if t == "/query"]


@pytest.fixture(scope="module")
def good_log(tmp_path_factory):
    return write_log(tmp_path_factory.mktemp("good")).read_bytes()


# ------------------------------------------------------------------- reading


def test_scan_reads_an_intact_file_whole(tmp_path, good_log):
    (tmp_path / "t.mcap").write_bytes(good_log)
    scan = scan_log(tmp_path / "t.mcap")
    assert scan.finalised and not scan.damaged and not scan.cut_tail
    assert query_ids(scan) == [f"ws0-{i}" for i in range(N)]


def chunk_spans(data: bytes) -> list[tuple[int, int]]:
    """(start, end) of each Chunk record's body: MCAP records are opcode, u64 length, body."""
    spans, at = [], 8  # after the magic
    while at + 9 <= len(data):
        op, length = data[at], int.from_bytes(data[at + 1 : at + 9], "little")
        if op == 0x06:
            spans.append((at + 9, at + 9 + length))
        if op == 0x0F:  # the footer
            break
        at += 9 + length
    return spans


def test_zeroed_bytes_mid_file_lose_only_their_chunk(tmp_path, good_log):
    """64 bytes zeroed inside the middle chunk's data (a byte offset alone could land in a
    message index, which the indexed reader never needs)."""
    bad = bytearray(good_log)
    start, end = chunk_spans(good_log)[len(chunk_spans(good_log)) // 2]
    mid = (start + end) // 2
    bad[mid : mid + 64] = bytes(64)
    (tmp_path / "t.mcap").write_bytes(bytes(bad))
    scan = scan_log(tmp_path / "t.mcap")
    assert scan.damaged and scan.damaged_bytes < 4096
    assert N - 2 <= len(query_ids(scan)) < N
    msgs, finalised = read_log(tmp_path / "t.mcap")
    assert not finalised  # damaged: never reported as a clean file
    assert sum(m.topic == "/query" for m in msgs) == len(query_ids(scan))


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_damage_in_a_chunks_own_fields_is_never_silent(tmp_path, good_log):
    """64 zeroed bytes from anywhere in a chunk's record head and fields (its times, size,
    CRC, compression, data length): every query read, or the file reported damaged. (Zeroed
    CRC and data length parsed as an empty chunk: its query was lost with no damage noted.)"""
    for start, _ in chunk_spans(good_log)[1:-1]:
        for off in range(start - 9, start + 45, 3):
            bad = bytearray(good_log)
            bad[off : off + 64] = bytes(64)
            (tmp_path / "t.mcap").write_bytes(bytes(bad))
            scan = scan_log(tmp_path / "t.mcap")
            assert scan.damaged or len(query_ids(scan)) == N, off


def test_a_lost_first_chunk_keeps_the_later_queries(tmp_path, good_log):
    bad = bytearray(good_log)
    bad[200:220] = bytes(20)  # inside the first chunk: its schemas, channels and /run
    (tmp_path / "t.mcap").write_bytes(bytes(bad))
    scan = scan_log(tmp_path / "t.mcap")
    assert scan.damaged and not any(t == "/run" for t, *_ in scan.messages)
    assert len(query_ids(scan)) >= N - 1  # topics known from the writer's channel order


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_corruption_gives_a_subset_of_the_logged_messages(tmp_path, good_log, data):
    """Zeroed, flipped or cut bytes anywhere: the scan never raises, and every message it
    returns is one that was logged (damage loses messages, never invents them)."""
    bad = bytearray(good_log)
    start = data.draw(st.integers(0, len(bad) - 1))
    kind = data.draw(st.sampled_from(["zero", "flip", "cut", "random"]))
    length = data.draw(st.integers(1, 300))
    if kind == "zero":
        bad[start : start + length] = bytes(len(bad[start : start + length]))
    elif kind == "flip":
        bad[start] ^= 0xFF
    elif kind == "cut":
        del bad[start:]
    else:
        bad[start : start + length] = data.draw(st.binary(min_size=length, max_size=length))
    path = tmp_path / "fuzz.mcap"
    path.write_bytes(bytes(bad))
    scan = scan_log(path)
    ids = query_ids(scan)
    assert len(ids) == len(set(ids)) and set(ids) <= {f"ws0-{i}" for i in range(N)}
    if kind == "cut":
        assert not scan.finalised or start >= len(good_log) - 200  # a cut file has no footer


# -------------------------------------------------------------------- resume


def test_resume_with_other_settings_is_refused_naming_them(tmp_path):
    write_log(tmp_path)
    before = (tmp_path / "trials.mcap").read_bytes()
    changed = {**SETTINGS, "budget_s": 5.0, "planner.stop": "time"}
    with pytest.raises(ResumeRefused) as e:
        TrialLog(tmp_path, make_run(settings=changed), SPECS["s2d"], rerun=False, resume=True)
    msg = str(e.value)
    assert "budget_s (10.0 -> 5.0)" in msg and "planner.stop ('first' -> 'time')" in msg and "\n" not in msg
    assert (tmp_path / "trials.mcap").read_bytes() == before  # untouched


def test_resume_of_a_log_without_settings_is_refused(tmp_path):
    log = TrialLog(tmp_path, make_run(), SPECS["s2d"], rerun=False)  # as older versions wrote it
    log.close()
    with pytest.raises(ResumeRefused, match="without its settings"):
        TrialLog(tmp_path, make_run(settings=SETTINGS), SPECS["s2d"], rerun=False, resume=True)


def test_resume_with_the_same_settings_goes_on(tmp_path):
    write_log(tmp_path, n=5, finalise=False)
    with TrialLog(tmp_path, make_run(settings=dict(SETTINGS)), SPECS["s2d"], rerun=False, resume=True) as log:
        assert len(log.done) == 5 and not log.notes


def test_resume_over_a_damaged_log_keeps_its_readable_queries_and_the_file(tmp_path, good_log):
    bad = bytearray(good_log)
    mid = len(bad) // 2
    bad[mid : mid + 64] = bytes(64)
    (tmp_path / "trials.mcap").write_bytes(bytes(bad))
    with TrialLog(tmp_path, make_run(settings=SETTINGS), SPECS["s2d"], rerun=False, resume=True) as log:
        kept = len(log.done)
        assert N - 2 <= kept < N
        assert len(log.notes) == 1 and "damaged" in log.notes[0] and "trials.mcap.damaged-1" in log.notes[0]
        for i in range(N):
            if ("seen", f"ws0-{i}") not in log.done:
                log.add_query(make_rec("s2d", f"ws0-{i}"))
    assert (tmp_path / "trials.mcap.damaged-1").read_bytes() == bytes(bad)  # kept as it was
    assert sorted(stock_queries(tmp_path / "trials.mcap")) == sorted(f"ws0-{i}" for i in range(N))


@pytest.mark.parametrize("content", [b"", b"\x00" * 3000, bytes(range(256)) * 8], ids=["empty", "zeros", "foreign"])
def test_resume_over_an_empty_or_foreign_file_never_loses_it(tmp_path, content):
    (tmp_path / "trials.mcap").write_bytes(content)
    with TrialLog(tmp_path, make_run(settings=SETTINGS), SPECS["s2d"], rerun=False, resume=True) as log:
        assert log.done == set()
        if content:
            assert "holds no readable trial" in log.notes[0] and "trials.mcap.damaged-1" in log.notes[0]
    if content:
        assert (tmp_path / "trials.mcap.damaged-1").read_bytes() == content


# -------------------------------------------------------------------- repair


def test_repair_finalises_a_killed_writers_file(tmp_path):
    path = write_log(tmp_path, n=7, finalise=False)
    with open(path, "ab") as f:
        f.write(b"\x06" + (500).to_bytes(8, "little") + b"half a chunk")  # killed mid-write
    with pytest.raises(Exception):  # noqa: B017 - whatever the indexed reader raises on an unfinished file
        stock_queries(path)
    assert "finalised with its 7 queries" in repair_file(path)
    assert stock_queries(path) == [f"ws0-{i}" for i in range(7)]
    assert "intact" in repair_file(path)
    assert not list(tmp_path.glob("trials.mcap.damaged-*"))


def test_repair_keeps_a_damaged_original(tmp_path, good_log, capsys):
    """A byte flipped inside the middle chunk's data: at the file's middle byte it could land in
    a message index, which costs no query (the log's size, and so its middle, varies with its
    timings: a full run on two workers found such a file)."""
    run = tmp_path / "sweep" / "s2d" / "seed0"
    run.mkdir(parents=True)
    bad = bytearray(good_log)
    start, end = chunk_spans(good_log)[len(chunk_spans(good_log)) // 2]
    bad[(start + end) // 2] ^= 0xFF
    (run / "trials.mcap").write_bytes(bytes(bad))
    assert repair_main([str(tmp_path / "sweep")]) == 0
    assert "original kept as" in capsys.readouterr().out
    assert (run / "trials.mcap.damaged-1").read_bytes() == bytes(bad)
    assert N - 2 <= len(stock_queries(run / "trials.mcap")) < N
    assert repair_main([str(tmp_path / "nowhere")]) == 1
