"""The trial log and the fine re-check in a child process, off the planning loop.

Writing a query to MCAP, Foxglove, Rerun and CSV costs ~150 us of Python and the fine
re-check ~0.3 ms: together half the time BIT* needs for an s2d query. The bench loop
only hands each finished query to this process over a pipe (~20 us), which judges it
(mpnet.motion.verify_path), logs it and tallies it for the summary. Being apart also makes the
judge independent of the planner's process, and the only place where `success` is decided.

Crash safety holds: the child ignores Ctrl-C and SIGTERM and finalises when the bench
closes the log, raises, is interrupted, or dies (the pipe ends); every query it received
is logged.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
import time
from pathlib import Path

from harness.core.provenance import peak_rss_mb, restart_peak_rss
from harness.log.drain import HELPER_START_S, JudgeRate, ReadAhead, judge_backlog, ws_key
from harness.log.tally import Tally
from mpnet.motion import path_cost, verify_path


def judge(spec, ws, rec: dict, validation_step: float) -> dict:
    """The record with `success` decided and the path's cost.

    `rec["failure"]` is the planner's side: None when it claimed an exact solution within
    the budget, else the reason. The claim stands only if the path passes the independent
    fine re-check; otherwise the failure becomes `recheck_<why>`. `success` is placed just
    before `failure` (any `success` the record carried is not trusted and is replaced).
    """
    path = [[float(x) for x in q] for q in rec["path"]]
    failure = rec["failure"]
    if failure is None:
        why = verify_path(spec, ws, path, rec["start"], rec["goal"], validation_step)
        if why:
            failure = f"recheck_{why}"
    out = {}
    for k, v in rec.items():
        if k == "failure":
            out["success"] = failure is None
            out["failure"] = failure
        elif k == "path":
            out["path"] = path
        elif k != "success":
            out[k] = v
    out["path_cost"] = path_cost(spec, path) if len(path) > 1 else None
    return out


def _serve(
    inbox,
    conn,
    run_dir: str,
    run: dict,
    spec,
    validation_step: float,
    log_kwargs: dict,
    parents_ends=(),
    judges: int = 1,
    helper_start_s: float = HELPER_START_S,
) -> None:
    # The parent decides when to stop: a Ctrl-C or a scheduler's SIGTERM sent to the whole
    # process group must not kill the log before it has written what it received.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    for end in parents_ends:  # forked: the parent's ends closed here, so its death ends the pipe
        end.close()
    rss0 = restart_peak_rss() if parents_ends else 0.0
    from harness.log.writer import TrialLog

    try:
        log = TrialLog(run_dir, run, spec, **log_kwargs)
    except Exception as e:  # noqa: BLE001  (reported to the parent, which raises it)
        conn.send(("error", e))
        return
    conn.send(("ready", (log.done, log.logged_obstacles(), log.notes)))
    workspaces: dict[tuple[str, str], object] = {}
    tally, rate = Tally(), JudgeRate()
    cpu0 = time.process_time()

    def write(kind: str, payload) -> None:
        if kind == "workspace":
            log.add_workspace(payload)
            return
        for rec in payload:  # one MCAP chunk per batch: a chunk index per query grew with the run
            log.add_query(rec, flush=False)
            tally.add(rec)
        log.flush()

    inbox = ReadAhead(inbox)  # the bench never waits on a full pipe (harness.log.drain)
    kind, payload, rest = None, None, []
    with log:
        while not inbox.closing:
            kind, payload = inbox.get()
            if kind == "workspace":
                workspaces[(payload.split, payload.id)] = payload
                write(kind, payload)
            elif kind == "queries":
                judged = []
                for n, q in enumerate(payload):
                    if inbox.closing and n:  # the close came: the batch's rest joins the backlog
                        rest = [(kind, payload[n:])]
                        break
                    judged.append(rate.timed(judge, spec, workspaces[ws_key(q)], q, validation_step))
                write(kind, judged)
            else:  # close, eof, error
                break
        # the bench has closed the log (or died: everything it sent is still judged and logged),
        # so nothing is timed any more: what is left may take a second process
        rest += inbox.rest()
        helper_cpu, helped = judge_backlog(
            rest, judge, spec, workspaces, rate, validation_step, write, judges, helper_start_s
        )
        last, why = rest[-1] if rest else (kind, payload)
        if last == "error":
            raise why  # unreadable: finalised (`with`); the bench sees the process die
        if last == "eof":
            return  # the parent died: `with` finalises what was received
    cpu_s = time.process_time() - cpu0 + helper_cpu
    conn.send(("closed", {"tally": tally, "cpu_s": cpu_s, "peak_rss_mb": peak_rss_mb() - rss0, "helped": helped}))


def one_thread() -> bool:
    """Does this process run a single thread? Only then may it fork: the copy is whole, with no
    lock held by a thread that is not there (OMPL and the thread pools start theirs later, or
    never). A forked child has its parent's imports and loaded kernels, ~1 CPU-s less a child."""
    try:
        return len(os.listdir("/proc/self/task")) == 1
    except OSError:
        return False


