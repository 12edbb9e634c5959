"""An actuator plugin the core cannot take at its word: its spec is checked when it is built and again after
open(), where it may change its rate but not its hard limits; each head site holds its own channel's limits.
A model's SystemExit is one failed impact, not a dead engine."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from hapticfx import hookspecs
from hapticfx.actuators.virtual import MemoryActuator
from hapticfx.engine import Engine
from hapticfx.errors import PluginError
from hapticfx.interfaces import ActuatorSpec, SafetyLimits
from hapticfx.pipeline import Pipeline
from hapticfx.registry import Registry, create_plugin_manager

KE = "{type: kinetic-energy, ke_max_j: 0.1}"  # a loud square pulse: any impact reaches full scale


def _registry(**plugins):
    """A registry with the core's plugins and these: ``_registry(actuators={"fx-test": cls}, models={...})``."""
    class P:
        pass

    for kind, named in plugins.items():
        def hook(self, register, named=named):
            for name, cls in named.items():
                register(name, cls)

        setattr(P, f"register_{kind}", hookspecs.hookimpl(hook))
    pm, infos = create_plugin_manager(entry_points=False)
    pm.register(P(), name="fx-test-plugin")
    return Registry(pm, infos)


def _effect(tmp_path, actuator="{type: fx-test}"):
    path = tmp_path / "e.yaml"
    path.write_text(f"name: e\nobject: concrete-brick\nmodel: {KE}\nactuator: {actuator}\n")
    return path


def _spec(**change):
    return dataclasses.replace(ActuatorSpec(8000.0, 1.0, (0.0, 4000.0), limits=SafetyLimits(peak=0.9, rms=0.9)),
                               **change)


class _Loose(SafetyLimits):
    def __post_init__(self):  # skips the checks that keep peak <= 1
        pass


@pytest.mark.parametrize("change, words", [
    (dict(rate_hz=math.nan), "rate_hz nan"),
    (dict(rate_hz=1e9), "rate_hz 1000000000.0"),
    (dict(band_hz=(3000.0, 50.0)), "band_hz (3000.0, 50.0)"),
    (dict(volts_peak=math.nan), "volts_peak nan"),
    (dict(default_gain="1"), "default_gain '1'"),
    (dict(limits=None), "limits of type NoneType"),
    (dict(limits=_Loose(peak=5.0, rms=5.0)), "limits of type _Loose"),
])
def test_a_spec_out_of_bounds_is_refused_naming_the_actuator(tmp_path, change, words):
    class Odd(MemoryActuator):
        name = "fx-test"

        def __init__(self, params, context):
            super().__init__(params, context, spec=_spec(**change))

    with pytest.raises(PluginError) as err:
        Pipeline.from_effect(_effect(tmp_path), registry=_registry(actuators={"fx-test": Odd}))
    assert f"actuator 'fx-test': its spec has {words}" in str(err.value) and str(err.value).startswith(str(tmp_path))


def test_hard_limits_changed_in_open_are_refused(tmp_path):
    class Changes(MemoryActuator):
        name = "fx-test"

        def __init__(self, params, context):
            super().__init__(params, context, spec=_spec())

        def open(self):
            self.spec = _spec(rate_hz=16000.0, limits=SafetyLimits(peak=0.1, rms=0.05))

    with pytest.raises(PluginError, match="'fx-test' changed its hard limits when it opened"):
        Pipeline.from_effect(_effect(tmp_path), registry=_registry(actuators={"fx-test": Changes})).open()


def test_each_head_site_holds_its_own_channels_hard_limits(tmp_path):
    """A plugin may declare stricter limits on one channel: the site on that channel keeps them."""
    class PerChannel(MemoryActuator):
        name = "fx-test"

        def __init__(self, params, context):
            peak = 0.1 if context.channel == 1 else 0.9
            super().__init__(params, context, spec=_spec(limits=SafetyLimits(peak=peak, rms=peak)))

    _effect(tmp_path, "{type: memory}")
    scene = tmp_path / "s.yaml"
    scene.write_text("name: s\nactuators:\n  helmet: {type: fx-test}\n"
                     "head:\n  actuator: helmet\n  sites:\n"
                     "    crown: {position: [0.0, 0.0, 0.13], channel: 0}\n"
                     "    front: {position: [0.0, 0.1126, 0.065], channel: 1}\n"
                     "effects:\n  brick: {effect: e.yaml, actuator: helmet}\n")
    engine = Engine(scene, registry=_registry(actuators={"fx-test": PerChannel}))
    engine.impact("brick", 5.0, point=[0.0, 0.1126, 0.065])
    engine.close()  # plays what is queued
    sites = {s.channel: s.actuator for s in engine._outputs["actuators.helmet"].sites}
    front = np.concatenate([s.samples for s in sites[1].played])
    assert 0.0 < np.max(np.abs(front)) <= 0.1 + 1e-12


