"""The drop-rig simulator behind the built-in data: contact law and solver, helmet and sensor models, drop sets."""

MAX_SEED = 2**32 - 1  # the largest seed of a simulation (`data synth --seed`, a spec's `seed`)
