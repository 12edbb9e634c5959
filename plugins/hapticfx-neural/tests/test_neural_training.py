"""Training: tiny configurations for a few steps; determinism, resume, checkpoints and refusals."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from neural_testkit import TINY_BY_ARCH, tiny_config

from hapticfx.errors import CheckpointError, EffectError
from hapticfx_neural import checkpoint
from hapticfx_neural.config import ARCHS, MODEL_DEFAULTS, config_from_mapping, load_config
from hapticfx_neural.run import train_from_config


def _weights(path):
    return checkpoint.load_tensors(path)


def test_paper_sizes_are_the_defaults():
    m = MODEL_DEFAULTS["convbilstm"]
    assert m["encoder_sizes"] == [256, 128, 64] and m["decoder_sizes"] == [256, 180, 150]
    assert (m["kernel"], m["encoder_dropout"], m["decoder_dropout"]) == (3, 0.4, 0.3)
    cfg = config_from_mapping({"interpolator": "convbilstm", "dataset": "x"})
    assert (cfg.training["learning_rate"], cfg.training["batch_size"]) == (1e-4, 8)
    assert MODEL_DEFAULTS["lstm"]["sizes"] == [200] and MODEL_DEFAULTS["bilstm"]["sizes"] == [200, 200]


@pytest.mark.parametrize("arch", ARCHS)
def test_every_architecture_trains_and_predicts(tmp_path, syn_dataset, arch):
    meta, path = train_from_config(load_config(tiny_config(tmp_path, syn_dataset, arch, epochs=2)), progress=False)
    assert meta["training"]["epochs_run"] == 2 and path.is_file()
    out = _interpolated(syn_dataset, arch, path)
    assert out.shape == (100,) and np.all(np.isfinite(out))


def _interpolated(dataset, arch, weights, velocity=3.5):
    """What ``weights`` render for the synthetic dataset's plastic frame at ``velocity``, between two recordings."""
    from hapticfx.data.dataset import open_dataset
    from hapticfx.registry import get_registry

    ds = open_dataset(dataset)
    bank = ds.bank("plastic-frame", "max-min")
    interp = get_registry().create("interpolator", arch, weights=str(weights))
    interp.prepare(bank, dataset=ds)
    return interp.interpolate(*bank.neighbours(velocity), velocity)


def test_same_seed_same_weights_and_resume_is_exact(tmp_path, syn_dataset):
    a = tmp_path / "a"
    a.mkdir()
    b = tmp_path / "b"
    b.mkdir()
    ca = load_config(tiny_config(a, syn_dataset, epochs=4, patience=100))
    train_from_config(ca, progress=False)
    cb = load_config(tiny_config(b, syn_dataset, epochs=4, patience=100))
    cb.training["epochs"] = 2
    train_from_config(cb, progress=False)
    cb.training["epochs"] = 4
    meta, _ = train_from_config(cb, resume=True, progress=False)
    assert meta["training"]["epochs_run"] == 4
    wa = _weights(a / "ck-convbilstm" / "resume.safetensors")
    wb = _weights(b / "ck-convbilstm" / "resume.safetensors")
    assert wa.keys() == wb.keys()
    for k in wa:
        if k.startswith("net."):
            assert np.array_equal(wa[k].numpy(), wb[k].numpy()), k


def test_resume_with_another_architecture_is_refused(tmp_path, syn_dataset):
    cfg = load_config(tiny_config(tmp_path, syn_dataset, epochs=1))
    train_from_config(cfg, progress=False)
    other = load_config(tiny_config(tmp_path, syn_dataset, epochs=2))
    other.model["decoder_sizes"] = [7]
    with pytest.raises(CheckpointError, match="cannot resume: its model differs"):
        train_from_config(other, resume=True, progress=False)


def test_checkpoint_for_another_architecture_or_dataset_is_refused(trained, syn_dataset):
    from hapticfx.data.dataset import open_dataset
    from hapticfx.registry import get_registry

    ds = open_dataset(syn_dataset)
    bank = ds.bank("plastic-frame", "max-min")
    with pytest.raises(CheckpointError, match="built for interpolator 'convbilstm', not 'lstm'"):
        get_registry().create("interpolator", "lstm", weights=str(trained)).prepare(bank, dataset=ds)

    class Other:
        name = "another-dataset"

    with pytest.raises(CheckpointError, match="trained on dataset 'synthetic', not 'another-dataset'"):
        get_registry().create("interpolator", "convbilstm", weights=str(trained)).prepare(bank, dataset=Other())


