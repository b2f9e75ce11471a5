"""CWT-ResNet-ML: the ResNet-18 layout under torchvision's key names, starting from a
state dict the test writes itself (never unpickled objects), the 4-channel stem, the
choice of the epoch count on held-out training classes and the refit on all of them, and
``--method-option CWT-ResNet-ML:weights=PATH``."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import torch

from models import cwt_resnet
from models.cwt_resnet import CWTResNetML, ResNet18, load_resnet18_weights
from tests.synthetic_data import make_dataset

#: torchvision's resnet18 state-dict keys of one BasicBlock with a downsample.
BLOCK_KEYS = (
    "conv1.weight bn1.weight bn1.bias bn1.running_mean bn1.running_var bn1.num_batches_tracked "
    "conv2.weight bn2.weight bn2.bias bn2.running_mean bn2.running_var bn2.num_batches_tracked "
    "downsample.0.weight downsample.1.weight downsample.1.bias downsample.1.running_mean "
    "downsample.1.running_var downsample.1.num_batches_tracked"
).split()


def _rgb_state_dict(seed: int = 0) -> dict[str, torch.Tensor]:
    """A ResNet-18 state dict as torchvision writes it: 3-channel stem, random weights,
    batch-norm statistics and a 1000-class ``fc``."""
    torch.manual_seed(seed)
    net = ResNet18(c_in=3)
    state = net.state_dict()
    for k, v in state.items():
        if v.is_floating_point():
            state[k] = torch.randn_like(v).abs() if "running_var" in k else torch.randn_like(v)
    state["fc.weight"] = torch.randn(1000, 512)
    state["fc.bias"] = torch.randn(1000)
    return state


def test_layout_has_torchvision_keys():
    keys = set(ResNet18().state_dict())
    assert {"conv1.weight", "bn1.running_var"} <= keys
    assert {f"layer2.0.{k}" for k in BLOCK_KEYS} <= keys
    assert "layer1.0.downsample.0.weight" not in keys  # layer1 keeps the width
    assert (
        sum(
            v.numel()
            for k, v in ResNet18(3).state_dict().items()
            if "running" not in k and "num_batches" not in k
        )
        == 11_176_512
    )  # torchvision's resnet18 without fc: 11,689,512 - 513,000 parameters
    assert ResNet18()(torch.zeros(2, 4, 20, 62)).shape == (2, 512)


def test_weights_load_with_the_stem_averaged_over_rgb(tmp_path):
    state = _rgb_state_dict()
    path = tmp_path / "resnet18.pth"
    torch.save({"state_dict": {f"module.{k}": v for k, v in state.items()}}, path)
    net = ResNet18(c_in=4)
    load_resnet18_weights(net, path)
    loaded = net.state_dict()
    for k, v in loaded.items():
        if k != "conv1.weight":
            assert torch.equal(v, state[k]), k
    stem = state["conv1.weight"]
    assert loaded["conv1.weight"].shape == (64, 4, 7, 7)
    assert torch.allclose(
        loaded["conv1.weight"], stem.sum(1, keepdim=True).expand(-1, 4, -1, -1) / 4
    )
    # A grey image meets the same response on the 4-channel stem as on the RGB one.
    grey = torch.full((1, 4, 20, 62), 0.7)
    rgb = torch.nn.functional.conv2d(grey[:, :3], stem, stride=2, padding=3)
    assert torch.allclose(net.conv1(grey), rgb, atol=1e-5)


def test_bad_weight_files_fail_naming_the_option(tmp_path):
    net = ResNet18()
    state = _rgb_state_dict()
    cases = {}
    del state["layer3.1.conv2.weight"]
    torch.save(state, tmp_path / "missing.pth")
    cases["missing.pth"] = "missing layer3.1.conv2.weight"
    state = _rgb_state_dict()
    state["layer4.0.conv1.weight"] = torch.zeros(512, 256, 1, 1)
    torch.save(state, tmp_path / "shape.pth")
    cases["shape.pth"] = r"layer4.0.conv1.weight has shape \(512, 256, 1, 1\)"
    # A pickle of an arbitrary object is refused, never executed.
    (tmp_path / "evil.pth").write_bytes(pickle.dumps({"conv1.weight": np.zeros(3)}, protocol=2))
    cases["evil.pth"] = "loads without pickled objects"
    torch.save([1, 2, 3], tmp_path / "list.pth")
    cases["list.pth"] = "does not hold a state dict"
    (tmp_path / "w.safetensors").write_bytes(b"x")
    cases["w.safetensors"] = "safetensors"
    for name, message in cases.items():
        with pytest.raises(ValueError, match=f"^weights: .*{message}"):
            load_resnet18_weights(net, tmp_path / name)


def test_fit_picks_epochs_on_held_out_classes_then_refits_on_all(tmp_path, monkeypatch):
    data = make_dataset(
        trials_per_class=4,
        shapes=("circle", "square", "moon", "triangle"),
        n_samples=400,
        noise=0.2,
    )
    trained_on: list[int] = []
    train = CWTResNetML._train

    def spy(self, images, labels, epochs, score=None):
        trained_on.append(np.unique(labels).size)
        return train(self, images, labels, epochs, score)

    monkeypatch.setattr(CWTResNetML, "_train", spy)
    path = tmp_path / "r18.pth"
    torch.save(_rgb_state_dict(), path)
    model = CWTResNetML(seed=0, max_epochs=2, patience=1, val_episodes=5, weights=str(path))
    assert model.arch == "resnet18"
    model.fit(data.signals, data.label)
    # Held-out quarter of the 12 classes (3) scored; then all 12 classes for epochs_.
    assert trained_on == [9, 12]
    curve = model.epoch_curve_
    assert curve[0, 0] == 0 and model.epochs_ == curve[np.argmax(curve[:, 1]), 0]
    assert model.feature_dim_ == 512
    # Epoch 0 starts from the file's weights (stem mapped); the kept network started there.
    start = cwt_resnet.ResNet18()
    load_resnet18_weights(start, path)
    if model.epochs_ == 0:
        assert torch.equal(model.net_.layer4[1].conv2.weight, start.layer4[1].conv2.weight)
    with pytest.raises(ValueError, match="arch must be 'resnet18'"):
        CWTResNetML(weights=str(path), arch="small")
