"""``hapticfx study``: run a perceptual study with a participant (or a simulated one) and analyse the results."""

from __future__ import annotations

import time
from contextlib import ExitStack
from pathlib import Path
from typing import Optional

import typer

from ..cli.options import finite
from ..errors import StudyError


def _device(value: Optional[str]):
    return int(value) if value is not None and value.strip().isdigit() else value


def run_one(study_path: Path, participant: str, out: Path, *, device, port: int, simulate: bool, pace_s: float,
            echo, force: bool = False) -> int:
    """Run (or resume) one participant's session; returns the number of answers given in this run."""
    from ..pipeline import stand_in
    from .player import StimulusPlayer
    from .schedule import build_schedule
    from .server import StudyServer
    from .session import Session
    from .spec import load_study

    study = load_study(study_path)
    schedule = build_schedule(study, participant)
    realtime = stand_in(device) is None
    with ExitStack() as stack:
        server = None
        if not simulate:  # the page's port first: one in use is refused before anything is written
            server = StudyServer(None, port=port)
            stack.callback(server.stop)
        player = stack.enter_context(StimulusPlayer(study, schedule, device=device, realtime=realtime,
                                                    overwrite=force))
        session = Session(study, participant, out, player, study_text=Path(study_path).read_bytes(),
                          simulated=simulate, enforce_breaks=not simulate)
        stack.callback(session.close)
        before = len(session.answered)
        if session.done:
            echo(f"{participant}: already complete ({len(schedule)} trials in {session.log.path})")
        elif simulate:
            from .simulate import run_simulated

            run_simulated(session, pace_s=pace_s)
            echo(f"{participant}: {len(session.answered) - before} answers simulated "
                 f"({len(session.answered)}/{len(schedule)} in {session.log.path})")
        else:
            _serve(session, server, echo=echo)
        return len(session.answered) - before


def _serve(session, server, *, echo) -> None:
    server.session = session
    with server:
        where = f"resuming at trial {session.position + 1}" if session.answered else "starting"
        echo(f"{session.participant}: {where} of {len(session.schedule)}; the participant's page is {server.url}")
        seen, errors = len(session.answered), 0
        while not session.done:
            time.sleep(0.2)
            if len(session.answered) != seen:
                seen = len(session.answered)
                echo(f"{session.participant}: {seen}/{len(session.schedule)} answered")
            for message in server.errors[errors:]:
                echo(message)
            errors = len(server.errors)
        time.sleep(1.0)  # let the page fetch the final screen
    echo(f"{session.participant}: complete; answers in {session.log.path}")


MAX_PACE_S = 60.0  # --pace: a simulated participant is paced to watch a demonstration, not for hours


def run(
    study: Path = typer.Argument(..., help="Study file (YAML), e.g. studies/paper_study2.yaml."),
    participant: Optional[str] = typer.Option(None, "--participant", "-p", metavar="ID",
                                              help="Participant id with a number (P07): picks the counterbalanced order."),
    out: Optional[Path] = typer.Option(None, "--out", "-o", metavar="DIR",
                                       help="Results folder (default: results/<study name>)."),
    device: Optional[str] = typer.Option(None, "--device", "-d", metavar="DEVICE",
                                         help="Replace every actuator: 'memory' or 'wav:PATH' (one file per actuator)."),
    port: int = typer.Option(8765, metavar="PORT", min=0, max=65535,
                             help="Port of the participant's page on 127.0.0.1 (0: any free)."),
    simulate: bool = typer.Option(False, "--simulate", help="A simulated participant answers (the study's 'simulate' model)."),
    participants: Optional[int] = typer.Option(None, "--participants", metavar="COUNT", min=1,
                                               help="With --simulate: simulate P01..PN (default: the study's simulate.participants)."),
    pace: float = typer.Option(0.0, metavar="SECONDS", min=0.0, callback=finite,
                              help="With --simulate: seconds between answers."),
    force: bool = typer.Option(False, "--force", help="With --device wav:PATH or csv:PATH: replace a file there "
                               "that hapticfx did not write (its own are replaced anyway)."),
):
    """Run one participant through a study: stimuli play on the actuators, answers come from a local web page.

    Every answer is on disk (fsynced) as it is given. Run the same command again after an interruption: the
    session resumes at the first unanswered trial.
    """
    from .spec import load_study

    if pace > MAX_PACE_S:  # NaN and infinity are refused by the option's callback
        raise StudyError(f"--pace: expected seconds between answers in [0, {MAX_PACE_S:g}], got {pace:g}")
    spec = load_study(study)
    folder = out or Path("results") / spec.name
    dev = _device(device)
    if participant is None:
        if not simulate:
            raise StudyError("--participant is required (a simulated run may give --participants N instead)")
        ids = [f"P{i:02d}" for i in range(1, (participants or spec.simulate.participants) + 1)]
    else:
        if participants is not None:
            raise StudyError("give --participant or --participants, not both")
        ids = [participant]
    try:
        for pid in ids:
            run_one(study, pid, folder, device=dev, port=port, simulate=simulate, pace_s=pace, echo=typer.echo,
                    force=force)
    except KeyboardInterrupt:
        typer.echo("interrupted; every answer given is saved: run the same command to resume", err=True)
        raise typer.Exit(130)