def test_a_checkpoint_of_another_interpolator_is_said_to_be_one_before_its_model_is_checked(tmp_path, trained,
                                                                                             syn_dataset):
    import shutil

    from hapticfx.data.dataset import open_dataset
    from hapticfx.registry import get_registry

    shutil.copy(trained, tmp_path / "model.safetensors")
    meta = json.loads(trained.with_suffix(".json").read_text())
    (tmp_path / "model.json").write_text(json.dumps({**meta, "interpolator": "lstm"}))  # a convbilstm's model keys
    ds = open_dataset(syn_dataset)
    with pytest.raises(CheckpointError, match="model.json: built for interpolator 'lstm', not 'convbilstm'"):
        get_registry().create("interpolator", "convbilstm", weights=str(tmp_path)).prepare(
            ds.bank("plastic-frame", "max-min"), dataset=ds)


@pytest.mark.parametrize("given, said", [("o/n.wav", "checkpoint not found"), ("a.wav", "not a checkpoint")])
def test_hapticfx_table_names_the_path_it_was_given(tmp_path, capsys, monkeypatch, given, said):
    from hapticfx.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.wav").write_bytes(b"RIFF")
    with pytest.raises(SystemExit) as done:
        main(["table", given])
    assert done.value.code == 2
    assert capsys.readouterr().err == (f"hapticfx: error: {given}: {said}; expected a checkpoint directory or its "
                                       "model.safetensors\n")


def test_checkpoint_whose_weights_do_not_fit_its_description_is_refused(tmp_path, trained):
    import shutil

    from hapticfx_neural.training import load_network

    for name in ("model.safetensors", "model.json"):
        shutil.copy(trained.parent / name, tmp_path / name)
    meta = json.loads((tmp_path / "model.json").read_text())
    meta["model"]["decoder_sizes"] = [9]
    (tmp_path / "model.json").write_text(json.dumps(meta))
    with pytest.raises(CheckpointError, match="weights do not fit the convbilstm network"):
        load_network(tmp_path / "model.safetensors", arch="convbilstm")
    (tmp_path / "model.safetensors").write_bytes(b"not safetensors")
    with pytest.raises(CheckpointError, match="the weights do not match model.json"):
        load_network(tmp_path / "model.safetensors", arch="convbilstm")
    meta["model"]["decoder_sizes"] = TINY_BY_ARCH["convbilstm"]["decoder_sizes"]
    meta["weights_sha256"] = checkpoint.file_sha256(tmp_path / "model.safetensors")
    (tmp_path / "model.json").write_text(json.dumps(meta))
    with pytest.raises(CheckpointError, match="corrupt or unreadable"):
        load_network(tmp_path / "model.safetensors", arch="convbilstm")


@pytest.mark.parametrize("version", [1, 2])
def test_older_checkpoints_are_refused_with_the_reason(tmp_path, trained, version):
    import shutil

    from hapticfx_neural.training import load_network

    shutil.copy(trained, tmp_path / "model.safetensors")
    meta = json.loads(trained.with_suffix(".json").read_text())
    meta["version"] = version
    (tmp_path / "model.json").write_text(json.dumps(meta))
    with pytest.raises(CheckpointError, match=rf"format version {version}; .*drop centres.*hapticfx train"):
        load_network(tmp_path / "model.safetensors", arch="convbilstm")


def test_no_weights_for_the_dataset_names_the_command(syn_dataset):
    from hapticfx.data.dataset import open_dataset
    from hapticfx.registry import get_registry

    ds = open_dataset(syn_dataset)
    with pytest.raises(CheckpointError, match="hapticfx train CONFIG.yaml"):
        get_registry().create("interpolator", "bilstm").prepare(ds.bank("plastic-frame", "max-min"), dataset=ds)


@pytest.mark.parametrize("bad, key", [
    ({"interpolator": "convbilstm", "dataset": "x", "modle": {}}, "unknown key"),
    ({"interpolator": "gru", "dataset": "x"}, "interpolator"),
    ({"interpolator": "lstm", "dataset": "x", "model": {"hidden": 3}}, "model"),
    ({"interpolator": "lstm", "dataset": "x", "training": {"epochs": 0}}, "training.epochs"),
    ({"interpolator": "convbilstm", "dataset": "x", "model": {"kernel": 4}}, "model.kernel"),
    ({"interpolator": "convbilstm", "dataset": "x", "model": {"decoder_input": "sideways"}}, "model.decoder_input"),
    ({"interpolator": "convbilstm", "dataset": "x", "training": {"device": "gpu"}}, "training.device"),
    ({"interpolator": "convbilstm", "dataset": "x", "training": {"device": "cuda:x"}}, "training.device"),
    ({"interpolator": "convbilstm", "dataset": "x", "training": {"device": 0}}, "training.device"),
])
def test_bad_config_names_file_and_key(tmp_path, bad, key):
    import yaml

    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(bad))
    with pytest.raises(EffectError) as err:
        load_config(path)
    assert str(path) in str(err.value) and key in str(err.value)


