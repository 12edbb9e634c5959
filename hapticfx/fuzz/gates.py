"""The input gates and their valid seeds: every format a user, a file, a sender or a board hands hapticfx.

A gate's ``run(data, workdir)`` takes one (mutated) input and passes it through
the entry point a user would reach: a :class:`~hapticfx.errors.HapticfxError` is a
clean refusal, anything else escaping is a bug. Gates whose plugin is not
installed are skipped.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

EFFECT_SEEDS = (
    b"""name: brick
object: concrete-brick
velocity_mps: 3.8
model: {type: kinetic-energy, pulse_ms: 30}
actuator: {type: memory, gain: 0.8, limits: {peak: 0.9, rms: 0.6, rms_window_s: 0.02}}
""",
    b"""name: beam
object: wood-beam
velocity_mps: 4.1
model: {type: data-driven, dataset: builtin:helmet-drops, reducer: max-min, interpolator: ensemble}
actuator: {type: wav, path: out.wav, rate_hz: 8000, format: pcm16}
""",
    b"""name: mug
description: a described object
object: {id: mug, mass_kg: 0.3, material: ceramic, dimensions_mm: [80, 95, 80]}
model: {type: kinetic-energy}
actuator: {type: memory, full_scale_g: 2.0, channel: 0}
""",
)
SCENE_SEEDS = (
    b"""name: room
actuators:
  helmet: {type: memory, gain: 0.8, limits: {peak: 0.9}}
effects:
  concrete-brick:
    inline: {name: b, object: concrete-brick, model: {type: kinetic-energy}, actuator: {type: memory}}
    actuator: helmet
  wood-beam: {inline: {name: w, object: wood-beam, model: {type: kinetic-energy}, actuator: {type: memory}}, channel: 1}
events:
  osc: {host: 127.0.0.1, port: 9000}
engine: {queue_size: 64}
""",
)
# A study of every task type on two actuators; its effect files are written beside it (``_study_seeds``).
STUDY_SEED = b"""name: fuzz-study
seed: 7
actuators:
  vt: {type: memory, gain: 0.8}
  hap: {type: memory}
stimuli:
  phys: {effect: kinetic.yaml, actuator: vt, factors: {method: physics, object: concrete}}
  phys-hap: {effect: kinetic.yaml, actuator: hap, factors: {method: physics, object: concrete}}
  real: {recorded: {dataset: builtin:helmet-drops, object: concrete-brick, reducer: max-min}, actuator: vt,
         factors: {method: real, object: concrete}}
  real-wood: {recorded: {object: wood-beam, drop: representative}, actuator: vt, factors: {method: real, object: wood}}
tasks:
  - name: realism
    type: rating
    stimuli: [phys, phys-hap, real]
    velocities: [3.13, 3.7]
    per_trial: sequence
    order: latin-square
    practice: 1
    questions:
      - {id: realism, text: "How realistic was it?", anchors: [not at all, completely]}
  - name: match
    type: matching
    targets: [phys]
    comparisons: [real, real-wood]
    match_by: object
    velocities: [3.7]
    question: "Which one matches?"
  - name: similar
    type: similarity
    pairs: [[phys, real]]
    upper: [[real, real]]
    lower: [[real, real-wood]]
    velocities: [3.7, 3.96]
    repetitions: 2
    question: {id: similarity, text: "How similar?", anchors: [different, identical]}
simulate:
  participants: 2
  base: 60
  noise_sd: 10
  effects:
    - {when: {method: physics}, question: realism, shift: -5}
