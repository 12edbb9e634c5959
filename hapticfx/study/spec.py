"""Study files: a perceptual experiment's stimuli, tasks and randomisation, read strictly.

A study file is YAML read with the same strict loader as effect files; an
unknown key, a wrong type or a dangling name is a :class:`StudyError` naming
the file, the key path and what was expected. See docs/studies.md.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from ..effect import Effect, check_effect, effect_from_mapping, load_effect, parse_actuator_section, read_yaml
from ..atomic import user_path
from ..errors import EffectError, HapticfxError, StudyError, preview
from ..params import doc, parse_params

TOP_KEYS = ("name", "description", "seed", "task_order", "actuators", "stimuli", "tasks", "simulate")
STIMULUS_KEYS = ("effect", "recorded", "actuator", "factors")
RECORDED_KEYS = ("dataset", "object", "reducer", "drop")
LIST_KEYS = {
    "rating": ("stimuli", "questions"),
    "matching": ("targets", "comparisons", "match_by", "question"),
    "similarity": ("pairs", "upper", "lower", "question"),
}
COMMON_KEYS = ("name", "type", "velocities")
# How a trial's stimulus slots are named on the participant's page.
SLOT_NAMES = "ABCDEFGHIJKLMNOPQRSTUVWXYZ"


@dataclass(frozen=True)
class Stimulus:
    """A named stimulus: an effect (or a recorded drop) on one of the study's actuators.

    ``drops`` is ``"random"`` when each presentation of a recorded stimulus plays
    another of the repeated drops at that velocity (as a real object dropped again
    would), ``"representative"`` for the bank's representative drop, and None for
    rendered effects.
    """

    name: str
    effect: Effect
    actuator: str
    factors: dict[str, str]
    recorded: bool
    drops: Literal["random", "representative"] | None = None

    @property
    def object_id(self) -> str:
        return self.effect.object_id


@dataclass(frozen=True)
class Question:
    """One rating scale: what is asked, its range and the labels at points of it."""

    id: str
    text: str
    anchors: tuple[tuple[float, str], ...]
    low: float = 0.0
    high: float = 100.0

    def holds(self, value) -> bool:
        """Whether ``value`` is a rating on this scale: a number in [low, high] (nan and infinity are not)."""
        return not isinstance(value, bool) and isinstance(value, (int, float)) and self.low <= value <= self.high


@dataclass(frozen=True)
class TaskOptions:
    """The keys every task accepts besides its stimuli."""

    instructions: str = field(default="", metadata=doc("shown before the task's first trial"))
    repetitions: int = field(default=1, metadata=doc("times each condition is presented per velocity", min=1, max=1000))
    order: Literal["random", "latin-square"] = field(
        default="random", metadata=doc("trials shuffled, or conditions in a balanced Latin square row per participant"))
    practice: int = field(default=0, metadata=doc("practice trials before the task (not analysed)", min=0, max=1000))
    break_every: int = field(default=0, metadata=doc("a break after this many trials (0: none)", min=0, max=100000))
    break_s: float = field(default=0.0, metadata=doc("shortest break (s)", min=0.0, max=3600.0))
    replay: bool | None = field(default=None, metadata=doc("stimuli may be played again (default: matching only)"))
    gap_s: float = field(default=0.8, metadata=doc("pause between impacts played in a row (s)", min=0.0, max=60.0))
    per_trial: Literal["each", "sequence"] = field(
        default="each", metadata=doc("rating: one velocity per trial, or every velocity in one trial (paper study 1)"))


@dataclass(frozen=True)
class Task:
    """One task of a study, with its cells: what one trial presents, before velocities and repetitions.

    ``cells`` maps a condition label to the stimulus names its trial plays:
    rating ``(stimulus,)``, matching ``(target, comparison, ...)``, similarity ``(a, b)``.
    ``roles`` gives a similarity cell's role (``test``, ``upper`` or ``lower``).
    """

    name: str
    type: Literal["rating", "matching", "similarity"]
    velocities: tuple[float, ...]
    options: TaskOptions
    cells: dict[str, tuple[str, ...]]
    questions: tuple[Question, ...]
    match_by: str | None = None
    roles: dict[str, str] = field(default_factory=dict)

    @property
    def replay(self) -> bool:
        return self.options.replay if self.options.replay is not None else self.type == "matching"


@dataclass(frozen=True)
class SimulatedEffect:
    """A known shift of the simulated ratings where a trial's stimulus has the given factor levels."""

    shift: float
    when: dict[str, str]
    task: str | None = None
    question: str | None = None


