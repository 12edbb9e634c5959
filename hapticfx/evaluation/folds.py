"""Which recorded velocities each evaluation round holds out, for datasets of any shape.

A *fold* is one (object, recorded velocity) to predict from its neighbours. A
*round* holds out one fold per object at once and trains every method once (one
network for all objects, as in the paper). Objects may be recorded at different
velocities and different numbers of them.

- ``lovo`` (leave one velocity out): round ``k`` holds out the ``k``-th interior
  velocity of every object that has one; every interior velocity of every object is
  predicted exactly once.
- ``looo`` (leave one object out): every interior velocity of one object is
  predicted, from its recorded neighbours, by methods fitted with no training
  target from that object (``targets`` lists none of it: its other velocities and
  drops are there only as the inputs a new object brings). Two rounds per object
  (odd, then even interior velocities) so that each held-out velocity keeps both
  recorded neighbours.
- ``paper``: the paper's split (Sect. 5.1): train targets 2.80, 3.13, 3.43, 4.85 and
  5.05 m/s, tests 3.96 and 4.43 m/s, for datasets recorded at those velocities.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import DatasetError

PAPER_TRAIN = (2.80, 3.13, 3.43, 4.85, 5.05)
PAPER_TEST = (3.96, 4.43)
PROTOCOLS = ("lovo", "looo", "paper")


@dataclass(frozen=True)
class Fold:
    """One held-out recorded velocity of one object."""

    object: str
    velocity: float


@dataclass(frozen=True)
class Round:
    """Folds held out together; ``targets`` restricts training targets (None: every interior velocity)."""

    name: str
    folds: tuple[Fold, ...]
    targets: dict[str, list[float]] | None = None

    @property
    def holdout(self) -> dict[str, list[float]]:
        out: dict[str, list[float]] = {}
        for f in self.folds:
            out.setdefault(f.object, []).append(f.velocity)
        return out


def lovo_rounds(banks: dict) -> list[Round]:
    """Leave one velocity out: round k holds out every object's k-th interior velocity."""
    longest = max((len(b) for b in banks.values()), default=0)
    rounds = []
    for k in range(1, longest - 1):
        folds = tuple(Fold(obj, float(b.velocities[k])) for obj, b in banks.items() if k < len(b) - 1)
        rounds.append(Round(f"interior velocity {k} of each object", folds))
    if not rounds:
        raise DatasetError("leave-one-velocity-out needs an object recorded at 3 or more velocities")
    return rounds


def looo_rounds(banks: dict) -> list[Round]:
    """Leave one object out: per object, its odd then its even interior velocities, no targets from it."""
    if len(banks) < 2:
        raise DatasetError("leave-one-object-out needs a dataset of 2 or more objects")
    interior = {obj: [float(v) for v in b.velocities[1:-1]] for obj, b in banks.items()}
    rounds = []
    for obj, vs in interior.items():
        for parity, which in ((0, "odd"), (1, "even")):
            held = vs[parity::2]
            if held:
                targets = {o: (v if o != obj else []) for o, v in interior.items()}
                rounds.append(Round(f"object {obj} left out ({which} interior velocities)",
                                    tuple(Fold(obj, v) for v in held), targets))
    if not rounds:
        raise DatasetError("leave-one-object-out needs an object recorded at 3 or more velocities")
    return rounds


def _snap(bank, v: float) -> float | None:
    hits = [float(x) for x in bank.velocities if abs(float(x) - v) <= 5e-4]
    return hits[0] if hits else None


def paper_rounds(banks: dict) -> list[Round]:
    """The paper's one split, on objects recorded at its velocities."""
    folds, targets = [], {}
    for obj, bank in banks.items():
        test = [_snap(bank, v) for v in PAPER_TEST]
        train = [_snap(bank, v) for v in PAPER_TRAIN]
        if None in test or None in train:
            raise DatasetError(f"the paper protocol needs {obj!r} recorded at {', '.join(map(str, PAPER_TRAIN + PAPER_TEST))} "
                               f"m/s; it has {', '.join(f'{x:g}' for x in bank.velocities)} (use --protocol lovo)")
        folds += [Fold(obj, v) for v in test]
        targets[obj] = train
    return [Round("paper split (Sect. 5.1)", tuple(folds), targets)]


def rounds_for(protocol: str, banks: dict) -> list[Round]:
    if protocol == "lovo":
        return lovo_rounds(banks)
    if protocol == "looo":
        return looo_rounds(banks)
    if protocol == "paper":
        return paper_rounds(banks)
    raise DatasetError(f"unknown protocol {protocol!r}; one of: {', '.join(PROTOCOLS)}")