def test_a_models_system_exit_is_one_failed_impact_and_the_engine_serves_on(tmp_path):
    from hapticfx.models.kinetic import KineticEnergyModel

    class Quits(KineticEnergyModel):
        def terms(self, impact):  # what the pipeline renders a kinetic-energy impact from
            if impact.velocity > 4.0:
                raise SystemExit(1)
            return super().terms(impact)

    path = tmp_path / "e.yaml"
    path.write_text("name: e\nobject: concrete-brick\nmodel: {type: fx-quits}\nactuator: {type: memory}\n")
    scene = tmp_path / "s.yaml"
    scene.write_text("name: s\neffects:\n  brick: e.yaml\n")
    engine = Engine(scene, registry=_registry(models={"fx-quits": Quits}))
    engine.impact("brick", 5.0)
    engine.impact("brick", 3.0)
    stats = engine.close()  # plays what is queued
    out = stats["outputs"]["brick"]
    assert (out["failed"], out["rendered"], out.get("errors")) == (1, 1, {"SystemExit": 1}), stats


def test_close_is_bounded_and_plays_nothing_into_a_closed_actuator(tmp_path):
    """A render that outlasts close_timeout_s is cancelled, not played; an actuator whose close() hangs is
    named and left behind, and close() returns."""
    import threading
    import time

    from hapticfx.models.kinetic import KineticEnergyModel

    release = threading.Event()

    class Slow(KineticEnergyModel):
        def terms(self, impact):
            time.sleep(0.6)
            return super().terms(impact)

    class Hangs(MemoryActuator):
        name = "fx-test"
        closing = False

        def close(self):
            self.closing = True
            release.wait()

        def play(self, signal):  # an impact played after close() would fail here, not be cancelled
            assert not self.closing, "play() after close()"
            super().play(signal)

    path = tmp_path / "e.yaml"
    path.write_text("name: e\nobject: concrete-brick\nmodel: {type: fx-slow}\nactuator: {type: fx-test}\n")
    scene = tmp_path / "s.yaml"
    scene.write_text("name: s\neffects:\n  brick: e.yaml\nengine: {close_timeout_s: 0.2}\n")
    engine = Engine(scene, registry=_registry(models={"fx-slow": Slow}, actuators={"fx-test": Hangs}))
    engine.impact("brick", 3.0)
    time.sleep(0.1)  # it is rendering
    started, closed = time.monotonic(), []
    closer = threading.Thread(target=lambda: closed.append(engine.close()), daemon=True)
    closer.start()
    closer.join(5.0)
    took = time.monotonic() - started
    release.set()
    assert closed, "close() did not return"
    stats = closed[0]
    time.sleep(0.7)  # the render ends: it must not be played into the closed actuator
    assert took < 3.0 and stats["close_errors"] == {"brick": "close() did not return within 1 s"}
    assert engine.stats()["outputs"]["brick"]["cancelled"] == 1


@pytest.mark.parametrize("returns, words", [
    (lambda: np.ones(100), "model 'fx-bad' rendered a ndarray, not a Signal"),
    (lambda: None, "model 'fx-bad' rendered a NoneType, not a Signal"),
    (lambda: __import__("hapticfx.signal", fromlist=["Signal"]).Signal(np.full(10, np.nan), 1000.0),
     "model: Signal.samples has 10 non-finite value(s)"),
])
def test_a_models_bad_profile_is_one_error_naming_the_effect(tmp_path, returns, words):
    from hapticfx.interfaces import Model

    class Bad(Model):
        name = "fx-bad"

        def __init__(self, params, context):
            pass

        def render(self, impact):
            return returns()

    path = tmp_path / "e.yaml"
    path.write_text("name: e\nobject: concrete-brick\nmodel: {type: fx-bad}\nactuator: {type: memory}\n")
    from hapticfx.errors import HapticfxError

    with Pipeline.from_effect(path, registry=_registry(models={"fx-bad": Bad})) as pipeline:
        with pytest.raises(HapticfxError) as err:
            pipeline.impact(velocity=3.0)
    assert str(err.value).startswith(f"{path}: ") and words in str(err.value)


