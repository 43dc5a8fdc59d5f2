"""MPNet's LightningModules: Enet then Pnet trained and reloaded, precomputed codes, Pnet's
module end to end, input noise; the package imported without Lightning."""

import math
import subprocess
import sys

import numpy as np
import pytest
import torch

from mpnet import models  # its LightningModules load on first use, not as pytest collects
from mpnet.models import ContractiveAE, Decoder, Enet, Pnet, load_enet_checkpoint, load_pnet_checkpoint
from tests.mpnet.models._helpers import _pair_data

SCALES_2D = {"state_scale": [20.0, 20.0], "cloud_scale": 20.0}  # the s2d bounds: [-20, 20]^2


# --------------------------------------------------------------------------- Lightning


def _trainer(tmp_path):
    import lightning

    return lightning.Trainer(
        max_epochs=2,
        accelerator="cpu",
        logger=False,
        enable_checkpointing=True,
        default_root_dir=tmp_path,
        enable_progress_bar=False,
        enable_model_summary=False,
    )


def _ae_loss(module: "models.EnetModule", clouds: np.ndarray) -> float:
    with torch.no_grad():
        return float(module.losses(torch.from_numpy(clouds))[0])


def _pnet_loss(module: "models.PnetModule", data) -> float:
    clouds, ws, x_t, x_goal, x_next = (torch.as_tensor(a) for a in data)
    batch = {"clouds": clouds.float(), "ws": ws, "x_t": x_t.float(), "x_goal": x_goal.float(), "x_next": x_next.float()}
    with torch.no_grad():
        return float(module.batch_loss(batch, stochastic=False)[0])


