"""harness.recheck: every logged success re-checked from the log alone."""

from __future__ import annotations

import numpy as np

from harness.log import TrialLog
from harness.recheck import main, recheck_file
from mpnet.envs.specs import get_spec
from mpnet.envs.workspace import Workspace

S2D = get_spec("s2d")
RUN = {
    "env": "s2d",
    "planner": "bit_star",
    "seed": 0,
    "split": "seen",
    "config": "budget_s: 10.0\n",
    "git_rev": "abc1234",
    "versions": {},
    "host": "test",
    "started_at": "2026-11-25T00:00:00+00:00",
}


def write(run_dir, paths: dict[str, list]):
    """A log of one workspace (a 4 x 4 block at the origin) and one success per path."""
    ws = Workspace("w", "seen", np.array([[0.0, 0.0]]), np.array([[4.0, 4.0]]))
    with TrialLog(run_dir, RUN, S2D, rerun=False) as log:
        log.add_workspace(ws)
        for qid, path in paths.items():
            log.add_query(
                dict(
                    query_id=qid,
                    workspace_id="w",
                    split="seen",
                    start=path[0],
                    goal=path[-1],
                    success=True,
                    failure=None,
                    path=path,
                    time_s=0.1,
                    cpu_s=0.1,
                    path_cost=1.0,
                    collision_checks=1,
                    state_checks=1,
                    motion_checks=0,
                )
            )
    return run_dir / "trials.mcap"


def test_a_path_through_a_block_is_a_false_success(tmp_path, capsys):
    around = [[-15.0, -15.0], [-15.0, 15.0], [15.0, 15.0]]
    through = [[-15.0, -15.0], [15.0, 15.0]]  # crosses the block at the origin
    f = write(tmp_path, {"w/0": around, "w/1": through})
    n, false, step = recheck_file(f)
    assert n == 2 and false == [("w/1", "collision")] and step == S2D.validation_step / 2
    assert main([str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "w/1: collision" in out and "false successes 1" in out


def test_clean_logs_pass_and_bad_arguments_are_one_line(tmp_path, capsys):
    write(tmp_path, {"w/0": [[-15.0, -15.0], [-15.0, 15.0]]})
    assert main([str(tmp_path), "--step", "0.001"]) == 0
    assert "1 successes re-checked at step 0.001, 0 false" in capsys.readouterr().out
    assert main([str(tmp_path / "nope")]) == 2
    assert main([str(tmp_path), "--step", "0"]) == 2
    err = capsys.readouterr().err
    assert "nope: no such file or folder" in err and "--step must be a positive number" in err