@dataclass(frozen=True)
class Simulation:
    """The simulated participant's noise and bias model (``--simulate``)."""

    noise_sd: float = field(default=10.0, metadata=doc("rating noise of each answer (scale points)", min=0.0, max=1000.0))
    participant_sd: float = field(default=8.0, metadata=doc("each participant's own offset, per question (points)", min=0.0, max=1000.0))
    base: float = field(default=50.0, metadata=doc("rating before effects, in scale points"))
    similarity_scale: float = field(default=1.0, metadata=doc("perceptual distance at which similarity falls to 37 %", min=1e-6))
    choice_temperature: float = field(default=0.25, metadata=doc("matching: softmax temperature on perceptual distance", min=1e-6))
    participants: int = field(default=10, metadata=doc("participants `study run --simulate --all` simulates", min=1, max=10000))
    effects: tuple[SimulatedEffect, ...] = ()


@dataclass(frozen=True)
class Study:
    """A validated study file."""

    name: str
    source: str
    sha256: str
    seed: int
    task_order: Literal["fixed", "latin-square"]
    actuators: dict[str, Any]
    stimuli: dict[str, Stimulus]
    tasks: tuple[Task, ...]
    simulate: Simulation
    description: str = ""
    base_dir: Path = Path(".")


def _fail(message: str, source: str, key: str) -> StudyError:
    return StudyError(message, source=source, key=key)


def _mapping(value, source, key, *, empty_ok=False) -> dict:
    if not isinstance(value, dict) or (not value and not empty_ok):
        raise _fail(f"expected a {'' if empty_ok else 'non-empty '}mapping, got {preview(value)}", source, key)
    return value


def _name(value, source, key) -> str:
    if not isinstance(value, str) or not value.strip() or len(value) > 200:
        raise _fail(f"expected a non-empty name, got {preview(value)}", source, key)
    return value


def _only(raw: dict, allowed: tuple[str, ...], source, key) -> None:
    unknown = [k for k in raw if k not in allowed]
    if unknown:
        raise _fail(f"unknown key {preview(unknown[0])}; allowed: {', '.join(allowed)}", source, key)


def _names(value, source, key, known: dict, *, what="stimulus") -> tuple[str, ...]:
    if not isinstance(value, list) or not value:
        raise _fail(f"expected a non-empty list of {what} names, got {preview(value)}", source, key)
    for i, n in enumerate(value):
        if not isinstance(n, str) or n not in known:
            raise _fail(f"unknown {what} {preview(n)}; the study's stimuli: {', '.join(known)}", source, f"{key}[{i}]")
    if len(set(value)) != len(value):
        raise _fail(f"names a stimulus twice: {preview(value)}", source, key)
    return tuple(value)


def _rekeyed(exc: EffectError, source: str, key: str) -> StudyError:
    """An effect-level error re-homed under ``key`` of the study file."""
    text = str(exc)
    if exc.source and text.startswith(f"{exc.source}: "):
        text = text[len(exc.source) + 2:]
    if exc.key and text.startswith(f"{exc.key}: "):
        text = text[len(exc.key) + 2:]
    if exc.source == source and (exc.key or "").startswith("actuators."):  # the study's own actuator section
        return StudyError(text, source=source, key=exc.key)
    inner = exc.key if exc.key and exc.key not in ("(top level)", "model", "actuator") else ""
    if exc.source != source:  # an effect file: keep its name, it is where the fix goes
        return StudyError(f"{exc.source}: {exc.key + ': ' if exc.key else ''}{text}", source=source, key=key)
    return StudyError(text, source=source, key=f"{key}.{inner}" if inner else key)


