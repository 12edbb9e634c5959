"""Registration module of hapticfx-neural: names only, no torch import."""

from __future__ import annotations

from hapticfx.hookspecs import hookimpl
from hapticfx.registry import lazy

INTERPOLATORS = {
    "convbilstm": "ConvBiLSTMInterpolator",
    "lstm": "LSTMInterpolator",
    "bilstm": "BiLSTMInterpolator",
    "lstm-sae": "LSTMSAEInterpolator",
    "bilstm-ed": "BiLSTMEDInterpolator",
    "convlstm-ed": "ConvLSTMEDInterpolator",
}


@hookimpl
def register_interpolators(register):
    for name, cls in INTERPOLATORS.items():
        register(name, lazy(f"hapticfx_neural.interpolator:{cls}"))


@hookimpl
def register_commands(app, bench):
    from . import cli

    cli.register(app, bench)
