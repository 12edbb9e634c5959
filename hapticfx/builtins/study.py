"""Built-in study plugin of hapticfx: the ``recorded`` model (a recorded drop played back) and ``hapticfx study``."""

from __future__ import annotations

from ..hookspecs import hookimpl
from ..registry import lazy


@hookimpl
def register_models(register):
    register("recorded", lazy("hapticfx.models.recorded:RecordedDropModel"))



@hookimpl
def register_commands(app):
    from ..study.commands import register

    register(app)
