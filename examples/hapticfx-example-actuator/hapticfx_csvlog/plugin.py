"""Registration module (the entry point). Keep it tiny: names and lazy references only,
so that ``hapticfx plugins`` never imports what the actuator needs to run."""

from hapticfx.hookspecs import hookimpl
from hapticfx.registry import lazy


@hookimpl
def register_actuators(register):
    register("csv-logger", lazy("hapticfx_csvlog.actuator:CsvLogger"))


@hookimpl
def register_formats(register):
    register("envelope-csv", lazy("hapticfx_csvlog.envelope:EnvelopeCsv"))