def test_training_on_a_cuda_device_this_machine_lacks_is_refused_in_one_line(tmp_path, syn_dataset):
    """On a machine with a CUDA GPU this refusal cannot happen; there `device: cuda` trains (not run here)."""
    import subprocess
    import sys

    import torch
    import yaml

    if torch.cuda.is_available():
        pytest.skip("a CUDA GPU is visible")
    path = tiny_config(tmp_path, syn_dataset, device="cuda")
    r = subprocess.run([sys.executable, "-m", "hapticfx", "train", str(path), "--quiet"], capture_output=True,
                       text=True)
    assert r.returncode != 0 and "Traceback" not in r.stderr
    assert re.search(r"training.device 'cuda': (this torch is a CPU build|no CUDA GPU is visible); train with "
                     r"device: cpu", r.stderr)
    assert not (tmp_path / "ck-convbilstm").exists()
    cfg = yaml.safe_load(path.read_text())
    cfg["training"]["device"] = "cpu"  # the default, named
    path.write_text(yaml.safe_dump(cfg))
    meta, _ = train_from_config(load_config(path), progress=False)
    assert meta["training"]["device"] == "cpu"


def test_training_on_a_cuda_gpu_resumes_a_cpu_run_and_serves_from_the_cpu(tmp_path, syn_dataset):
    """Needs a CUDA GPU: skipped in CI and on the project's machine; run on the device machine when one is lent.

    A run started on the CPU continues on the GPU (docs/neural.md: a run may resume on another device), and what
    it writes (weights, table) is the CPU's: it loads and interpolates without CUDA.
    """
    import torch
    import yaml

    if not torch.cuda.is_available():
        pytest.skip("no CUDA GPU is visible")
    path = tiny_config(tmp_path, syn_dataset, epochs=2, patience=100)
    cpu_meta, _ = train_from_config(load_config(path), progress=False)
    resume = tmp_path / "ck-convbilstm" / "resume.safetensors"
    after_cpu = checkpoint.load_tensors(resume)
    cfg = yaml.safe_load(path.read_text())
    cfg["training"].update(device="cuda", epochs=6)
    path.write_text(yaml.safe_dump(cfg))
    meta, weights = train_from_config(load_config(path), resume=True, progress=False)
    history = meta["training"]["history"]
    assert meta["training"]["device"] == "cuda" and meta["training"]["epochs_run"] == 6
    assert history[:2] == cpu_meta["training"]["history"] and np.all(np.isfinite(history))
    after_gpu = checkpoint.load_tensors(resume)
    assert any(not torch.equal(after_gpu[k], after_cpu[k]) for k in after_cpu if k.startswith("net."))  # it trained
    tensors = checkpoint.load_tensors(weights)
    assert all(t.device.type == "cpu" and torch.isfinite(t).all() for t in tensors.values())
    out = _interpolated(syn_dataset, "convbilstm", weights)
    assert out.shape == (100,) and np.all(np.isfinite(out))


def test_steps_must_divide_the_profile_length(tmp_path, syn_dataset):
    """Said without the config file or key, before d6e805d."""
    from hapticfx.errors import EffectError

    cfg = load_config(tiny_config(tmp_path, syn_dataset))
    cfg.model["steps"] = 7
    with pytest.raises(EffectError, match=r"model.steps: synthetic's profiles of 100 samples cannot be cut into 7 "
                                          r"equal steps") as err:
        train_from_config(cfg, progress=False)
    assert str(err.value).startswith(f"{cfg.source}: ")


def test_tiny_config_table_covers_every_architecture():
    assert set(TINY_BY_ARCH) == set(ARCHS)