def check(
    study: Path = typer.Argument(..., help="Study file (YAML)."),
    participant: str = typer.Option("P01", "--participant", "-p", metavar="ID", help="Whose schedule to show."),
    trials: bool = typer.Option(False, "--trials", help="List every trial of the schedule."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON (for programs) instead of the summary."),
):
    """Validate a study file and summarise one participant's schedule (exit 2 if the file is wrong)."""
    from .schedule import build_schedule
    from .spec import load_study

    spec = load_study(study)
    schedule = build_schedule(spec, participant)
    if as_json:
        _check_json(study, spec, participant, schedule, trials)
        return
    typer.echo(f"ok: {study} (study {spec.name!r}: {len(spec.stimuli)} stimuli, {len(spec.tasks)} tasks)")
    for task in spec.tasks:
        mine = [t for t in schedule if t.task == task.name]
        practice = sum(t.practice for t in mine)
        impacts = sum(len(s.velocities) for t in mine for s in t.slots)
        typer.echo(f"  {task.name} ({task.type}): {len(task.cells)} conditions, {len(mine) - practice} trials"
                   f" + {practice} practice, {impacts} impacts, order {task.options.order}")
    if trials:
        for t in schedule:
            slots = ", ".join(f"{s.name}={s.stimulus}@{'/'.join(f'{v:g}' for v in s.velocities)}" for s in t.slots)
            typer.echo(f"  {t.index:4d} {t.task} {'practice ' if t.practice else ''}{slots}"
                       + (f" (correct {t.correct})" if t.correct else ""))


def _check_json(path: Path, spec, participant: str, schedule, trials: bool) -> None:
    import json

    tasks = []
    for task in spec.tasks:
        mine = [t for t in schedule if t.task == task.name]
        practice = sum(t.practice for t in mine)
        tasks.append({"name": task.name, "type": task.type, "conditions": len(task.cells),
                      "trials": len(mine) - practice, "practice": practice,
                      "impacts": sum(len(s.velocities) for t in mine for s in t.slots), "order": task.options.order})
    out = {"file": str(path), "study": spec.name, "stimuli": len(spec.stimuli), "participant": participant,
           "tasks": tasks}
    if trials:
        out["schedule"] = [{"index": t.index, "task": t.task, "practice": bool(t.practice), "correct": t.correct or None,
                            "slots": [{"name": s.name, "stimulus": s.stimulus, "velocities": list(s.velocities)}
                                      for s in t.slots]} for t in schedule]
    typer.echo(json.dumps(out, indent=2))


def analyze(
    results: Path = typer.Argument(..., help="Results folder of `study run` (holds <participant>.jsonl files)."),
    out: Optional[Path] = typer.Option(None, "--out", "-o", metavar="DIR",
                                       help="Where to write tables, figures and the report "
                                                                  "(default: RESULTS/analysis)."),
):
    """Tidy CSV of all trials, means with 95% CIs, repeated-measures ANOVA, Holm pairwise tests, confusion
    matrices, PNG figures and a text report."""
    from ..atomic import atomic_path
    from .analysis import analyse, report
    from .plots import draw_all
    from .results import load_folder

    a = analyse(load_folder(results))
    folder = out or Path(results) / "analysis"
    folder.mkdir(parents=True, exist_ok=True)
    pd = __import__("pandas")
    tables = {
        "trials.csv": a.trials,
        "means.csv": pd.concat([r.means.assign(task=r.task, question=r.question) for r in a.ratings]) if a.ratings else None,
        "anova.csv": pd.concat([r.anova.assign(task=r.task, question=r.question) for r in a.ratings if r.anova is not None])
        if any(r.anova is not None for r in a.ratings) else None,
        "pairwise.csv": pd.concat([r.pairwise.assign(task=r.task, question=r.question) for r in a.ratings
                                   if r.pairwise is not None]) if any(r.pairwise is not None for r in a.ratings) else None,
        "confusion.csv": pd.concat([m.confusion.stack().rename("count").reset_index().assign(task=m.task)
                                    for m in a.matching]) if a.matching else None,
    }
    written = []
    for name, table in tables.items():
        if table is None:
            continue
        with atomic_path(folder / name) as tmp:
            table.to_csv(tmp, index=name == "anova.csv", index_label="effect" if name == "anova.csv" else None)
        written.append(folder / name)
    typer.echo("drawing figures", err=True)
    written += draw_all(a, folder)
    text = report(a)
    with atomic_path(folder / "report.txt") as tmp:
        tmp.write_text(text)
    typer.echo(text, nl=False)
    typer.echo(f"wrote {len(written) + 1} files to {folder}: {', '.join(p.name for p in written)}, report.txt")


def register(app: typer.Typer) -> None:
    study = typer.Typer(help="Perceptual studies: run the paper's user experiments and analyse them (docs/studies.md).",
                        no_args_is_help=True)
    app.add_typer(study, name="study")
    for fn in (check, run, analyze):
        study.command(fn.__name__)(fn)