"""
CSV_HEADER = b"object,velocity_mps,drop,t_s,ax_g,ay_g,az_g\n"


def _csv_seed() -> bytes:
    rows = [CSV_HEADER]
    for v in (2.5, 3.5):
        t = np.arange(64) / 1000.0
        for ti in t:
            x = v * np.exp(-ti / 0.01) * np.sin(2 * np.pi * 120 * ti)
            rows.append(f"wood-beam,{v},0,{ti:.6f},{x:.5f},0.01,1.0\n".encode())
    return b"".join(rows)


def _osc(address: str, tags: str, *args) -> bytes:
    def pad(b: bytes) -> bytes:
        b += b"\0"
        return b + b"\0" * (-len(b) % 4)

    out = pad(address.encode()) + pad(("," + tags).encode())
    for t, a in zip(tags, args):
        out += {"s": lambda: pad(a.encode()), "f": lambda: struct.pack(">f", a), "i": lambda: struct.pack(">i", a),
                "d": lambda: struct.pack(">d", a)}[t]()
    return out


OSC_SEEDS = (_osc("/hapticfx/impact", "sf", "concrete-brick", 3.8), _osc("/hapticfx/impact", "sdif", "wood-beam", 4.2, 1, 0.5))
AT2_SEED = b"""PEER NGA STRONG MOTION DATABASE RECORD
TEST EVENT, 2026-11-22, HAPTICFX, 0
ACCELERATION TIME SERIES IN UNITS OF G
NPTS=   10, DT=   .0100 SEC
  .0010  -.0020   .0030  -.0010   .0005
 -.0040   .0020   .0010  -.0030   .0000
"""
SERIAL_SEEDS = (
    b"HAPTICFX-ACCEL 1 rate_hz=1000 sensor=ADXL335 board=GY-61 adc_bits=10 zero=512,512,512 counts_per_g=102.4,102.4,102.4",
    b"17,511,513,615",
    b"PONG 1 hapticfx-solenoid-0.1",
    b"STATUS on=0 used_ms=0 budget_ms=2500 max_on_ms=100 duty_permille=250 window_ms=10000 fired=0 refused=0",
    b"OK FIRE 30 200",
    b"ERR LIMIT pulse 200 ms over 100",
)


@dataclass(frozen=True)
class Gate:
    """One input format: valid seeds and the entry point that takes it; ``yaml`` when its inputs are YAML
    documents (the type-confusion mutator applies)."""

    name: str
    seeds: Callable[[Path], list[bytes]]
    run: Callable[[bytes, Path], None]
    yaml: bool = False


def _effect(data: bytes, work: Path) -> None:
    from ..pipeline import Pipeline

    path = work / "effect.yaml"
    path.write_bytes(data)
    Pipeline.from_effect(path, device="memory").render()


def _scene(data: bytes, work: Path) -> None:
    from ..scene import load_scene

    path = work / "scene.yaml"
    path.write_bytes(data)
    load_scene(path)


def _study_seeds(work: Path) -> list[bytes]:
    (work / "kinetic.yaml").write_bytes(EFFECT_SEEDS[0])
    return [STUDY_SEED]


def _study(data: bytes, work: Path) -> None:
    """What ``hapticfx study check`` does: load the study, then build a participant's schedule."""
    from ..study.schedule import build_schedule
    from ..study.spec import load_study

    path = work / "study.yaml"
    path.write_bytes(data)
    build_schedule(load_study(path), "P01")


def _csv(data: bytes, work: Path) -> None:
    from ..data.csv_import import read_csv_recordings

    path = work / "drops.csv"
    path.write_bytes(data)
    read_csv_recordings([path])


def _dataset_seeds(work: Path) -> list[bytes]:
    """A small dataset written once; the seeds are its dataset.json and one bank file."""
    from ..data.build import build_dataset
    from ..data.toy import toy_recordings
    from ..objects import PAPER_OBJECTS

    base = work / "dataset-seed"
    if not base.exists():
        build_dataset(base, [toy_recordings(PAPER_OBJECTS["wood-beam"], [2.4, 3.1, 3.9], drops=3, seed=0)],
                      name="fuzz", rate_hz=1000.0, sensor={}, provenance={})
    return [b"J" + (base / "dataset.json").read_bytes(), b"B" + (base / "banks/max-min/wood-beam.npz").read_bytes()]


def _dataset(data: bytes, work: Path) -> None:
    import shutil

    from ..data.dataset import open_dataset

    base, trial = work / "dataset-seed", work / "dataset-trial"
    shutil.rmtree(trial, ignore_errors=True)
    shutil.copytree(base, trial)
    target = trial / ("dataset.json" if data[:1] == b"J" else "banks/max-min/wood-beam.npz")
    target.write_bytes(data[1:])
    ds = open_dataset(trial)
    for obj in ds.objects:
        ds.bank(obj, "max-min")
        ds.windows(obj)


