"""The interpolators a dataset carries fitted tables of: ``ensemble`` and ``ensemble-warp``.

Both are fitted to every drop of a dataset; a dataset written by hapticfx keeps
their velocity tables (``tables/<name>-<reducer>.table.npz``), so that an effect
loads them instead of fitting at every start.
"""

from __future__ import annotations

from pathlib import Path

from ..interfaces import TrainingData
from . import ensemble, ensemble_warp

FITTED = (ensemble, ensemble_warp)  # modules with NAME, fit_table(data) and table_path(dataset_path, reducer)


def describe(table) -> str:
    """What a fitted table chose, in a few words."""
    source = table.meta["source"]
    if "penalty" not in source:
        return f"trim {source['trim']}"
    warped = sum(p is not None for p in source["penalty"].values())
    shrunk = sum(bool(s) for s in source["shrink"].values())
    smoothed = sum(s is not None for s in source.get("smooth", {}).values())  # none before smoothing was offered
    unwarped = table.meta.get("fit", {}).get("unwarped", [])
    fill = table.meta.get("fit", {}).get("fill", 0.0)  # none before it was offered
    return (f"trim {source['trim']}, {warped} of {len(source['penalty'])} objects warped, {shrunk} shrunk, "
            f"{smoothed} smoothed, texture {source.get('texture', 0.0)}"  # no texture before it was offered
            + (f", fill {fill}" if fill else "")
            + (f", pull {source['pull']}" if source.get("pull", 2) != 2 else "")  # 2: the bump, the pull before
            + (f"; served without the warp: {', '.join(unwarped)}" if unwarped else ""))


def save_tables(data: TrainingData, folder: Path, *, progress=None) -> list[Path]:
    """Fit every interpolator of :data:`FITTED` to ``data`` and save its table under the dataset ``folder``."""
    say = progress or (lambda message: None)
    written = []
    for module in FITTED:
        table = module.fit_table(data)
        written.append(table.save(module.table_path(folder, data.reducer)))
        say(f"{module.NAME} interpolator ({data.reducer}): {describe(table)}; wrote {written[-1]}")
    return written


def write_tables(dataset, *, progress=None) -> list[Path]:
    """Rewrite the fitted tables of every bank (reducer) of ``dataset``; returns the files.

    Every bank and recording is read, and checked, before any table is written: a bad one leaves the
    tables as they were, not some of them rewritten."""
    from ..data.training import training_data

    data = [training_data(dataset, reducer) for reducer in dataset.reducers()]
    return [path for each in data for path in save_tables(each, dataset.path, progress=progress)]


__all__ = ["FITTED", "describe", "save_tables", "write_tables"]
