"""Ctrl-C during Pnet's fit keeps the finished Enet (its own artifact), says so, and the
next fit resumes at Pnet, training the same Pnet as a fit run straight through."""

import os
import selectors
import signal
import subprocess
import sys
import time

import pytest
import torch

from tests.harness._cli import printed_folder

pytestmark = pytest.mark.slow  # the training CLI in subprocesses

# Pnet wide and with epochs enough that its fit is still running when Ctrl-C comes.
LONG_PNET = ("scale.fit.pnet_epochs=100000", "scale.model.pnet_hidden=[2048,2048]")


def _args(cache, *extra, run_dir=None):
    run = run_dir or cache / "run"
    return ["harness.train", "+env=s2d", "scale=tiny", f"cache_dir={cache}", f"hydra.run.dir={run}", *extra]


def _interrupt_in_pnet(repo, cache) -> tuple[int, str]:
    """Run the fit, send SIGINT once Pnet's bar appears; (exit status, stderr)."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "HYDRA_FULL_ERROR": "0"}
    p = subprocess.Popen(
        [sys.executable, "-m", *_args(cache, *LONG_PNET)],
        cwd=repo,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env=env,
        # Ctrl-C's default action, as in a terminal: a suite started in the background by a
        # non-interactive shell (`cmd &`) ignores SIGINT, its children inherit that, and Python
        # then never raises KeyboardInterrupt (the fit ran on to early stopping)
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    sel = selectors.DefaultSelector()
    sel.register(p.stderr, selectors.EVENT_READ)
    err, deadline = b"", time.monotonic() + 300
    try:
        while b"Pnet 0/" not in err:
            assert time.monotonic() < deadline and p.poll() is None, err.decode()
            if sel.select(1):
                err += os.read(p.stderr.fileno(), 1 << 16)
        p.send_signal(signal.SIGINT)
        err += p.communicate(timeout=120)[1]
    finally:
        if p.poll() is None:
            p.kill()
    return p.returncode, err.decode()


def test_ctrl_c_in_pnet_keeps_enet_and_resumes(tmp_path, repo, run_cli, sweeps_cache):
    cache = tmp_path / "a"
    rc, err = _interrupt_in_pnet(repo, cache)
    (enet,) = [d for d in (cache / "enet").iterdir() if d.is_dir()]
    assert rc == 130, err
    assert f"interrupted: Enet is kept in {enet}; the same command resumes at Pnet" in err
    # Pnet's fit was cut short: no models artifact, only its partial folder (no epoch finished)
    folders = [d.name for d in (cache / "models").iterdir() if d.is_dir()]
    assert len(folders) == 1 and folders[0].startswith(".") and folders[0].endswith(".partial"), folders
    stamp = (enet / "manifest.json").stat().st_mtime_ns

    resumed = run_cli(*_args(cache, "progress=false"), timeout=600)  # the tiny Pnet: a short fit
    assert f"Enet: cached in {enet}" in resumed.stderr
    assert (enet / "manifest.json").stat().st_mtime_ns == stamp

    # a fit not cut short: the session's of the same key, built once by whichever test needs it first
    # (its Enet cached before or not, the same Pnet: test_enet_artifact_trains_what_one_fit_did)
    straight = run_cli(*_args(sweeps_cache, "progress=false", run_dir=tmp_path / "straight"), timeout=600)
    folders = [printed_folder(p.stdout) for p in (resumed, straight)]
    assert folders[0].name == folders[1].name and folders[0] != folders[1]
    pnets = [torch.load(f / "pnet.ckpt", weights_only=True)["state_dict"] for f in folders]
    assert pnets[0].keys() == pnets[1].keys() and all(torch.equal(pnets[0][k], pnets[1][k]) for k in pnets[0])


def test_enet_artifact_trains_what_one_fit_did(tmp_path, settings, sweeps_cache):
    """Enet cached on its own, then Pnet: the same Pnet as one fit of both with no artifact
    between (Pnet's fit starts from the random state Enet's left, kept in the artifact)."""
    from harness.artifacts.ensure import ensure_dataset
    from harness.artifacts.fit import _fit_autoencoder, _fit_pnet, _quiet_lightning, fit_enet, fit_models, load_encoder
    from mpnet.data.dataset import load_dataset

    run = settings(["+env=s2d", "scale=tiny", f"cache_dir={sweeps_cache}"])  # the session's data; fits here
    spec, params, lightning = run.env.spec, run.models, run.lightning
    data = load_dataset(*ensure_dataset(run, progress=False)[:2])
    one, enet, models = (tmp_path / n for n in ("one", "enet", "models"))
    for f in (one, enet, models):
        f.mkdir()

    _quiet_lightning(params["seed"])  # the fit before Enet was an artifact of its own
    flat = data.train_clouds.reshape(len(data.train_clouds), -1)
    _fit_autoencoder(spec, data, params, lightning, one, False, flat)
    with torch.random.fork_rng():  # _fit_autoencoder loaded the best encoder once already
        encoder = load_encoder(one)
    _fit_pnet(spec, data, params, lightning, one, False, encoder, flat, frozen=True)

    fields = fit_enet(spec, data, params, lightning, enet, False)
    fit_models(spec, data, params, lightning, models, False, enet=(enet, {"key": "k", **fields}))
    a, b = (torch.load(f / "pnet.ckpt", weights_only=True)["state_dict"] for f in (one, models))
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def _pnet(folder):
    return torch.load(folder / "pnet.ckpt", weights_only=True)["state_dict"]


def test_a_fit_cut_short_goes_on_from_its_last_epoch(tmp_path, settings, monkeypatch, capsys, sweeps_cache):
    """A fit stopped after its second epoch (a killed job, a session's end) resumes from the
    epoch kept in its partial folder and trains the Pnet a fit run straight through trains,
    bit for bit; a kept epoch that does not load is dropped with a warning, not used."""
    from harness.artifacts import fit
    from harness.artifacts.ensure import ensure_dataset
    from mpnet.data.dataset import load_dataset

    run = settings(["+env=s2d", "scale=tiny", f"cache_dir={sweeps_cache}", "scale.fit.pnet_epochs=4"])  # its data
    spec, params, lightning = run.env.spec, {**run.models, "patience": 10}, run.lightning
    data = load_dataset(*ensure_dataset(run, progress=False)[:2])
    straight, cut, work, damaged, work2 = (tmp_path / n for n in ("straight", "cut", "work", "damaged", "work2"))
    for f in (straight, cut, work, damaged, work2):
        f.mkdir()
    whole = fit.fit_models(spec, data, params, lightning, straight, False)["fit"]["pnet"]
    assert whole["epochs"] == 4 and "resumed_at_epoch" not in whole
    assert not (straight / "pnet.last.ckpt").exists()  # without a partial folder nothing more is written

    real = fit._resume_state

    def cut_at_epoch_2(started):
        callback = real(started)

        def stop(trainer, module):
            if trainer.current_epoch == 2:
                raise KeyboardInterrupt

        callback.on_train_epoch_start = stop
        return callback

    monkeypatch.setattr(fit, "_resume_state", cut_at_epoch_2)
    with pytest.raises(KeyboardInterrupt, match=f"Pnet's fit is kept at epoch 2 in {work}; the same command resumes"):
        fit.fit_models(spec, data, params, lightning, cut, False, resume=work)
    monkeypatch.undo()
    assert not (cut / "pnet.ckpt").exists() and (work / "pnet.last.ckpt").exists()

    resumed = fit.fit_models(spec, data, params, lightning, cut, False, resume=work)["fit"]["pnet"]
    assert resumed["resumed_at_epoch"] == 2 and resumed["epochs"] == 4
    assert resumed["best_val_loss"] == whole["best_val_loss"]
    a, b = _pnet(straight), _pnet(cut)
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert (cut / "pnet_logs").is_dir() and not (work / "pnet.ckpt").exists()  # moved into the artifact

    (work2 / "pnet.last.ckpt").write_bytes(b"not a checkpoint")  # cut short while writing it
    fit.fit_models(spec, data, params, lightning, damaged, False, resume=work2)
    assert f"warning: {work2 / 'pnet.last.ckpt'}: unreadable" in capsys.readouterr().err
    c = _pnet(damaged)
    assert all(torch.equal(a[k], c[k]) for k in a)