@pytest.mark.parametrize("arch", ARCHS)
def test_an_untrained_network_without_drops_is_the_linear_interpolator(arch):
    from hapticfx.interpolators.linear import LinearInterpolator
    from hapticfx.interfaces import Profile
    from hapticfx_neural.samples import stack_triples
    from hapticfx_neural.training import make_network, predict

    rng = np.random.default_rng(4)
    lo, hi = Profile(3.0, rng.standard_normal(100)), Profile(3.5, rng.standard_normal(100))
    net = make_network(arch, {**MODEL_DEFAULTS[arch], **TINY_BY_ARCH[arch]}, 100)
    meta = {"steps": TINY_BY_ARCH[arch]["steps"], "normalisation": {"velocity_mean": 3.0, "velocity_std": 1.0}}
    out = predict(net, meta, stack_triples([(lo, hi, 3.2, None)], ["x"]))[0]
    assert np.allclose(out, LinearInterpolator().interpolate(lo, hi, 3.2), rtol=0, atol=1e-14)


@pytest.mark.parametrize("change, expected", [
    (lambda m: m["model"].update(decoder_sizes=[4000000]), "model.decoder_sizes: expected a list of 1 to 8 integers"),
    (lambda m: m.pop("normalisation"), "normalisation: expected a mapping with a finite velocity_mean"),
    (lambda m: m.update(dataset="x"), "dataset: expected a mapping with the dataset's name and reducer"),
    (lambda m: m.update(interpolator="gpt"), "interpolator: expected one of convbilstm"),
    (lambda m: m.update(n_samples=10**9), "n_samples: expected an integer in [1, 100000]"),
    (lambda m: m["model"].update(colour=1), "model: expected a mapping with steps, kernel, encoder_sizes"),
    (lambda m: m.update(weights_sha256=None), "weights_sha256: expected the weights' SHA-256"),
])
def test_checkpoint_metadata_is_validated_before_anything_is_built(tmp_path, trained, change, expected):
    import shutil

    from hapticfx_neural.training import load_network

    shutil.copy(trained, tmp_path / "model.safetensors")
    meta = json.loads(trained.with_suffix(".json").read_text())
    change(meta)
    (tmp_path / "model.json").write_text(json.dumps(meta))
    with pytest.raises(CheckpointError, match="model.json: " + re.escape(expected)):
        load_network(tmp_path / "model.safetensors", arch="convbilstm")


def test_training_that_cannot_write_says_so_and_leaves_no_empty_directory(tmp_path, syn_dataset):
    """Every file capped at 1 kB (RLIMIT_FSIZE: the OS refuses the write with EFBIG, as a full disk would)."""
    import subprocess
    import sys

    cfg = tiny_config(tmp_path, syn_dataset, epochs=2)
    code = ("import resource, signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
            "resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000)); "
            "from hapticfx.cli import main; main(sys.argv[1:])")
    r = subprocess.run([sys.executable, "-c", code, "train", str(cfg), "--quiet"], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert re.search(r"cannot write the checkpoint \(File too large.*\); nothing was saved", r.stderr), r.stderr
    assert not (tmp_path / "ck-convbilstm").exists()


@pytest.mark.parametrize("out", ["a-file", "a-file/ck"])
def test_an_output_that_cannot_hold_a_checkpoint_is_refused_before_training(tmp_path, syn_dataset, out):
    (tmp_path / "a-file").write_text("not a folder")
    cfg = load_config(tiny_config(tmp_path, syn_dataset, epochs=1))
    cfg.out = str(tmp_path / out)
    with pytest.raises(CheckpointError, match=re.escape(f"{tmp_path / out}: cannot write the checkpoint there "
                                                        "(Not a directory); nothing was trained")):
        train_from_config(cfg, progress=False)


def test_a_checkpoint_write_that_fails_says_what_can_be_resumed(tmp_path, syn_dataset, monkeypatch):
    import errno
    from pathlib import Path

    real, resumes = checkpoint.save, []

    def full_after_one_epoch(path, tensors, meta):
        resumes.extend([path] if Path(path).name == "resume.safetensors" else [])
        if len(resumes) > 1:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(path, tensors, meta)

    monkeypatch.setattr(checkpoint, "save", full_after_one_epoch)
    with pytest.raises(CheckpointError, match=r"cannot write the checkpoint \(No space left on device\); "
                                              r"epoch 1 is saved there: continue with --resume once it can be written"):
        train_from_config(load_config(tiny_config(tmp_path, syn_dataset, epochs=3)), progress=False)

    def denied(path, tensors, meta):
        raise OSError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(checkpoint, "save", denied)
    (tmp_path / "kept").mkdir()
    cfg = load_config(tiny_config(tmp_path, syn_dataset, epochs=3))
    cfg.out = str(tmp_path / "kept")
    with pytest.raises(CheckpointError, match=r"cannot write the checkpoint \(Permission denied\); "
                                              r"no resume state is saved there"):
        train_from_config(cfg, progress=False)
