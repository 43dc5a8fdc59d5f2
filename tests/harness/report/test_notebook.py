"""The example notebook (examples/explore_a_run.ipynb): committed without outputs, and it runs
end to end on a tiny run in a real kernel, drawing its figures."""

import os

import nbformat
import pytest
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

NOTEBOOK = "examples/explore_a_run.ipynb"


def execute(repo, env: dict[str, str], monkeypatch):
    """Run the notebook as Jupyter would (cwd examples/, kernel python3), with `env` set and
    this checkout first on the kernel's path; returns the executed notebook."""
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    paths = [str(repo), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(paths))
    monkeypatch.setenv("OMP_NUM_THREADS", os.environ.get("OMP_NUM_THREADS", "1"))
    nb = nbformat.read(repo / NOTEBOOK, as_version=4)
    client = NotebookClient(
        nb, kernel_name="python3", timeout=300, resources={"metadata": {"path": str(repo / "examples")}}
    )
    client.execute()
    return nb


def outputs(nb):
    return [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]


def test_committed_without_outputs(repo):
    nb = nbformat.read(repo / NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code and all(not c.outputs and c.execution_count is None for c in code)
    assert nb.metadata.kernelspec.name == "python3"


@pytest.mark.slow
def test_notebook_runs_on_a_tiny_run(tmp_path, run_cli, repo, monkeypatch):
    run_dir, png = tmp_path / "run", tmp_path / "query.png"
    run_cli("harness", "+env=s2d", "+planner=bit_star", "scale=tiny", "rerun=false", f"hydra.run.dir={run_dir}")
    nb = execute(repo, {"MPNET_RUN_DIR": str(run_dir), "MPNET_FIGURE": str(png), "MPNET_QUERY": "1/0"}, monkeypatch)
    outs = outputs(nb)
    assert not [o for o in outs if o.output_type == "error"]
    text = "".join(o.get("text", "") + o.get("data", {}).get("text/plain", "") for o in outs)
    assert "s2d / bit_star / seed 0: 8 queries in 4 workspaces" in text
    assert "agree on all 8 queries" in text and "success_rate" in text
    assert sum("image/png" in o.get("data", {}) for o in outs) == 2  # time per split, and the query
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_notebook_says_when_the_run_is_missing(tmp_path, repo, monkeypatch):
    with pytest.raises(CellExecutionError, match="no trials.mcap in .*make a run first"):
        execute(repo, {"MPNET_RUN_DIR": str(tmp_path / "nothing")}, monkeypatch)