def _stimulus(name, raw, *, source, base_dir, actuators) -> Stimulus:
    key = f"stimuli.{name}"
    _name(name, source, "stimuli")
    raw = _mapping(raw, source, key)
    _only(raw, STIMULUS_KEYS, source, key)
    if ("effect" in raw) == ("recorded" in raw):
        raise _fail("give exactly one of 'effect' (an effect file) or 'recorded' (a dataset's recorded drops)", source, key)
    if "actuator" in raw:
        actuator = raw["actuator"]
        if not isinstance(actuator, str) or actuator not in actuators:
            raise _fail(f"unknown actuator {preview(actuator)}; the study's actuators: {', '.join(actuators)}", source, f"{key}.actuator")
    elif len(actuators) == 1:
        actuator = next(iter(actuators))
    else:
        raise _fail(f"say which actuator plays it; the study's actuators: {', '.join(actuators)}", source, key)
    factors = _mapping(raw.get("factors", {}), source, f"{key}.factors", empty_ok=True)
    for f, level in factors.items():
        if not isinstance(f, str) or not isinstance(level, (str, int, float)) or isinstance(level, bool):
            raise _fail(f"expected factor: level (a name or number), got {preview(f)}: {preview(level)}", source, f"{key}.factors")
    factors = {f: str(level) for f, level in factors.items()}
    drops = None
    try:
        if "effect" in raw:
            path = user_path(_name(raw["effect"], source, f"{key}.effect"))
            effect = load_effect(path if path.is_absolute() else base_dir / path)
        else:
            rec = _mapping(raw["recorded"], source, f"{key}.recorded")
            _only(rec, RECORDED_KEYS, source, f"{key}.recorded")
            if "object" not in rec:
                raise _fail("required key 'object' is missing", source, f"{key}.recorded")
            drops = rec.get("drop", "random")
            if drops not in ("random", "representative"):
                raise _fail(f"expected 'random' or 'representative', got {preview(drops)}", source, f"{key}.recorded.drop")
            model = {"type": "recorded", **{k: rec[k] for k in ("dataset", "reducer") if k in rec}}
            effect = effect_from_mapping({"name": name, "object": rec["object"], "model": model, "actuator": {"type": "memory"}},
                                         source=source, base_dir=base_dir)
        effect = dataclasses.replace(effect, actuator=actuators[actuator], actuator_at=(source, f"actuators.{actuator}"))
        check_effect(effect)
        if "recorded" in raw:
            _recorded_bank(effect)
    except StudyError:  # already names this file and key
        raise
    except EffectError as exc:
        raise _rekeyed(exc, source, f"{key}.recorded" if "recorded" in raw else f"{key}.effect") from None
    except HapticfxError as exc:  # a dataset or plugin error, raised while checking the stimulus
        raise _fail(str(exc), source, f"{key}.recorded" if "recorded" in raw else f"{key}.effect") from None
    return Stimulus(name, effect, actuator, factors, "recorded" in raw, drops)


def _recorded_bank(effect: Effect):
    """The bank a recorded stimulus draws from (opens the dataset; reads the object's bank)."""
    from ..models.recorded import RecordedDropModel

    model = RecordedDropModel(check_effect(effect).model_params, effect.context())
    return model.dataset.bank(effect.object_id, model.params.reducer)


def recorded_velocities(stimulus: Stimulus) -> tuple[float, ...]:
    """The velocities a recorded stimulus can play."""
    return tuple(float(v) for v in _recorded_bank(stimulus.effect).velocities)


def _velocities(value, source, key) -> tuple[float, ...]:
    if not isinstance(value, list) or not value:
        raise _fail(f"expected a non-empty list of impact velocities (m/s), got {preview(value)}", source, key)
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 < v <= 100:
            raise _fail(f"expected a velocity in (0, 100] m/s, got {preview(v)}", source, f"{key}[{i}]")
        out.append(float(v))
    if len(set(out)) != len(out):
        raise _fail(f"lists a velocity twice: {preview(value)}", source, key)
    return tuple(out)