@contextlib.contextmanager
def starting():
    """The context to start a child in: fork while this process runs one thread, else spawn
    (spawning)."""
    if one_thread():
        yield mp.get_context("fork")
    else:
        with spawning() as ctx:
            yield ctx


def _widen(conn, size: int = 1 << 20) -> None:
    """Grow a pipe's kernel buffer (Linux F_SETPIPE_SZ; up to /proc/sys/fs/pipe-max-size)."""
    try:
        import fcntl

        fcntl.fcntl(conn.fileno(), getattr(fcntl, "F_SETPIPE_SZ", 1031), size)
    except (ImportError, OSError):
        pass


@contextlib.contextmanager
def spawning():
    """multiprocessing's spawn context to start children in, inside joblib's loky workers too.
    A spawned child re-applies its parent's default start method, which is 'loky' there and
    unknown to a plain child: while the block starts children the default is spawn, and the
    parent's own is put back when it ends (nothing outlives the block)."""
    method = mp.get_start_method(allow_none=True)
    plain = method in (None, "spawn", "fork", "forkserver")
    if not plain:
        mp.set_start_method("spawn", force=True)
    try:
        yield mp.get_context("spawn")
    finally:
        if not plain:
            mp.set_start_method(method, force=True)


# Queries go to the log process in small batches: one pipe send costs ~10 us, more than a
# fast planner's whole query takes to hand off otherwise. A batch leaves after this many
# queries or this long after the last one, whichever comes first, and on close (an error or a
# Ctrl-C included); only a kill -9 can lose it, and resume then plans those queries again.
FLUSH_QUERIES = 32
FLUSH_S = 0.2


class LogProcessDied(RuntimeError):
    """The trial-log process ended before the bench closed it (killed, or out of memory)."""


class LogProcess:
    """TrialLog's interface (add_workspace, add_query, done, context manager), served by
    a child process that also judges each query. close() returns the run's Tally."""

    def __init__(
        self,
        run_dir: str | Path,
        run: dict,
        spec,
        *,
        validation_step: float,
        rerun: bool = True,
        resume: bool = False,
        judges: int = 1,
        helper_start_s: float = HELPER_START_S,
    ):
        # Queries go down a one-way pipe widened to hold hundreds of them, so the loop never
        # waits on a burst of slow writes (a Rerun batch); replies come up a second pipe.
        with starting() as ctx:  # never fork a process that has started threads (OMPL's, a pool's)
            forked = ctx.get_start_method() == "fork"
            inbox, self._outbox = ctx.Pipe(duplex=False)
            self._conn, reply = ctx.Pipe(duplex=False)
            _widen(self._outbox)
            self._proc = ctx.Process(
                target=_serve,
                name="trial-log",
                daemon=True,
                args=(inbox, reply, str(run_dir), run, spec, validation_step, {"rerun": rerun, "resume": resume}),
                kwargs={
                    "parents_ends": (self._outbox, self._conn) if forked else (),
                    "judges": judges,
                    "helper_start_s": helper_start_s,
                },
            )
            self._proc.start()
        inbox.close()
        reply.close()
        self.tally = Tally()
        self.child_cpu_s = 0.0
        self.child_peak_rss_mb = float("nan")
        self.helped = 0
        self._closed = False
        self._pending: list[dict] = []
        self._sent_at = time.perf_counter()
        kind, payload = self._recv()
        if kind == "error":
            self._proc.join()
            self._closed = True
            raise payload
        self.done: set[tuple[str, str]] = payload[0]
        self.logged_obstacles: dict[tuple[str, str], list] = payload[1]
        self.notes: list[str] = payload[2]

    def _died(self) -> LogProcessDied:
        self._proc.join(timeout=5)
        self._closed = True
        return LogProcessDied(f"the trial-log process died (exit code {self._proc.exitcode})")

    def _recv(self):
        try:
            return self._conn.recv()
        except (EOFError, OSError):
            raise self._died() from None

    def _send(self, msg) -> None:
        try:
            self._outbox.send(msg)
        except OSError:  # BrokenPipeError: nobody reads the pipe any more
            raise self._died() from None

    def add_workspace(self, ws) -> None:
        self._send(("workspace", ws))

    def add_query(self, rec: dict) -> None:
        self._pending.append(rec)
        if len(self._pending) >= FLUSH_QUERIES or time.perf_counter() - self._sent_at > FLUSH_S:
            self.flush()

    def flush(self) -> None:
        """Send the queries not yet sent."""
        if self._pending:
            pending, self._pending = self._pending, []
            self._send(("queries", pending))
        self._sent_at = time.perf_counter()

    def close(self) -> Tally:
        if self._closed:
            return self.tally
        self._closed = True
        self.flush()
        self._send(("close", None))
        _, payload = self._recv()
        self._proc.join()
        self.tally, self.child_cpu_s = payload["tally"], payload["cpu_s"]
        self.child_peak_rss_mb = payload["peak_rss_mb"]
        self.helped = payload["helped"]  # queries a second judge took once planning was done (harness.log.drain)
        return self.tally

    def __enter__(self) -> LogProcess:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
