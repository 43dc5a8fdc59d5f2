"""The log process's inbox read ahead, and the backlog judged by two processes once planning ends.

Why: on an arm the judge (pybullet every 0.002 rad, ~5,000 states a path) is slower than the
planner, so the bench waited on a full pipe while it planned and waited again at close while
one process judged what was left (MBM's 700 Panda problems: ~10 s of planning, minutes of
judging). A thread of the log process now reads the pipe as it fills (the bench never waits on
it), and once the bench has closed the log, nothing is timed any more: a second process judges
the tail of the backlog while the log process judges its head, and the log is written in the
order the queries came. The judge's verdicts do not depend on which process gives them (a fresh
pybullet world per workspace; a hit is always measured afresh: mpnet.envs.checkers.pybullet_arm).
"""

from __future__ import annotations

import collections
import os
import pickle
import resource
import signal
import subprocess
import sys
import threading
import time

import numpy as np

HELPER_START_S = 1.5  # what a helper (a spawned process) costs to start, in seconds of judging
SAY_S = 5.0  # a backlog this long (seconds of judging) is announced on stderr


class ReadAhead:
    """The pipe's messages, read by a thread as they come: get() the next, in order;
    `closing` once the bench's close has been read, or the pipe's end (("eof", None)), or
    something unreadable (("error", the exception)): the last message there is."""

    def __init__(self, conn):
        self._items: collections.deque = collections.deque()
        self._ready = threading.Condition()
        self.closing = False
        self._thread = threading.Thread(target=self._read, args=(conn,), name="trial-log-inbox", daemon=True)
        self._thread.start()

    def _read(self, conn) -> None:
        while True:
            try:
                msg = conn.recv()
            except (EOFError, OSError):  # the bench died: what came is judged and logged
                msg = ("eof", None)
            except BaseException as e:  # noqa: BLE001  (raised by the log process, after it finalised the log)
                msg = ("error", e)
            with self._ready:
                self._items.append(msg)
                self.closing = msg[0] in ("close", "eof", "error")
                self._ready.notify()
            if self.closing:
                return

    def get(self) -> tuple:
        with self._ready:
            while not self._items:
                self._ready.wait()
            return self._items.popleft()

    def rest(self) -> list:
        """Every message not yet taken (once `closing`: up to the close, in order)."""
        with self._ready:
            items, self._items = list(self._items), collections.deque()
        return items


def ws_key(rec: dict) -> tuple[str, str]:
    """The (split, workspace id) a query record belongs to: the key of the logged workspaces."""
    return rec["split"], rec["workspace_id"]


def judged_states(rec: dict, step: float) -> float:
    """About how many states the judge samples on the record's path (0 for a failure: not judged)."""
    if rec["failure"] is not None or len(rec["path"]) < 2:
        return 0.0
    p = np.asarray(rec["path"], float)
    return float(np.ceil(np.linalg.norm(np.diff(p, axis=0), axis=1) / step).sum())


class JudgeRate:
    """The log process's seconds of judging per sampled state, measured on the run's queries."""

    def __init__(self):
        self.seconds, self.states = 0.0, 0.0

    def timed(self, judge, spec, ws, rec: dict, step: float) -> dict:
        t = time.perf_counter()
        out = judge(spec, ws, rec, step)
        self.seconds += time.perf_counter() - t
        self.states += judged_states(rec, step)
        return out

    def per_state(self) -> float | None:
        return self.seconds / self.states if self.states > 0 else None


def helper_share(costs: list[float], start_s: float = HELPER_START_S) -> int:
    """How many of the last queries (their judging seconds: costs) a helper takes, so that both
    processes end about together (it starts start_s later and takes the tail); 0 when what it
    would take is less than what its start costs."""
    left = (sum(costs) - start_s) / 2
    k, taken = 0, 0.0
    while k < len(costs) and taken + costs[-1 - k] <= left:
        taken += costs[-1 - k]
        k += 1
    return k if taken >= start_s else 0


def _start_helper(judge, spec, items: list, step: float) -> subprocess.Popen:
    """A fresh interpreter judging `items` ((workspace, record) pairs): _helper_main, the work
    pickled down its stdin (a subprocess, not a multiprocessing child: the log process is a
    daemon, which multiprocessing lets have none). It sees this process's sys.path."""
    work = pickle.dumps((judge, spec, items, step))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    code = "from harness.log.drain import _helper_main; _helper_main()"
    proc = subprocess.Popen([sys.executable, "-c", code, str(os.getpid())], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, env=env)  # fmt: skip
    # fed by a thread: a share larger than the pipe would hold the log process until the helper's
    # interpreter has started and read it (~1 s it judges its own head instead)
    threading.Thread(target=_feed, args=(proc.stdin, work), name="trial-log-feed", daemon=True).start()
    return proc


