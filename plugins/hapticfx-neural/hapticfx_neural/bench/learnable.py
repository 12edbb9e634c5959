"""`hapticfx bench learnable`: how much of the error left after the blend of the neighbours' centres a network
could learn, on a training configuration's own triples (numpy only).

Two measures:

- **Noise budget**: for every triple, the mean square of (blend of the neighbours' drop means - the target's
  drop mean) against what the sampling noise of those three means alone gives
  (``(1-w)^2 var_L / D_L + w^2 var_U / D_U + var_T / D_T``, per sample). A ratio near 1 means the error is
  noise that no function of the inputs removes. With the configuration's ``training.input_drops``, the
  neighbours' means are those of the drops validation gives them (the first K, or one fixed draw in a range).
- **Linear learner**: ridge regression from the network's own inputs (the two normalised centres and their
  products with ``w``) to the normalised correction, fitted on the training split and scored on the
  validation split that training uses (whole target pools held out), for a few penalties. If a linear map
  cannot beat the plain blend on validation, a network has little to find either.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from hapticfx.timing import table

PENALTIES = (1.0, 10.0, 100.0, 1000.0)


def noise_budget(data) -> tuple[float, float]:
    """Observed and noise-only mean square of the blend of centres against the target's drop mean."""
    obs, noise = [], []
    for lo, hi, tg, vl, vh, v in zip(data.lo, data.hi, data.tgt, data.v_lo, data.v_hi, data.v):
        w = (v - vl) / (vh - vl)
        pl, pu, pt = data.fixed_inputs(lo), data.fixed_inputs(hi), data.pools[tg]
        if min(len(pl), len(pu), len(pt)) < 2:
            continue
        blend = (1 - w) * pl.mean(0) + w * pu.mean(0)
        obs.append(np.mean((blend - pt.mean(0)) ** 2))
        noise.append(np.mean((1 - w) ** 2 * pl.var(0, ddof=1) / len(pl) + w ** 2 * pu.var(0, ddof=1) / len(pu)
                             + pt.var(0, ddof=1) / len(pt)))
    return float(np.mean(obs)), float(np.mean(noise))


def ridge_scores(data, *, val_fraction: float, seed: int, steps: int) -> tuple[float, dict[float, float]] | None:
    """Validation RMSE (normalised) of the plain blend and of ridge regression at each penalty (None when the
    training split holds no validation triple: fewer than 5 target velocities, or ``val_fraction`` 0)."""
    import torch

    from ..samples import encode
    from ..training import _split

    tr, va = _split(data, val_fraction, torch.Generator().manual_seed(seed))
    if len(va) == 0:
        return None
    t = data.centres()
    x, vel, y = encode(t, steps=steps, v_mean=0.0, v_std=1.0)
    n = len(y)
    pair = x.transpose(0, 2, 1, 3).reshape(n, 2, -1).astype(np.float64)
    w = vel[:, :1].astype(np.float64)
    target = y.reshape(n, -1) - ((1 - w) * pair[:, 0] + w * pair[:, 1])
    feats = np.hstack([pair[:, 0], pair[:, 1], pair[:, 0] * w, pair[:, 1] * w, w, np.ones((n, 1))])
    a, b = feats[tr], target[tr]
    gram, rhs = a.T @ a, a.T @ b
    base = float(np.sqrt(np.mean(target[va] ** 2)))
    scores = {}
    for lam in PENALTIES:
        coef = np.linalg.solve(gram + lam * np.eye(len(gram)), rhs)
        scores[lam] = float(np.sqrt(np.mean((target[va] - feats[va] @ coef) ** 2)))
    return base, scores


def learnable(
    config: Path = typer.Argument(..., help="Training configuration YAML (its datasets, gaps, trim and split)."),
    gaps: Optional[str] = typer.Option(None, "--gaps", metavar="N,...",
                                       help="Neighbours this many recorded velocities either side, instead of the "
                                            "configuration's `gaps` (e.g. 1 for adjacent neighbours only)."),
    trim: Optional[float] = typer.Option(None, "--trim", metavar="FRACTION",
                                         help="The centres' trim, instead of the configuration's `trim` (0: the "
                                              "plain mean): what is left to learn depends on where the blend "
                                              "starts."),
):
    """What is left to learn after the blend of the neighbours' drop centres: noise budget and a linear learner."""
    import dataclasses

    from hapticfx.errors import EffectError

    from ..config import MAX_GAP, POOLED, config_from_mapping, load_config
    from ..run import config_triples

    cfg = load_config(config)
    if cfg.inputs == POOLED:
        raise EffectError("bench learnable measures the noise of the neighbours' own drop centres; it does not "
                          f"take inputs: {cfg.inputs}", source=cfg.source, key="inputs")
    if gaps is not None:
        try:
            wanted = [int(g) for g in gaps.split(",")]
        except ValueError:
            wanted = []
        if not wanted or not all(1 <= g <= MAX_GAP for g in wanted):
            raise EffectError(f"expected comma-separated integers in [1, {MAX_GAP}], got {gaps!r}", key="--gaps")
        cfg = config_from_mapping({**cfg.as_dict(), "gaps": wanted}, source=cfg.source)
    if trim is not None:
        cfg = config_from_mapping({**cfg.as_dict(), "trim": trim}, source=f"{cfg.source} with --trim")
    _, data, meta = config_triples(cfg)
    data = dataclasses.replace(data, input_drops=cfg.training["input_drops"])
    obs, noise = noise_budget(data)
    ridge = ridge_scores(data, val_fraction=cfg.training["val_fraction"], seed=cfg.training["seed"],
                         steps=cfg.model["steps"])
    k = data.input_drops
    inputs = ("" if k is None else f", inputs from the first {k} drops" if isinstance(k, int)
              else f", inputs from {k[0]}-{k[1]} drops (one fixed draw)")
    typer.echo(f"{meta['name']}: {len(data)} triples, gaps {cfg.gaps}, trim {cfg.trim:g}{inputs}")
    rows = [["blend of drop means vs target drop mean: mean square (g^2)", f"{obs:.5f}"],
            ["the same from the sampling noise of the three means alone", f"{noise:.5f}"],
            ["share of the mean square that is sampling noise", f"{min(noise / obs, 1.0):.1%}"]]
    if ridge is None:
        rows.append(["validation RMSE", "none: the split needs 5 target velocities and a val_fraction above 0"])
    else:
        base, scores = ridge
        rows.append(["validation RMSE (normalised), blend of the centres (trimmed as configured)", f"{base:.5f}"])
        rows += [[f"validation RMSE, ridge (penalty {lam:g}) on the network's inputs", f"{s:.5f} ({s / base:.3f}x)"]
                 for lam, s in scores.items()]
    typer.echo(table(["what", "value"], rows))