class _Tampers(MemoryActuator):
    """Does what numpy allows with an array that owns its memory or whose base is writable: flags it (and
    each base under it) writable again and writes full scale into it, then keeps what it was given."""
    name = "fx-test"

    def play(self, signal):
        arr = signal.samples
        while isinstance(arr, np.ndarray):
            try:
                arr.setflags(write=True)
                arr[...] = 1.0
            except ValueError:  # read-only for good
                pass
            arr = arr.base
        super().play(signal)


def test_an_actuator_cannot_write_into_what_it_was_given(tmp_path):
    """What Pipeline.impact() played and returns stays what the limiter let through."""
    path = _effect(tmp_path, "{type: fx-test, limits: {peak: 0.2, rms: 0.1}}")
    with Pipeline.from_effect(path, registry=_registry(actuators={"fx-test": _Tampers})) as pipeline:
        delivery = pipeline.impact(velocity=5.0)
    assert 0.0 < delivery.output.peak <= 0.2 + 1e-12


def test_a_head_site_cannot_write_into_another_sites_samples_or_the_engines_record(tmp_path):
    """An impact on the crown alone: the crown's actuator cannot reach the front's (silent, so unlimited)
    row of the block they were cut from, nor what on_played and played() receive."""
    _effect(tmp_path, "{type: memory}")
    scene = tmp_path / "s.yaml"
    scene.write_text("name: s\nactuators:\n  helmet: {type: fx-test, limits: {peak: 0.2, rms: 0.1}}\n"
                     "head:\n  actuator: helmet\n  sites:\n"
                     "    crown: {position: [0.0, 0.0, 0.13], channel: 0}\n"
                     "    front: {position: [0.0, 0.1126, 0.065], channel: 1}\n"
                     "effects:\n  brick: {effect: e.yaml, actuator: helmet}\n")
    seen = []
    engine = Engine(scene, registry=_registry(actuators={"fx-test": _Tampers}), on_played=seen.append)
    engine.impact("brick", 5.0, channel=0)
    engine.close()  # plays what is queued
    front = next(s.actuator for s in engine._outputs["actuators.helmet"].sites if s.channel == 1)
    assert [np.max(np.abs(s.samples)) for s in front.played] == [0.0]
    (playback,) = seen
    assert 0.0 < playback.signal.peak <= 0.2 + 1e-12 and engine.played()[0].peak == playback.signal.peak


@pytest.mark.parametrize("way", ["render", "terms", "atoms"])
def test_a_models_overlong_profile_is_one_error_naming_the_effect(tmp_path, way):
    """Refused before it is shaped, where it would grow 48 times (1 kHz to 48 kHz): rendered, as terms, or as
    the atoms shaped when the effect opens."""
    from hapticfx.interfaces import Model, Term, Terms
    from hapticfx.signal import Signal

    long = Terms(1000.0, (Term("long", 1.0, np.full(130_000, 0.01)),))  # 130 s at 1 kHz

    class Long(Model):
        name = "fx-long"

        def __init__(self, params, context):
            pass

        def render(self, impact):
            return long.profile()

        def terms(self, impact):
            return long if way == "terms" else None

        def atoms(self):
            return long if way == "atoms" else None

    path = tmp_path / "e.yaml"
    path.write_text("name: e\nobject: concrete-brick\nmodel: {type: fx-long}\nactuator: {type: memory}\n")
    pipeline = Pipeline.from_effect(path, registry=_registry(models={"fx-long": Long}))
    with pytest.raises(PluginError) as err:
        with pipeline:
            pipeline.impact(velocity=3.0)
    assert str(err.value) == (f"{path}: model: model 'fx-long' rendered a profile of 130 s (130000 samples at "
                              "1000 Hz); a profile is at most 120 s and 23040000 samples")


def _tracked(calls: list, name: str) -> type:
    """A memory actuator ``name`` that notes each open() and close() in ``calls``."""

    class Tracked(MemoryActuator):
        def open(self):
            calls.append("open")

        def close(self):
            calls.append("close")

    Tracked.name = name
    return Tracked


def test_an_actuator_whose_open_raises_is_one_error_naming_the_output_and_the_opened_are_closed(tmp_path):
    """A plugin's bug in open() (not a HapticfxError) is a DeviceError naming the scene, the output and the
    actuator; the output opened before it is closed again."""
    calls = []
    scene, err = _second_output_fails(tmp_path, _tracked(calls, "fx-tracked"))
    assert str(err) == f"{scene}: brick: actuator 'fx-test' failed to open: RuntimeError: port handle is None"
    assert calls == ["open", "close"]