def _feed(pipe, data: bytes) -> None:
    try:
        pipe.write(data)
    except OSError:  # the helper died at once: its share is judged here (_collect)
        pass
    finally:
        try:
            pipe.close()
        except OSError:
            pass


def _helper_main() -> None:
    """The helper: each (workspace, record) judged, the records written back in order. A Ctrl-C to
    the process group does not stop it (the log process decides); its parent's end does (the
    kernel's SIGTERM: the log process ignores SIGTERM, and that would be inherited)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    from mpnet.workers import end_with_parent

    end_with_parent(int(sys.argv[1]))
    out = os.fdopen(os.dup(1), "wb")  # the results' pipe; anything else printed goes to stderr
    os.dup2(2, 1)
    judge, spec, items, step = pickle.load(sys.stdin.buffer)
    pickle.dump([judge(spec, ws, rec, step) for ws, rec in items], out)
    out.close()


def judge_backlog(messages: list, judge, spec, workspaces: dict, rate: JudgeRate, step: float, write,
                  judges: int = 2, helper_start_s: float = HELPER_START_S) -> tuple[float, int]:  # fmt: skip
    """The backlog (messages up to the close) judged and handed to write(kind, payload) in order:
    ("workspace", ws) as it comes, ("queries", judged records) per batch. With judges > 1 and a
    backlog worth it (at this run's judging rate: helper_share), a second process judges its
    tail. Returns the helper's CPU seconds (from start to exit) and the queries it judged (0.0,
    0 without one). A helper that fails leaves its share to this process; one still running when
    this raises is killed."""
    queue = []  # (batch index, position, workspace, record) of every query, in order
    for i, (kind, payload) in enumerate(messages):
        if kind == "workspace":
            workspaces[(payload.split, payload.id)] = payload
        elif kind == "queries":
            queue += [(i, j, workspaces[ws_key(q)], q) for j, q in enumerate(payload)]
    done: dict[tuple[int, int], dict] = {}
    while judges > 1 and queue and rate.per_state() is None:  # the rate measured on the first success
        i, j, ws, q = queue.pop(0)
        done[(i, j)] = rate.timed(judge, spec, ws, q, step)
    costs = [judged_states(q, step) * (rate.per_state() or 0.0) for *_, q in queue]
    tail = helper_share(costs, helper_start_s) if judges > 1 else 0
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = _start_helper(judge, spec, [(ws, q) for _, _, ws, q in queue[-tail:]], step) if tail else None
    if sum(costs) >= SAY_S:  # the bench's progress bar is done: say what it waits for
        how = "two processes" if tail else "one process"
        print(f"trial log: judging the last {len(queue)} queries ({how}, about {sum(costs) / (1 + bool(tail)):.0f} s)",
              file=sys.stderr, flush=True)  # fmt: skip
    theirs, at = None, {(i, j): k for k, (i, j, _, _) in enumerate(queue[len(queue) - tail :])}
    try:
        for i, (kind, payload) in enumerate(messages):  # written as judged, batch by batch, in order
            if kind == "workspace":
                write(kind, payload)
            if kind != "queries":
                continue
            out = []
            for j, q in enumerate(payload):
                if (i, j) in done:
                    out.append(done.pop((i, j)))
                    continue
                if (k := at.get((i, j))) is not None:
                    if theirs is None:
                        theirs = _collect(proc, tail)
                    if theirs:
                        out.append(theirs[k])
                        continue
                out.append(rate.timed(judge, spec, workspaces[ws_key(q)], q, step))
            write(kind, out)
    finally:
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()
    if proc is None:
        return 0.0, 0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return cpu, tail if theirs else 0


def _collect(proc: subprocess.Popen, n: int) -> list:
    """The helper's n judged records; [] if it died or sent something else."""
    try:
        out = pickle.load(proc.stdout)
    except Exception:  # noqa: BLE001  (whatever it left: its share is judged here)
        out = []
    proc.stdout.close()
    proc.wait()
    return out if isinstance(out, list) and len(out) == n else []
