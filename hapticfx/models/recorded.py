"""A recorded drop played back: the closest thing to a real object falling that hapticfx has.

In the paper's perceptual study the real stimuli were objects dropped on the
helmet. Here a study's "real" reference is one recorded drop of a dataset,
preprocessed and reduced exactly as the dataset's banks were, and played
through the same shaping, limiter and actuator as any rendered impact.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from ..data.dataset import Dataset, open_dataset
from ..data.training import recorded_drops
from ..errors import DatasetError, SignalError
from ..interfaces import Impact, Model
from ..params import BuildContext, doc
from ..registry import Registry
from ..signal import Signal


# Every drop of an object, preprocessed and reduced, shared by all models that play it: a study's scene holds one
# entry (one model) per recorded drop it plays, and each would otherwise preprocess all drops of the object again.
# Keyed by the raw file and dataset.json (the preprocessing), each with its size and modification time, so a
# dataset rewritten on disk is read again.
_SHARED_DROPS: OrderedDict[tuple, tuple[np.ndarray, np.ndarray]] = OrderedDict()
_SHARED_LOCK = threading.Lock()
_SHARED_MAX = 16


def shared_drops(dataset: Dataset, object_id: str, reducer: str, registry: Registry) -> tuple[np.ndarray, np.ndarray]:
    """``velocities (V,)`` and every drop reduced ``(V, D, N)`` by ``registry``'s ``reducer``, read-only,
    computed once per file version and reducer class."""
    raw, meta = dataset.path / "raw" / f"{object_id}.npz", dataset.path / "dataset.json"
    try:
        versions = tuple((st.st_size, st.st_mtime_ns) for st in (raw.stat(), meta.stat()))
    except OSError:
        raise DatasetError(f"dataset {dataset.name!r} keeps no raw drops of {object_id!r}") from None
    key = (str(raw.resolve()), reducer, registry.get("reducer", reducer).factory, versions)
    with _SHARED_LOCK:
        if key in _SHARED_DROPS:
            _SHARED_DROPS.move_to_end(key)
            return _SHARED_DROPS[key]
        found = recorded_drops(dataset, object_id, reducer, registry=registry)
        if found is None:
            raise DatasetError(f"dataset {dataset.name!r} keeps no raw drops of {object_id!r}")
        for array in found:
            array.setflags(write=False)
        _SHARED_DROPS[key] = found
        while len(_SHARED_DROPS) > _SHARED_MAX:
            _SHARED_DROPS.popitem(last=False)
        return found


class RecordedDropModel(Model):
    """One recorded drop of ``object`` at the impact's velocity, which must be a recorded one.

    ``drop`` picks which of the repeated drops at that velocity plays (0-based);
    without it, the representative drop of the bank plays.
    """

    name = "recorded"
    units = "g"

    @dataclass(frozen=True)
    class Params:
        dataset: str = field(default="builtin:helmet-drops", metadata=doc("dataset path or builtin:NAME"))
        reducer: str = field(default="max-min", metadata=doc("reduce the 3 axes as this bank was"))
        drop: int | None = field(default=None, metadata=doc("which repeated drop (0-based); default: the representative", min=0))

    def __init__(self, params: Params, context: BuildContext):
        self.params = params
        self.context = context
        self.dataset: Dataset = open_dataset(params.dataset, relative_to=context.base_dir)
        if context.object_id:
            self.dataset.bank(context.object_id, params.reducer)  # the object and bank exist

    def drops(self, object_id: str) -> tuple[np.ndarray, np.ndarray]:
        """``velocities (V,)`` and every drop reduced ``(V, D, N)`` (read once per object and file version)."""
        return shared_drops(self.dataset, object_id, self.params.reducer, self.context.components())

    def profile(self, object_id: str, velocity: float) -> np.ndarray:
        bank = self.dataset.bank(object_id, self.params.reducer)
        i = bank.index_of(velocity)
        if i is None:
            raise SignalError(f"{object_id!r} was not recorded at {velocity} m/s; recorded: "
                              f"{', '.join(f'{v:g}' for v in bank.velocities)}")
        if self.params.drop is None:
            return bank.profiles[i].copy()
        velocities, drops = self.drops(object_id)
        j = int(np.flatnonzero(velocities == velocity)[0])
        if self.params.drop >= drops.shape[1]:
            raise SignalError(f"{object_id!r} at {velocity} m/s has {drops.shape[1]} drops; drop {self.params.drop} does not exist")
        return np.asarray(drops[j, self.params.drop], dtype=np.float64).copy()

    def render(self, impact: Impact) -> Signal:
        return Signal(self.profile(impact.object or self.context.object_id, impact.velocity), self.dataset.rate_hz)

    def describe(self) -> dict:
        return {"model": self.name, "dataset": str(self.dataset.path), "reducer": self.params.reducer,
                "drop": "representative" if self.params.drop is None else self.params.drop}
