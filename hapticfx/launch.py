"""The ``hapticfx`` command: a Ctrl-C while the command line interface is still being imported is
told as one line, like one while a command runs (:func:`hapticfx.cli.main`), not as a traceback."""

import sys


def main() -> None:
    try:
        from .cli import main as run
    except KeyboardInterrupt:
        sys.stderr.write("aborted\n")
        sys.exit(130)
    run()
