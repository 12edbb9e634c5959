"""What the decoder reads: the paper's repeat vector, or the encoder's output at each step."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from neural_testkit import TINY, TINY_BY_ARCH

from hapticfx_neural import checkpoint
from hapticfx_neural.config import MODEL_DEFAULTS
from hapticfx_neural.samples import drop_triples
from hapticfx_neural.training import train_network


def test_the_paper_repeat_vector_is_the_default_and_older_checkpoints_read_as_it(tmp_path):
    for arch in ("convbilstm", "convlstm-ed", "bilstm-ed", "lstm-sae"):
        assert MODEL_DEFAULTS[arch]["decoder_input"] == "repeat"
    # a checkpoint written before the key existed reads as what it was trained with
    shipped = checkpoint.default_weights("helmet-drops", "max-min", "convbilstm")
    meta = json.loads(shipped.with_suffix(".json").read_text())
    del meta["model"]["decoder_input"]
    old = tmp_path / "model.safetensors"
    shutil.copyfile(shipped, old)
    old.with_suffix(".json").write_text(json.dumps(meta))
    assert checkpoint.read_meta(old)["model"]["decoder_input"] == "repeat"


def _moving_bounce(n: int = 100):
    """Drops whose one bounce comes 4 samples later per 0.1 m/s: between neighbours 2-3 velocities apart the
    blend shows it twice at half height, and the correction that fixes it depends on where it is."""
    v = np.round(np.linspace(1.0, 2.0, 11), 6)
    t = np.arange(n)
    pools = [np.repeat(np.exp(-0.5 * ((t - 20 - 40 * (x - 1.0)) / 2.0) ** 2)[None], 3, axis=0) for x in v]
    return drop_triples([("bounce", v, pools, list(v[3:-3]))], gaps=[2, 3])


def test_reading_the_encoders_steps_the_decoder_learns_a_correction_placed_in_time():
    data = _moving_bounce()
    model = {**MODEL_DEFAULTS["convbilstm"], **TINY, "encoder_dropout": 0.0, "decoder_dropout": 0.0,
             "decoder_input": "sequence"}
    training = {"epochs": 40, "batch_size": 4, "learning_rate": 1e-2, "beta1": 0.9, "val_fraction": 0.0,
                "patience": 40, "seed": 0, "threads": 1, "augment": False}
    _, meta = train_network("convbilstm", model, training, data, dataset_meta={"name": "bounce"}, progress=False)
    history = np.array(meta["training"]["history"])
    assert history[-1, 0] < 0.5 * history[0, 0]  # the blend's two half bounces are mostly gone
    assert meta["model"]["decoder_input"] == "sequence"


@pytest.mark.parametrize("decoder_input", ["repeat", "sequence"])
@pytest.mark.parametrize("arch", ["convbilstm", "convlstm-ed", "bilstm-ed", "lstm-sae"])
def test_every_encoder_decoder_takes_either_and_starts_at_the_blend(arch, decoder_input):
    import torch

    from hapticfx_neural.training import make_network

    tiny = TINY_BY_ARCH[arch]
    net = make_network(arch, {**MODEL_DEFAULTS[arch], **tiny, "decoder_input": decoder_input}, 100)
    out = net(torch.randn(3, tiny["steps"], 2, 100 // tiny["steps"]), torch.randn(3, 2))
    assert out.shape == (3, tiny["steps"], 100 // tiny["steps"])
    assert torch.count_nonzero(out) == 0  # zero correction: the blend