def _question(raw, source, key, *, default_id: str) -> Question:
    if isinstance(raw, str):
        raw = {"text": raw}
    raw = _mapping(raw, source, key)
    _only(raw, ("id", "text", "anchors", "range"), source, key)
    qid = _name(raw.get("id", default_id), source, f"{key}.id")
    text = _name(raw.get("text"), source, f"{key}.text") if "text" in raw else None
    if text is None:
        raise _fail("required key 'text' is missing (the wording of the question)", source, key)
    low, high = 0.0, 100.0
    if "range" in raw:
        r = raw["range"]
        if (not isinstance(r, list) or len(r) != 2 or any(isinstance(x, bool) or not isinstance(x, (int, float)) for x in r)
                or not r[0] < r[1]):
            raise _fail(f"expected [low, high] with low < high, got {preview(r)}", source, f"{key}.range")
        low, high = float(r[0]), float(r[1])
    anchors = raw.get("anchors", [])
    if isinstance(anchors, list):
        if len(anchors) not in (0, 2) or not all(isinstance(a, str) for a in anchors):
            raise _fail(f"expected [label at low, label at high] or a mapping point: label, got {preview(anchors)}", source,
                        f"{key}.anchors")
        anchors = dict(zip((low, high), anchors))
    elif not isinstance(anchors, dict):
        raise _fail(f"expected a list or a mapping point: label, got {preview(anchors)}", source, f"{key}.anchors")
    points = []
    for point, label in anchors.items():
        if isinstance(point, bool) or not isinstance(point, (int, float)) or not low <= point <= high or not isinstance(label, str):
            raise _fail(f"expected a point in [{low:g}, {high:g}] and a label, got {preview(point)}: {preview(label)}", source, f"{key}.anchors")
        points.append((float(point), label))
    return Question(qid, text, tuple(sorted(points)), low, high)


def _pairs(value, source, key, stimuli, role) -> dict[str, tuple[str, str]]:
    if not isinstance(value, list) or (not value and role == "test"):
        raise _fail(f"expected a list of [stimulus, stimulus] pairs, got {preview(value)}", source, key)
    out = {}
    for i, pair in enumerate(value):
        if not isinstance(pair, list) or len(pair) != 2:
            raise _fail(f"expected [stimulus, stimulus], got {preview(pair)}", source, f"{key}[{i}]")
        for j, n in enumerate(pair):
            if not isinstance(n, str) or n not in stimuli:
                raise _fail(f"unknown stimulus {preview(n)}; the study's stimuli: {', '.join(stimuli)}", source, f"{key}[{i}][{j}]")
        label = f"{pair[0]}|{pair[1]}"
        if label in out:
            raise _fail(f"pair {preview(pair)} is listed twice", source, f"{key}[{i}]")
        out[label] = (pair[0], pair[1])
    return out


def _task_list(value, source) -> list:
    if not isinstance(value, list) or not value:
        raise _fail(f"expected a non-empty list of tasks, got {preview(value)}", source, "tasks")
    return value


def _task_head(i: int, raw, source) -> tuple[dict, str, str, tuple[Question, ...]]:
    """A task's mapping, type, name and questions: all that the answers to it are checked against."""
    key = f"tasks[{i}]"
    raw = _mapping(raw, source, key)
    kind = raw.get("type")
    if not isinstance(kind, str) or kind not in LIST_KEYS:
        raise _fail(f"expected type rating, matching or similarity, got {preview(kind)}", source, f"{key}.type")
    allowed = COMMON_KEYS + LIST_KEYS[kind] + tuple(f.name for f in dataclasses.fields(TaskOptions))
    _only(raw, allowed, source, key)
    name = _name(raw.get("name"), source, f"{key}.name")
    asked = "questions" if kind == "rating" else "question"
    if asked not in raw:
        raise _fail(f"required key {preview(asked)} is missing", source, key)
    if kind != "rating":
        return raw, kind, name, (_question(raw["question"], source, f"{key}.question", default_id=name),)
    qs = raw["questions"]
    if not isinstance(qs, list) or not qs:
        raise _fail(f"expected a non-empty list of questions, got {preview(qs)}", source, f"{key}.questions")
    questions = tuple(_question(q, source, f"{key}.questions[{j}]", default_id=name if len(qs) == 1 else f"q{j + 1}")
                      for j, q in enumerate(qs))
    if len({q.id for q in questions}) != len(questions):
        raise _fail("two questions have the same id", source, f"{key}.questions")
    return raw, kind, name, questions


