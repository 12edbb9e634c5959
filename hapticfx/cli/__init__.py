"""The ``hapticfx`` command line. Commands come from plugins through ``register_commands``."""

from __future__ import annotations

import importlib
import os
import sys
import traceback

import typer

from ..errors import HapticfxError, one_line

HELP = """Haptic impact effects: render and play what a falling object feels like.

Try `hapticfx play effects/falling_brick.yaml`. Add --debug before the command to see
tracebacks. Docs: docs/ in the source tree.
"""


def build_app() -> typer.Typer:
    """The root app with the ``bench`` and ``data`` groups, filled by every plugin's hook."""
    from ..registry import get_registry

    app = typer.Typer(help=HELP, no_args_is_help=True, add_completion=True, pretty_exceptions_enable=False,
                      rich_markup_mode=None)
    bench = typer.Typer(help="Measure speed and accuracy; prints tables (median, spread, ratios).",
                        no_args_is_help=True)
    data = typer.Typer(help="Record, import, synthesise, inspect and plot impact datasets.", no_args_is_help=True)
    app.add_typer(bench, name="bench")
    app.add_typer(data, name="data")

    @app.callback()
    def root(
        debug: bool = typer.Option(False, "--debug", help="Show the traceback of errors."),
        version: bool = typer.Option(False, "--version", is_eager=True, callback=_version,
                                     help="Print the versions of hapticfx and its installed plugins, and exit."),
    ):
        """hapticfx."""

    get_registry().pm.hook.register_commands(app=app, bench=bench, data=data)
    app.registered_commands.sort(key=_rank)  # plugins register in any order; --help lists the common first
    _summarise(app)
    return app


def summary(text: str | None) -> str:
    """The one-line summary of a command's help for the lists of commands: its first sentence, up to its first
    colon or semicolon outside brackets (what follows one is detail). Click would cut the text at a fixed
    width, mid-phrase ('Check effect files (or haptic files: .haptic, .ahap,...')."""
    words = " ".join((text or "").strip().split("\n\n")[0].split())
    depth = 0
    for i, ch in enumerate(words):
        depth += (ch in "([{") - (ch in ")]}")
        if depth <= 0 and (ch in ":;" or ch == ".") and (i + 1 == len(words) or words[i + 1] == " "):
            return words[:i] + "."
    return words


def _summarise(app: typer.Typer) -> None:
    """Give every command and group without a short help the :func:`summary` of its help."""
    for info in app.registered_commands:
        if info.short_help is None:
            info.short_help = summary(info.help or (info.callback.__doc__ if info.callback else ""))
    for group in app.registered_groups:  # a group's settings may be typer's DefaultPlaceholder(value)
        info = group.typer_instance.info
        if all(getattr(x, "value", x) is None for x in (group.short_help, info.short_help)):
            group.short_help = summary(getattr(group.help, "value", group.help) or getattr(info.help, "value", info.help))
        _summarise(group.typer_instance)


# Commands in the order `hapticfx --help` lists them: most used first; others (a plugin's) after these.
COMMAND_ORDER = ("play", "render", "validate", "info", "serve", "devices", "plugins", "train", "table", "schema")


def _name(command) -> str:
    return command.name or command.callback.__name__.replace("_", "-")


def _rank(command) -> int:
    name = _name(command)
    return COMMAND_ORDER.index(name) if name in COMMAND_ORDER else len(COMMAND_ORDER)


def narrowed(app: typer.Typer, argv: list[str]) -> typer.Typer:
    """``app`` with only the command or group that ``argv`` names, so that click is built for it alone: typer
    builds each of some 45 commands at about 1 ms on this machine, a tenth of `play`'s start. Anything else
    (the root's --help, a name no command has, shell completion) keeps every command, so that lists, "no such
    command" and its suggestions, and completion see them all."""
    if "_HAPTICFX_COMPLETE" in os.environ:
        return app
    name = next((a for a in argv if not a.startswith("-")), None)
    commands = [c for c in app.registered_commands if _name(c) == name]
    groups = [g for g in app.registered_groups if g.name == name]
    if commands or groups:
        app.registered_commands, app.registered_groups = commands, groups
    return app


def _version(value: bool) -> None:
    if not value:
        return
    from .. import __version__
    from ..registry import get_registry

    dists = sorted({(p.distribution, p.version) for p in get_registry().plugins.values()
                    if p.distribution and p.distribution != "hapticfx"})
    typer.echo(f"hapticfx {__version__}" + (f" (plugins: {', '.join(f'{d} {v}' for d, v in dists)})" if dists else ""))
    raise typer.Exit()


def _click_errors() -> tuple[type, ...]:
    """ClickException classes: typer >= 0.26 bundles its own click, older typer uses click's."""
    found = []
    for name in ("typer._click.exceptions", "click.exceptions"):
        try:
            found.append(importlib.import_module(name).ClickException)
        except (ImportError, AttributeError):
            continue
    return tuple(found)


def error(message: str) -> None:
    """Print one error line to stderr."""
    typer.echo(f"hapticfx: error: {message}", err=True)


def main(argv: list[str] | None = None) -> None:
    """Entry point: domain errors become one line and exit code 2 (raises SystemExit)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    try:
        command = typer.main.get_command(narrowed(build_app(), argv))
        result = command.main(args=argv, prog_name="hapticfx", standalone_mode=False)
        code = result if isinstance(result, int) else 0
    except HapticfxError as exc:
        if debug:
            traceback.print_exc()
        error(one_line("; ".join([str(exc), *getattr(exc, "__notes__", ())])))  # a failed clean-up, say
        code = 2
    except OSError as exc:  # the machine's, not the program's: a full disk, a read-only or missing directory
        if debug:
            traceback.print_exc()
        where = f"{exc.filename}: " if exc.filename else ""
        error(one_line(f"{where}{exc.strerror or exc}"))
        code = 2
    except typer.Exit as exc:
        code = exc.exit_code
    except (typer.Abort, KeyboardInterrupt):  # Ctrl-C: click makes it Abort inside a command, not while starting
        typer.echo("aborted", err=True)
        code = 130
    except _click_errors() as exc:  # usage errors: click prints them in its own format
        exc.show()
        code = 2
    sys.exit(code)
