"""harness.step_error: Pnet's step error on the paths its fit held out, toward ends and intermediate goals."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import torch

from mpnet import models  # its LightningModules load on first use, not as pytest collects
from mpnet.envs import get_spec
from mpnet.models import Enet, Pnet, waypoint_pairs


def _checkpoint(path, state_dim: int, cloud_dim: int):
    import lightning as L

    torch.manual_seed(0)
    module = models.PnetModule(
        Pnet(4 + 2 * state_dim, state_dim, (16,), dropout=0.1),
        Enet(cloud_dim, (8,), 4),
        freeze_encoder=False,
        state_scale=[3.0] * state_dim,
        cloud_scale=[1.0] * 3,
    )
    trainer = L.Trainer(max_epochs=0, logger=False, enable_checkpointing=False, enable_progress_bar=False)
    trainer.strategy.connect(module)
    trainer.save_checkpoint(path)


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_the_step_error_reads_the_fits_held_out_paths_both_ways(tmp_path):
    from harness.step_error import step_errors

    spec = get_spec("panda_mbm")
    rng = np.random.default_rng(0)
    lengths = [2, 4, 1, 5, 3, 6, 4, 2, 3, 5, 4, 3]
    paths = [rng.uniform(-1, 1, (n, 7)) for n in lengths]
    ws = rng.integers(0, 3, len(paths))
    clouds = rng.normal(size=(3, 30, 3))
    data = SimpleNamespace(paths=SimpleNamespace(paths=lambda: paths, workspace=ws), train_clouds=clouds)
    _checkpoint(tmp_path / "pnet.ckpt", 7, 90)
    params = {"val_fraction": 0.25, "seed": 3}
    out = step_errors(spec, data, params, tmp_path / "pnet.ckpt")
    # the same paths a fit's datamodule holds out (split by path, seeded)
    pairs = waypoint_pairs(paths, ws, space=spec.space)
    dm = models.MPNetDataModule(
        clouds.reshape(3, -1),
        pairs.ws_index,
        pairs.x_t,
        pairs.x_goal,
        pairs.x_next,
        val_fraction=0.25,
        seed=3,
        groups=pairs.path_id,
    )
    held = np.unique(pairs.path_id[dm.val_indices])
    assert out["validation_paths"] == len(held) == 3
    n = np.array(lengths)[held]
    assert out["end"]["pairs"] == 2 * np.sum(n - 1)
    assert out["intermediate"]["pairs"] == np.sum((n - 1) * (n - 2))  # (j, k < end), both ways
    for part in ("end", "intermediate"):
        assert 0 < out[part]["median"] and np.isfinite(out[part]["mean"])


@pytest.mark.slow
def test_the_command_prints_one_json_object(run_cli):
    import json

    p = run_cli("harness.step_error", "+env=s2d", "scale=tiny", "+planner=mpnet_nr", "progress=false")
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert out["planner"] == "mpnet_nr" and out["validation_paths"] > 0
    assert out["end"]["pairs"] > 0 and out["end"]["mean"] > 0
