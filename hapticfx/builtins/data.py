"""Built-in data plugin of hapticfx: the reducers and the ``data`` / ``bench reducers`` commands."""

from ..hookspecs import hookimpl
from ..registry import lazy


@hookimpl
def register_reducers(register):
    register("max-min", lazy("hapticfx.processing.reducers:MaxMin"))
    register("dft321", lazy("hapticfx.processing.reducers:DFT321"))


@hookimpl
def register_commands(bench, data):
    from ..data.commands import register

    register(bench, data)
