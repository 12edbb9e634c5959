"""Plot why the shipped convbilstm does not beat linear: its learning curve against two references.

    python plugins/hapticfx-neural/benchmarks/why.py   (from the repository root)

References, in the network's normalised units on the same training and validation triples
(the training run's seeded split of every interior velocity of every object of
builtin:helmet-drops, max-min): the paper's linear weighted average, and a predictor that
outputs silence (zeros).
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

from hapticfx.data.dataset import open_dataset  # noqa: E402
from hapticfx_neural.checkpoint import default_weights, read_meta  # noqa: E402
from hapticfx_neural.run import dataset_triples  # noqa: E402
from hapticfx_neural.training import _split  # noqa: E402

meta = read_meta(default_weights("helmet-drops", "max-min", "convbilstm"))
ds = open_dataset("builtin:helmet-drops")
t, _ = dataset_triples(ds, "max-min", ds.objects, train=None, holdout=[])
scale = np.maximum(np.abs(t.lower).max(1), np.abs(t.upper).max(1))[:, None]
w = ((t.v - t.v_lo) / (t.v_hi - t.v_lo))[:, None]
lin_err = (((1 - w) * t.lower + w * t.upper - t.target) / scale) ** 2
zero_err = (t.target / scale) ** 2
tr_idx, va_idx = _split(len(t), meta["training"]["val_fraction"], torch.Generator().manual_seed(meta["training"]["seed"]))
ref = {name: {part: float(np.sqrt(np.mean(err[idx]))) for part, idx in (("train", tr_idx), ("val", va_idx))}
       for name, err in (("linear", lin_err), ("zeros", zero_err))}
hist = np.array(meta["training"]["history"])
fig, ax = plt.subplots(figsize=(6.5, 4))
ax.plot(np.arange(1, len(hist) + 1), hist[:, 0], label="convbilstm training RMSE")
ax.plot(np.arange(1, len(hist) + 1), hist[:, 1], label="convbilstm validation RMSE")
ax.axhline(ref["linear"]["train"], color="C0", ls="--", label=f"linear on the training triples ({ref['linear']['train']:.3f})")
ax.axhline(ref["linear"]["val"], color="C1", ls="--", label=f"linear on the validation triples ({ref['linear']['val']:.3f})")
ax.axhline(ref["zeros"]["val"], color="gray", ls=":", label=f"silence on the validation triples ({ref['zeros']['val']:.3f})")
ax.set_xlabel("epoch (Adam, lr 1e-4, batch 8)")
ax.set_ylabel("RMSE, normalised by the neighbours' peak")
ax.set_title("Shipped convbilstm (helmet-drops, max-min): learning curve")
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
fig.tight_layout()
out = Path(__file__).resolve().parents[3] / "docs" / "images" / "neural" / "why-convbilstm.png"
fig.savefig(out, dpi=120)
print(f"references {ref}; convbilstm best validation {min(hist[:, 1]):.4f} (epoch {int(np.argmin(hist[:, 1])) + 1}), "
      f"last training {hist[-1, 0]:.4f}; wrote {out}")