def task_questions(path: str | Path) -> dict[str, tuple[str, tuple[Question, ...]]]:
    """Each task's type and questions (task name -> (type, questions)), read from a study file without opening
    the effects and datasets it names: what a results folder's copy of its study file says its answers are."""
    source = str(path)
    data = _mapping(read_yaml(Path(path)), source, "(top level)")
    heads = [_task_head(i, raw, source) for i, raw in enumerate(_task_list(data.get("tasks"), source))]
    return {name: (kind, questions) for _, kind, name, questions in heads}


def _task(i: int, raw, *, source, stimuli: dict[str, Stimulus], seen: set) -> Task:
    key = f"tasks[{i}]"
    raw, kind, name, questions = _task_head(i, raw, source)
    if name in seen:
        raise _fail(f"another task is named {preview(name)}", source, f"{key}.name")
    seen.add(name)
    if "velocities" not in raw:
        raise _fail("required key 'velocities' is missing", source, key)
    velocities = _velocities(raw["velocities"], source, f"{key}.velocities")
    options = parse_params(TaskOptions, {k: v for k, v in raw.items() if k not in COMMON_KEYS + LIST_KEYS[kind]},
                           source=source, key=key)
    for needed in LIST_KEYS[kind]:
        if needed not in raw and needed not in ("upper", "lower"):
            raise _fail(f"required key {preview(needed)} is missing", source, key)
    match_by, roles = None, {}
    if kind == "rating":
        cells = {n: (n,) for n in _names(raw["stimuli"], source, f"{key}.stimuli", stimuli)}
    elif kind == "matching":
        targets = _names(raw["targets"], source, f"{key}.targets", stimuli)
        comparisons = _names(raw["comparisons"], source, f"{key}.comparisons", stimuli)
        if not 2 <= len(comparisons) <= len(SLOT_NAMES):
            raise _fail(f"expected 2 to {len(SLOT_NAMES)} comparisons, got {len(comparisons)}", source, f"{key}.comparisons")
        match_by = _name(raw["match_by"], source, f"{key}.match_by")
        for n in targets + comparisons:
            if match_by not in stimuli[n].factors:
                raise _fail(f"stimulus {preview(n)} has no factor {preview(match_by)} (stimuli.{n}.factors)", source, f"{key}.match_by")
        for t in targets:
            hits = [c for c in comparisons if stimuli[c].factors[match_by] == stimuli[t].factors[match_by]]
            if len(hits) != 1:
                raise _fail(f"target {preview(t)} must match exactly one comparison by {preview(match_by)}, matches {hits or 'none'}",
                            source, f"{key}.targets")
        cells = {t: (t, *comparisons) for t in targets}
    else:
        cells = {}
        for role in ("test", "upper", "lower"):
            pairs = _pairs(raw.get("pairs" if role == "test" else role, []), source,
                           f"{key}.{'pairs' if role == 'test' else role}", stimuli, role)
            for label in pairs:
                if label in cells:
                    raise _fail(f"pair {preview(label)} is listed twice", source, key)
                roles[label] = role
            cells.update(pairs)
    used = {s for cell in cells.values() for s in cell}
    for s in sorted(used):
        if stimuli[s].recorded:
            have = recorded_velocities(stimuli[s])
            missing = [v for v in velocities if v not in have]
            if missing:
                raise _fail(f"recorded stimulus {preview(s)} has no drops at {', '.join(f'{v:g}' for v in missing)} m/s; "
                            f"recorded: {', '.join(f'{v:g}' for v in have)}", source, f"{key}.velocities")
    return Task(name, kind, velocities, options, cells, questions, match_by, roles)