def _second_output_fails(tmp_path, first: type):
    """A scene of two outputs, the first played by ``first`` (as ``fx-tracked``), the second by an actuator whose
    open() has a plugin's bug: the scene's path and the DeviceError of building its Engine."""
    from hapticfx.errors import DeviceError

    class Broken(MemoryActuator):
        name = "fx-test"

        def open(self):
            raise RuntimeError("port handle is None")

    _effect(tmp_path)
    (tmp_path / "t.yaml").write_text(f"name: t\nobject: concrete-brick\nmodel: {KE}\nactuator: {{type: fx-tracked}}\n")
    scene = tmp_path / "s.yaml"
    scene.write_text("name: s\neffects:\n  first: t.yaml\n  brick: e.yaml\n")
    with pytest.raises(DeviceError) as err:
        Engine(scene, registry=_registry(actuators={"fx-test": Broken, "fx-tracked": first}))
    return scene, err.value


def _open_with_too_long_atoms(tmp_path, actuator: type) -> PluginError:
    """Open a pipeline played by ``actuator`` (as ``fx-test``) whose model's atoms, shaped once the actuator is
    open, are refused (130 s): the error its open() raises."""
    from hapticfx.interfaces import Term, Terms
    from hapticfx.models.kinetic import KineticEnergyModel

    class LongAtoms(KineticEnergyModel):
        def atoms(self):
            return Terms(1000.0, (Term("long", 1.0, np.zeros(130_000)),))  # 130 s

    path = tmp_path / "e.yaml"
    path.write_text("name: e\nobject: concrete-brick\nmodel: {type: fx-long}\nactuator: {type: fx-test}\n")
    pipeline = Pipeline.from_effect(path, registry=_registry(models={"fx-long": LongAtoms},
                                                             actuators={"fx-test": actuator}))
    with pytest.raises(PluginError, match="a profile is at most 120 s") as err:
        pipeline.open()
    return err.value


def test_a_pipeline_that_fails_after_its_actuator_opened_closes_it_again(tmp_path):
    """The model's atoms, shaped once the actuator is open, are refused (too long): the actuator is closed."""
    calls = []
    _open_with_too_long_atoms(tmp_path, _tracked(calls, "fx-test"))
    assert calls == ["open", "close"]


def test_a_close_that_fails_after_a_failed_open_does_not_hide_why_it_failed(tmp_path):
    """The pipeline's open fails (atoms too long), then its actuator's close() raises as well: the error raised is
    still the first, with the failed close as its note."""

    class BadClose(MemoryActuator):
        name = "fx-test"

        def close(self):
            raise RuntimeError("port already gone")

    err = _open_with_too_long_atoms(tmp_path, BadClose)
    assert err.__notes__ == ["actuator 'fx-test' also failed to close: RuntimeError: port already gone"]


def test_the_cli_line_carries_a_note_of_a_failed_clean_up(monkeypatch, capsys):
    """The command's error and the note on it, one line, exit 2."""
    import typer

    import hapticfx.cli as cli
    from hapticfx.errors import DeviceError

    def failing():
        exc = DeviceError("actuator 'fx-test' failed to open: RuntimeError: port handle is None")
        exc.add_note("actuator 'fx-tracked' also failed to close: RuntimeError: port already gone")
        raise exc

    app = typer.Typer()
    app.callback()(lambda: None)  # a group, as hapticfx's own app is
    app.command("go")(failing)
    monkeypatch.setattr(cli, "build_app", lambda: app)
    with pytest.raises(SystemExit) as done:
        cli.main(["go"])
    assert done.value.code == 2
    assert capsys.readouterr().err == ("hapticfx: error: actuator 'fx-test' failed to open: RuntimeError: port handle is "
                                       "None; actuator 'fx-tracked' also failed to close: RuntimeError: port already gone\n")


def test_an_engine_whose_cleanup_fails_still_raises_why_it_could_not_open(tmp_path):
    """The second output's open() raises; closing the first raises too: the DeviceError of the open is raised."""
    class BadClose(MemoryActuator):
        name = "fx-tracked"

        def close(self):
            raise RuntimeError("port already gone")

    _, err = _second_output_fails(tmp_path, BadClose)
    assert str(err).endswith("brick: actuator 'fx-test' failed to open: RuntimeError: port handle is None")
    assert err.__notes__ == ["actuator 'fx-tracked' also failed to close: RuntimeError: port already gone"]
