"""Registration module of hapticfx-solenoid (entry point ``solenoid`` in group ``hapticfx``).

Only names and lazy references here: listing plugins must not import pyserial.
"""

from hapticfx.hookspecs import hookimpl
from hapticfx.registry import lazy


@hookimpl
def register_actuators(register):
    register("solenoid", lazy("hapticfx_solenoid.actuator:SolenoidActuator"))


@hookimpl
def register_commands(app, bench):
    import typer

    from hapticfx.cli.options import finite

    @bench.command("isolation")
    def bench_isolation(
        impacts: int = typer.Option(200, "--impacts", "-n", metavar="COUNT", min=4,
                                    help="Impacts to the WAV output per run."),
        repeats: int = typer.Option(3, "--repeats", metavar="COUNT", min=1,
                                    help="Runs per board state (no board, healthy and silent take turns)."),
        interval_ms: float = typer.Option(20.0, "--interval-ms", metavar="MS", min=0.0, callback=finite,
                                          help="Pause between impacts (ms)."),
    ):
        """Whether a silent solenoid board delays a WAV output in the same engine, and how long close() takes;
        against a healthy board and against the WAV output alone (no board), in turns."""
        from .bench.isolation import BOARDS, run_once, table

        results: dict[str, list] = {board: [] for board in BOARDS}
        for i in range(repeats):
            for board in BOARDS:
                results[board].append(run_once(board, impacts, interval_ms / 1e3))
                typer.echo(f"  run {i + 1}/{repeats}, {BOARDS[board]}: close() {results[board][-1]['close_s']:.2f} s",
                           err=True)
        typer.echo(f"{repeats} runs per state, {impacts} impacts to the WAV output each ({interval_ms:g} ms apart), "
                   "a solenoid pulse after every 4th\n")
        typer.echo(table(results))
