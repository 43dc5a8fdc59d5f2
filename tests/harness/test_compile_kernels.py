"""harness.compile_kernels: the kernels it compiles are those a run calls (the shipped networks'
and every scale's depths), so a run after it compiles nothing; its CLI."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from harness.compile_kernels import network_depths, untrained_networks
from mpnet.envs.specs import get_spec
from mpnet.models.pnet_kernel import PnetKernel
from mpnet.models.pretrained import SHIPPED, read_meta
from tests.conftest import wait_for_kernels


@pytest.mark.slow  # ~60 compositions of the config
def test_network_depths_are_the_composed_scales():
    """tiny's (2, 3), quick's and paper's: the arms' own scale settings (env_scale) replace the
    generic ones, so their paper Pnet has 8 hidden layers, the planar envs' 11."""
    depths = {env: network_depths(env) for env in ("s2d", "c2d", "c3d", "rigid", "arm7", "panda_mbm")}
    s2d, panda = depths["s2d"], depths["panda_mbm"]
    assert (2, 3) in s2d and (3, 4) in s2d and (3, 11) in s2d and not any(p == 8 for _, p in s2d)
    assert (2, 3) in panda and (2, 4) in panda and (3, 8) in panda and not any(p == 11 for _, p in panda)
    assert [p for _, p in s2d] == sorted(p for _, p in s2d)  # fewest layers (the tests' tiny) first
    for env, got in depths.items():  # the shipped networks' depths are among them
        hp = read_meta(SHIPPED / f"{env}-quick")["hyper_parameters"]
        assert (len(hp["encoder"]["hidden"]), len(hp["pnet"]["hidden"])) in got


@pytest.mark.parametrize("depths", [(2, 3), (3, 11)])
def test_untrained_networks_have_the_depths_and_step(depths):
    spec = get_spec("rigid")
    enet, pnet = untrained_networks(spec, 40, depths)
    assert len(enet.weights) == depths[0] + 1 and len(pnet.weights) == depths[1] + 1
    z = enet.encode(np.zeros((20, 2)))
    x = PnetKernel(pnet).step(z, np.zeros(3), np.ones(3))
    assert x.shape == (3,) and np.isfinite(x).all()


# In a fresh interpreter: a worker's earlier tests may have specialised the kernels already.
AFTER_COMPILE = """
import sys
import numpy as np
from harness.compile_kernels import compile_env, network_depths
from mpnet.envs.specs import get_spec
from mpnet.models.pretrained import SHIPPED, write_checkpoint
from mpnet.planners.compiled import batched
from mpnet.planners.compiled import kernels as K
from mpnet.planners.base import Problem
from mpnet.planners.mpnet import from_checkpoint

env, folder = sys.argv[1], sys.argv[2]
spec = get_spec(env)
depths = network_depths(env)
compile_env(spec, depths)
kernels = (K.neural_planner, K.contract, K.is_feasible, K.lockstep)
before = [len(f.signatures) for f in kernels]
assert before[0] == 1 < len({p for _, p in depths}), before  # one specialisation serves every depth
write_checkpoint(SHIPPED / f"{env}-quick", f"{folder}/pnet.ckpt")
ws = spec.generator.make(1, "seen", 0)
planner = from_checkpoint(folder, spec, 0, lambda w: spec.cloud(w, 200, 0), name="mpnet_nr", compiled=True)
rng = np.random.default_rng(1)
start, goal = spec.space.sample(rng), spec.space.sample(rng)
batched.warm_up(planner, Problem(spec, ws, spec.make_checker(ws), start, goal, seed=0))
assert [len(f.signatures) for f in kernels] == before, ([len(f.signatures) for f in kernels], before)
"""


@pytest.mark.slow
@pytest.mark.parametrize("env", ["s2d", "panda_mbm"])
def test_a_run_after_it_compiles_no_kernel_more(env, tmp_path):
    """After compile_env, the shipped quick networks' planner (what a run builds) warms up, its
    batched planning too, with the loop's specialisations already there: none is added. One
    specialisation of the loop serves every network depth (Pnet's layers travel flat)."""
    wait_for_kernels()  # else a cold cache's arm would compile here too, beside the session's compile
    p = subprocess.run([sys.executable, "-c", AFTER_COMPILE, env, str(tmp_path)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-3000:]


@pytest.mark.slow
def test_compile_kernels_cli(run_cli):
    p = run_cli("harness.compile_kernels", "s2d", "rigid", "arm7")
    lines = p.stdout.strip().splitlines()
    assert [line.split(":")[0] for line in lines] == ["s2d", "rigid", "arm7"]
    assert "Pnet of 3, 4, 11 hidden layers" in lines[0] and "Pnet of 3, 4, 8 hidden layers" in lines[2]
    bad = run_cli("harness.compile_kernels", "s3d", check=False)
    assert bad.returncode == 2 and bad.stderr.strip().splitlines() == [
        "error: unknown env 's3d'; choices: arm7, c2d, c3d, mbm_fetch, mbm_ur5, panda_mbm, rigid, s2d"
    ]
