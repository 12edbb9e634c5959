"""``hapticfx bench fuzz``: mutated inputs through every gate, random overrides through the limiter."""

from __future__ import annotations

import time
from typing import Optional

import typer

from ..cli.options import finite
from ..errors import HapticfxError
from ..progress import Progress
from ..timing import table


def fuzz(
    gates: Optional[list[str]] = typer.Argument(None, help="Gates to fuzz (default: all installed; with --mutator "
                                                "types, the YAML ones): effect, scene, study, csv, dataset, checkpoint, "
                                                "osc, serial, at2, limits."),
    mutator: str = typer.Option("bytes", "--mutator", metavar="bytes|types",
                                help="bytes: flipped, dropped and inserted bytes and tokens; "
                                "types: a value of the wrong type (list, mapping, null, boolean, number, name) at any "
                                "key of a valid YAML file."),
    inputs: int = typer.Option(100_000, "--inputs", metavar="COUNT", min=1, help="Mutated inputs per gate."),
    seed: int = typer.Option(0, "--seed", metavar="SEED", help="The same seed gives the same inputs."),
    time_limit: float = typer.Option(1.0, "--time-limit", metavar="SECONDS", min=0.01, callback=finite,
                                     help="Seconds one input may take (else a hang)."),
    overrides: int = typer.Option(10_000, "--overrides", metavar="COUNT", min=1,
                                  help="limits gate: random effect overrides."),
    signals: int = typer.Option(100, "--signals", metavar="COUNT", min=1,
                                help="limits gate: random profiles per override."),
):
    """Fuzz the input gates: every mutant must be accepted or refused in one line under 300 characters, within
    the time limit, never with a traceback; and random profiles, gains and limit overrides must never take the
    output past an actuator's hard limits. Prints the counts; exit code 1 if anything failed. The peak RSS column
    is the process's high-water mark so far: name one gate to measure that gate alone."""
    from ..fuzz.gates import gates as installed
    from ..fuzz.limits import check_limits
    from ..fuzz.runner import fuzz_gate, peak_rss_mb

    from ..fuzz.runner import MUTATORS

    if mutator not in MUTATORS:
        raise HapticfxError(f"unknown mutator {mutator!r}; choose {' or '.join(MUTATORS)}")
    available = installed()
    if mutator == "types":  # a YAML tree to confuse: the YAML formats only, and no limits run
        available = {name: gate for name, gate in available.items() if gate.yaml}
    names = gates or [*available, *(["limits"] if mutator == "bytes" else [])]
    unknown = [g for g in names if g not in available and (g != "limits" or mutator != "bytes")]
    if unknown:
        raise HapticfxError(f"unknown or uninstalled gate(s) {', '.join(unknown)} for --mutator {mutator}; available: "
                            f"{', '.join([*available, *(['limits'] if mutator == 'bytes' else [])])}")
    rows, failed, examples = [], 0, []
    for name in names:
        t0 = time.perf_counter()
        if name == "limits":
            with Progress(overrides, name, unit="overrides") as bar:
                r = check_limits(overrides, signals, seed=seed, progress=bar.update)
            rows.append(["limits", f"{r.overrides} overrides x {signals} profiles = {r.signals}", "-", "-", "-",
                         "-", "-", f"{r.violations} above a hard limit", f"{time.perf_counter() - t0:.0f}",
                         f"{peak_rss_mb():.0f}"])
            failed += r.violations
            if r.worst:
                examples.append(f"limits: {r.worst}")
            continue
        with Progress(inputs, name, unit="inputs") as bar:
            r = fuzz_gate(available[name], inputs, seed=seed, time_limit_s=time_limit,
                          progress=lambda step: bar.update(step), mutator=mutator)
        rows.append([name, r.inputs, r.accepted, r.refused, r.bad_messages, r.tracebacks, r.hangs,
                     f"longest message {r.longest_message}, slowest {r.slowest_s * 1e3:.0f} ms",
                     f"{time.perf_counter() - t0:.0f}", f"{peak_rss_mb():.0f}"])
        failed += r.failures
        examples += [f"{name}: {kind}: {text}" for kind, text in r.examples.items()]
    typer.echo(f"mutator {mutator}, seed {seed}, time limit {time_limit:g} s per input")
    typer.echo(table(["gate", "inputs", "accepted", "refused", "bad messages", "tracebacks", "hangs", "notes",
                      "seconds", "peak RSS MiB (process)"], rows))
    for example in examples:
        typer.echo(example)
    if failed:
        raise typer.Exit(1)


def register(bench: typer.Typer) -> None:
    bench.command("fuzz")(fuzz)
