"""Built-in formats plugin: .haptic, AHAP, Android (arguments and audio-coupled Ogg) and HJIF files, the ``haptic-file`` model,
``hapticfx export`` and ``hapticfx bench formats``."""

from ..hookspecs import hookimpl
from ..registry import lazy


@hookimpl
def register_formats(register):
    register("haptic", lazy("hapticfx.formats.haptic:HapticFormat"))
    register("ahap", lazy("hapticfx.formats.ahap:AhapFormat"))
    register("android", lazy("hapticfx.formats.android:AndroidFormat"))
    register("hjif", lazy("hapticfx.formats.hjif:HjifFormat"))
    register("android-ogg", lazy("hapticfx.formats.ogg:AndroidOggFormat"))


@hookimpl
def register_models(register):
    register("haptic-file", lazy("hapticfx.formats.model:HapticFileModel"))


@hookimpl
def register_commands(app, bench):
    from ..formats import commands

    commands.register(app, bench)