def _checkpoint_seeds(work: Path) -> list[bytes]:
    from hapticfx_neural.checkpoint import default_weights

    shipped = default_weights("helmet-drops", "max-min", "convbilstm")
    return [shipped.with_suffix(".json").read_bytes()] if shipped else []


def _checkpoint(data: bytes, work: Path) -> None:
    from hapticfx_neural.checkpoint import read_meta

    (work / "model.safetensors").write_bytes(b"")
    (work / "model.json").write_bytes(data)
    read_meta(work / "model.safetensors")


def _osc_run(data: bytes, work: Path) -> None:
    from ..osc import decode_message, parse_impact

    address, tags, args = decode_message(data)  # an OscDecodeError is a drop the bridge counts by reason
    parse_impact(tags, args)


def _serial(data: bytes, work: Path) -> None:
    """One line from a board: the accelerometer's HELLO or sample, the solenoid's replies (each tried)."""
    from ..board.protocol import parse_hello, parse_sample
    from ..errors import HapticfxError

    line = data.decode("latin-1")
    parse_sample(line)
    parsers = [parse_hello]
    if _installed("hapticfx_solenoid"):
        from hapticfx_solenoid import protocol

        line = protocol.decode_line(data + b"\n")
        parsers += [protocol.parse_pong, protocol.parse_status, protocol.parse_fire_reply]
    for parse in parsers:  # a line is meant for one of them: the others refuse it cleanly
        try:
            parse(line)
        except HapticfxError:
            pass


def _at2(data: bytes, work: Path) -> None:
    from ..groundmotion import read_at2

    path = work / "record.AT2"
    path.write_bytes(data)
    read_at2(path)


def _haptic_seeds(suffix: str):
    """A file of each platform format, exported from a decaying sine with a sharp onset."""

    def seeds(work: Path) -> list[bytes]:
        from ..formats import ExportOptions, format_for
        from ..formats.device import PRESETS
        from ..signal import Signal

        t = np.arange(9600) / 48000
        x = Signal(np.where(t > 0.01, 0.6 * np.exp(-t / 0.05) * np.sin(2 * np.pi * 120 * t), 0.0), 48000.0)
        path = work / f"seed{suffix}"
        format_for(path).write(path, x, ExportOptions(device=PRESETS["quest"]))
        return [path.read_bytes()]

    return seeds


def _haptic_file(suffix: str):
    """Read, validate and render a haptic file as ``hapticfx play`` does before shaping."""

    def run(data: bytes, work: Path) -> None:
        from ..formats import format_for
        from ..formats.device import PRESETS

        path = work / f"fuzz{suffix}"
        path.write_bytes(data)
        format_for(path).read(path, PRESETS["quest"], rate_hz=8000.0)

    return run


def _installed(module: str) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None


def gates() -> dict[str, Gate]:
    """Every gate whose code is installed."""
    out = [
        Gate("effect", lambda w: list(EFFECT_SEEDS), _effect, yaml=True),
        Gate("scene", lambda w: list(SCENE_SEEDS), _scene, yaml=True),
        Gate("study", _study_seeds, _study, yaml=True),
        Gate("csv", lambda w: [_csv_seed()], _csv),
        Gate("dataset", _dataset_seeds, _dataset),
        Gate("osc", lambda w: list(OSC_SEEDS), _osc_run),
        Gate("serial", lambda w: list(SERIAL_SEEDS), _serial),
        Gate("at2", lambda w: [AT2_SEED], _at2),
        *(Gate(name, _haptic_seeds(suffix), _haptic_file(suffix))
          for name, suffix in (("haptic", ".haptic"), ("android", ".android.json"), ("hjif", ".hjif"))),
    ]
    if _installed("hapticfx_neural"):
        out.append(Gate("checkpoint", _checkpoint_seeds, _checkpoint))
    return {g.name: g for g in out}
