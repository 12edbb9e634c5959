"""Built-in physics plugin of hapticfx: the ``contact`` model, ``data synth``, ``bench contact`` and ``bench physics``."""

from ..hookspecs import hookimpl
from ..registry import lazy


@hookimpl
def register_models(register):
    register("contact", lazy("hapticfx.models.contact:ContactModel"))


@hookimpl
def register_commands(bench, data):
    from ..droprig.commands import register

    register(bench, data)
