"""The training stage at tiny scale: Lightning trains Enet then Pnet into the cache,
reproducibly, and the planner-side reader loads the result without Lightning."""

import json
from pathlib import Path

import numpy as np
import pytest
import torch

pytestmark = pytest.mark.slow  # the training CLI in subprocesses


def train(run_cli, cache, *extra, run_dir=None):
    p = run_cli(
        "harness.train",
        "+env=rigid",
        "scale=tiny",
        "progress=false",
        f"cache_dir={cache}",
        f"hydra.run.dir={run_dir or cache / 'run'}",
        *extra,
        timeout=900,
    )
    return next(line for line in p.stdout.splitlines() if line.startswith(("trained:", "cached:")))


def test_train_cli_caches_and_reproduces(tmp_path, run_cli, sweeps_cache):
    out = train(run_cli, tmp_path / "a")
    assert out.startswith("trained:")
    assert train(run_cli, tmp_path / "a").startswith("cached:")
    # the same fit in another process: the session's of the same key (built once, by whichever test first needs it)
    again = train(run_cli, sweeps_cache, run_dir=tmp_path / "again")
    folders = [Path(line.split(": ", 1)[1]) for line in (out, again)]
    assert folders[0].name == folders[1].name and folders[0].parent == tmp_path / "a" / "models"
    manifest = json.loads((folders[0] / "manifest.json").read_text())
    assert manifest["fit"]["pnet"]["pairs"] > 0 and "data_folder" in manifest and manifest["config"]["seed"] == 0
    assert (folders[0] / "pnet_logs" / "version_0" / "metrics.csv").exists()
    a = torch.load(folders[0] / "pnet.ckpt", weights_only=True)["state_dict"]
    b = torch.load(folders[1] / "pnet.ckpt", weights_only=True)["state_dict"]
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)

    from mpnet.models import load_pnet_checkpoint

    nets = load_pnet_checkpoint(folders[0] / "pnet.ckpt")
    encode, step = nets.to_numpy()
    z = encode(np.zeros((1400, 2), np.float32))
    x = step(z, np.array([1.0, 2.0, 0.5]), np.array([-3.0, 4.0, -1.0]), np.random.default_rng(0))
    assert x.shape == (3,) and np.all(np.isfinite(x))
    other = train(run_cli, tmp_path / "a", "train.seed=1")
    assert other.startswith("trained:")