@pytest.mark.slow  # over ~1.3 s: out of the fast loop
def test_train_enet_then_pnet_and_reload(tmp_path):
    import lightning

    lightning.seed_everything(0)
    data = _pair_data()
    clouds = data[0]
    # a low-rank family of clouds, so the autoencoder has something to learn in 2 epochs
    rng = np.random.default_rng(0)
    ae_clouds = (rng.normal(size=(512, 3)) @ rng.normal(size=(3, 120)) * 4).astype(np.float32)
    enet = Enet(120, (32, 16), 6)
    emod = models.EnetModule(
        ContractiveAE(enet, Decoder.mirror(enet)), lr=1e-2, lam=1e-4, optimizer="adam", cloud_scale=20.0
    )
    before = _ae_loss(emod, ae_clouds)
    trainer = _trainer(tmp_path / "enet")
    trainer.fit(emod, models.CloudDataModule(ae_clouds, batch_size=16, val_fraction=0.25, seed=0))
    assert {"train_loss", "val_loss", "train_penalty"} <= set(trainer.callback_metrics)
    assert _ae_loss(emod, ae_clouds) < 0.7 * before
    ckpt = trainer.checkpoint_callback.best_model_path
    again = models.EnetModule.load_from_checkpoint(ckpt)
    assert again.hparams == emod.hparams and again.hparams["lam"] == 1e-4
    for k, v in emod.state_dict().items():
        assert torch.equal(v, again.state_dict()[k])
    ae, cloud_norm = load_enet_checkpoint(ckpt)
    assert cloud_norm.to_list() == [20.0]
    with torch.no_grad():
        assert torch.equal(ae.encoder(torch.ones(1, 120)), emod.ae.encoder(torch.ones(1, 120)))

    # Pnet on the trained (frozen) encoder
    enc_before = {k: v.clone() for k, v in emod.encoder.state_dict().items()}
    pmod = models.PnetModule(Pnet(6 + 4, 2, (64, 32, 16)), emod.encoder, lr=3e-3, optimizer="adam", **SCALES_2D)
    before = _pnet_loss(pmod, data)
    trainer = _trainer(tmp_path / "pnet")
    trainer.fit(pmod, models.MPNetDataModule(*data, batch_size=50, val_fraction=0.1, seed=0))
    assert {"train_loss", "val_loss"} <= set(trainer.callback_metrics)
    assert _pnet_loss(pmod, data) < 0.5 * before
    for k, v in pmod.encoder.state_dict().items():
        assert torch.equal(v, enc_before[k])  # frozen
    ckpt = trainer.checkpoint_callback.best_model_path
    again = models.PnetModule.load_from_checkpoint(ckpt)
    assert again.hparams == pmod.hparams and again.freeze_encoder
    for k, v in pmod.state_dict().items():
        assert torch.equal(v, again.state_dict()[k])
    cloud = torch.from_numpy(clouds[3])
    x, g = torch.tensor([[1.0, 2.0]]), torch.tensor([[-5.0, 7.0]])
    with torch.inference_mode():
        ref = pmod(cloud, x, g, stochastic=False)
        assert torch.equal(again(cloud, x, g, stochastic=False), ref)
    # without Lightning: the planner's reader and its numpy versions agree
    nets = load_pnet_checkpoint(ckpt)
    assert nets.state_norm.to_list() == [20.0, 20.0] and nets.cloud_norm.to_list() == [20.0]
    np_enet, np_pnet = nets.to_numpy()
    z = np_enet(clouds[3].reshape(60, 2))
    np.testing.assert_allclose(z, nets.encode(clouds[3].reshape(60, 2)).numpy(), rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(np_pnet(z, x[0].numpy(), g[0].numpy()), ref[0].numpy(), rtol=1e-4, atol=1e-4)


def test_precomputed_codes_give_the_same_loss_as_clouds():
    """Training on a frozen encoder's codes, computed once, is training on the clouds."""
    torch.manual_seed(0)
    clouds, ws, x_t, x_goal, x_next = _pair_data(n=50)
    mod = models.PnetModule(Pnet(4 + 4, 2, (16, 8)), Enet(120, (16,), 4), **SCALES_2D)
    with torch.no_grad():
        codes = mod.encode(torch.from_numpy(clouds).float()).numpy()
    by_cloud = models.MPNetDataModule(clouds, ws, x_t, x_goal, x_next, batch_size=50, val_fraction=0.2, seed=0)
    by_code = models.MPNetDataModule(
        codes, ws, x_t, x_goal, x_next, batch_size=50, val_fraction=0.2, seed=0, features="codes"
    )
    by_cloud.setup("fit")
    by_code.setup("fit")
    (a,), (b,) = list(by_cloud.val_dataloader()), list(by_code.val_dataloader())
    assert "codes" in b and "clouds" not in b
    with torch.no_grad():
        la, lb = mod.batch_loss(a, stochastic=False)[0], mod.batch_loss(b, stochastic=False)[0]
    assert torch.allclose(la, lb, rtol=1e-5, atol=1e-7)
    end_to_end = models.PnetModule(Pnet(4 + 4, 2, (16, 8)), Enet(120, (16,), 4), freeze_encoder=False, **SCALES_2D)
    with pytest.raises(ValueError, match="frozen"):
        end_to_end.batch_loss(b, stochastic=False)
    with pytest.raises(ValueError):
        models.MPNetDataModule(codes, ws, x_t, x_goal, x_next, 8, 0.1, 0, features="pixels")


def test_pnet_module_end_to_end_and_checks():
    torch.manual_seed(0)
    enet = Enet(120, (16,), 4)
    mod = models.PnetModule(
        Pnet(4 + 6, 3, (16, 8)), enet, freeze_encoder=False, state_scale=[20.0, 20.0, math.pi], cloud_scale=20.0
    )
    opt = mod.configure_optimizers()
    n_opt = sum(p.numel() for grp in opt.param_groups for p in grp["params"])
    assert n_opt == sum(p.numel() for p in mod.parameters())
    assert isinstance(opt, torch.optim.Adagrad)
    batch = (torch.randn(5, 120), torch.randn(5, 3), torch.randn(5, 3), torch.randn(5, 3))
    mod.batch_loss(batch, stochastic=True)[0].backward()
    assert all(p.grad is not None for p in enet.parameters())
    frozen = models.PnetModule(
        Pnet(4 + 6, 3, (16, 8)), Enet(120, (16,), 4), state_scale=[20, 20, math.pi], cloud_scale=20.0
    )
    n_opt = sum(p.numel() for grp in frozen.configure_optimizers().param_groups for p in grp["params"])
    assert n_opt == sum(p.numel() for p in frozen.pnet.parameters())
    with pytest.raises(ValueError):
        models.PnetModule(Pnet(11, 3, (16,)), Enet(120, (16,), 4), **SCALES_2D)
    with pytest.raises(ValueError):
        models.PnetModule(Pnet(10, 3, (16,)), Enet(120, (16,), 4), optimizer="sgd", **SCALES_2D)


@pytest.mark.slow
def test_importing_the_package_does_not_import_lightning():
    code = (
        "import sys, mpnet.models, mpnet.models.networks, mpnet.models.checkpoint; "
        "assert 'lightning' not in sys.modules and 'pytorch_lightning' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def test_input_noise_moves_only_the_training_states():
    """The DART-style recipe option: training batches see x_t moved by N(0, noise^2) (so the loss
    changes), validation and the zero default see the states as given; it is saved with the
    module and a negative noise is refused."""
    torch.manual_seed(0)
    batch = (torch.randn(64, 120), torch.randn(64, 2), torch.randn(64, 2), torch.randn(64, 2))
    noisy = models.PnetModule(Pnet(4 + 4, 2, (16, 8), dropout=0.0), Enet(120, (16,), 4), input_noise=3.0, **SCALES_2D)
    plain = models.PnetModule(Pnet(4 + 4, 2, (16, 8), dropout=0.0), Enet(120, (16,), 4), **SCALES_2D)
    plain.load_state_dict(noisy.state_dict())
    with torch.no_grad():
        clean = plain.batch_loss(batch, stochastic=False)[0]
        assert torch.equal(noisy.batch_loss(batch, stochastic=False)[0], clean)  # validation: no noise
        assert not torch.equal(noisy.batch_loss(batch, stochastic=False, noise=noisy.input_noise)[0], clean)
    assert noisy.hparams["input_noise"] == 3.0 and "input_noise" not in plain.hparams
    with pytest.raises(ValueError, match="input_noise"):
        models.PnetModule(Pnet(4 + 4, 2, (16, 8)), Enet(120, (16,), 4), input_noise=-1.0, **SCALES_2D)


def test_fused_optimizer_takes_the_same_first_step_and_is_saved_only_when_set():
    """train.fused: torch's fused step (one kernel over every parameter), both modules; its first
    Adagrad step equals the per-tensor one's to rounding, it is in the saved hyper-parameters
    only when set (the checkpoints and keys of unfused fits stay as they were)."""
    batch = (torch.randn(16, 120), torch.randn(16, 2), torch.randn(16, 2), torch.randn(16, 2))
    weights = {}
    for fused in (False, True):
        torch.manual_seed(0)
        mod = models.PnetModule(Pnet(4 + 4, 2, (16, 8), dropout=0.0), Enet(120, (16,), 4), fused=fused, **SCALES_2D)
        opt = mod.configure_optimizers()
        assert bool(opt.defaults.get("fused")) is fused and ("fused" in mod.hparams) is fused
        mod.batch_loss(batch, stochastic=False)[0].backward()
        opt.step()
        weights[fused] = torch.cat([p.detach().flatten() for p in mod.parameters()])
    assert not torch.equal(weights[False], torch.cat([p.detach().flatten() for p in Enet(120, (16,), 4).parameters()]))
    torch.testing.assert_close(weights[True], weights[False], rtol=1e-5, atol=1e-6)
    ae = models.EnetModule(ContractiveAE(Enet(120, (16,), 4), Decoder(120, (16,), 4)), fused=True, cloud_scale=20.0)
    assert ae.configure_optimizers().defaults["fused"] and ae.hparams["fused"]