def _simulation(raw, source, tasks: tuple[Task, ...], stimuli: dict[str, Stimulus]) -> Simulation:
    raw = dict(_mapping(raw, source, "simulate", empty_ok=True))
    levels: dict[str, dict[str, None]] = {}  # factor -> its levels (in order), over the study's stimuli
    for stimulus in stimuli.values():
        for f, level in stimulus.factors.items():
            levels.setdefault(f, {})[level] = None
    effects = raw.pop("effects", [])
    if not isinstance(effects, list):
        raise _fail(f"expected a list of effects, got {preview(effects)}", source, "simulate.effects")
    parsed = []
    for i, e in enumerate(effects):
        k = f"simulate.effects[{i}]"
        e = _mapping(e, source, k)
        _only(e, ("shift", "when", "task", "question"), source, k)
        shift = e.get("shift")
        if isinstance(shift, bool) or not isinstance(shift, (int, float)) or not math.isfinite(shift):
            raise _fail(f"expected a number of scale points, got {preview(shift)}", source, f"{k}.shift")
        task, question = e.get("task"), e.get("question")
        if task is not None and task not in [t.name for t in tasks]:  # a list: a task given as a list is unhashable
            raise _fail(f"unknown task {preview(task)}; the study's tasks: {', '.join(t.name for t in tasks)}", source,
                        f"{k}.task")
        asked = list(dict.fromkeys(q.id for t in tasks if task in (None, t.name) for q in t.questions))
        if question is not None and question not in asked:
            raise _fail(f"unknown question {preview(question)}; {f'task {task}' if task else 'the study'} asks "
                        f"{', '.join(asked)}", source, f"{k}.question")
        when = {str(f): str(v) for f, v in _mapping(e.get("when", {}), source, f"{k}.when", empty_ok=True).items()}
        for f, level in when.items():  # an effect no stimulus can have would silently shift nothing
            if f not in levels:
                raise _fail(f"no stimulus has a factor {preview(f)}; the stimuli's factors: {', '.join(levels) or 'none'}",
                            source, f"{k}.when")
            if level not in levels[f]:
                raise _fail(f"no stimulus has {f} {preview(level)}; its levels: {', '.join(levels[f])}", source,
                            f"{k}.when.{f}")
        parsed.append(SimulatedEffect(float(shift), when, task, question))
    sim = parse_params(Simulation, raw, source=source, key="simulate")
    return dataclasses.replace(sim, effects=tuple(parsed))


def study_from_mapping(data: Any, *, source: str, base_dir: Path, sha256: str = "") -> Study:
    """Validate a study mapping; the effect files and datasets it names are read and checked too."""
    if data is None:
        raise _fail("the file is empty; a study needs name, actuators, stimuli and tasks", source, "(top level)")
    data = _mapping(data, source, "(top level)")
    _only(data, TOP_KEYS, source, "(top level)")
    for required in ("name", "actuators", "stimuli", "tasks"):
        if required not in data:
            raise _fail(f"required key {preview(required)} is missing", source, "(top level)")
    name = _name(data["name"], source, "name")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise _fail(f"expected a string, got {preview(description)}", source, "description")
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise _fail(f"expected an integer >= 0, got {preview(seed)}", source, "seed")
    task_order = data.get("task_order", "fixed")
    if task_order not in ("fixed", "latin-square"):
        raise _fail(f"expected 'fixed' or 'latin-square', got {preview(task_order)}", source, "task_order")
    actuators = {str(n): parse_actuator_section(a, source=source, key=f"actuators.{n}")
                 for n, a in _mapping(data["actuators"], source, "actuators").items()}
    stimuli = {n: _stimulus(n, raw, source=source, base_dir=base_dir, actuators=actuators)
               for n, raw in _mapping(data["stimuli"], source, "stimuli").items()}
    seen: set = set()
    tasks = tuple(_task(i, t, source=source, stimuli=stimuli, seen=seen)
                  for i, t in enumerate(_task_list(data["tasks"], source)))
    simulate = _simulation(data.get("simulate", {}), source, tasks, stimuli)
    return Study(name, source, sha256, seed, task_order, actuators, stimuli, tasks, simulate, description, base_dir)


def load_study(path: str | Path) -> Study:
    """Read and validate a study file (and the effect files and datasets it names)."""
    path = Path(path)
    data = read_yaml(path)
    sha = hashlib.sha256(path.read_bytes()).hexdigest()
    return study_from_mapping(data, source=str(path), base_dir=path.resolve().parent, sha256=sha)

