"""`hapticfx.Engine`: off-thread rendering, bounded queue, errors per event, shutdown.

A test plugin (registered through the real plugin manager) adds a model whose
render can be held on a gate or made to fail, so the tests can reach the
states they describe without timing anything.
"""

from __future__ import annotations

import re
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field

import numpy as np
import pytest

from hapticfx.actuators.virtual import MemoryActuator
from hapticfx.engine import Engine
from hapticfx.errors import EffectError, HapticfxError, SignalError
from hapticfx.hookspecs import hookimpl
from hapticfx.interfaces import Impact, Model
from hapticfx.params import BuildContext
from hapticfx.registry import Registry, create_plugin_manager
from hapticfx.signal import Signal

GATE = threading.Event()
RENDER_THREADS: list[int] = []


class GatedModel(Model):
    """Renders a short burst; waits for GATE when ``gated``; fails at chosen velocities."""

    name = "test-gated"
    units = "fraction"

    @dataclass(frozen=True)
    class Params:
        gated: bool = False
        fail_at: float = field(default=-1.0)

    def __init__(self, params, context: BuildContext):
        self.params = params

    def render(self, impact: Impact) -> Signal:
        RENDER_THREADS.append(threading.get_ident())
        if self.params.gated and not GATE.wait(10):
            raise RuntimeError("gate never opened")
        if impact.velocity == self.params.fail_at:
            raise ValueError("a bug inside a model")
        if impact.velocity == self.params.fail_at + 1:
            raise SignalError("a user-facing model error")
        return Signal(np.sin(np.linspace(0, 20, 200)) * min(impact.velocity / 5, 1.0), 1000.0)


class TimedMemory(MemoryActuator):
    """A memory actuator that asks for each impact's time of receipt, as the sound card's queue does."""

    name = "test-timed"
    takes_received = True

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.receipts: list[float] = []

    def play(self, signal: Signal, *, received: float) -> None:
        self.receipts.append(received)
        super().play(signal)


class TestPlugin:
    @hookimpl
    def register_models(self, register):
        register("test-gated", GatedModel)

    @hookimpl
    def register_actuators(self, register):
        register("test-timed", TimedMemory)


@pytest.fixture
def registry():
    pm, infos = create_plugin_manager(entry_points=False)
    pm.register(TestPlugin(), name="test-plugin")
    GATE.clear()
    RENDER_THREADS.clear()
    yield Registry(pm, infos)
    GATE.set()


def scene(tmp_path, *, model="{type: test-gated}", queue=16, limits="", extra="", frame_model=None):
    path = tmp_path / "scene.yaml"
    def inline(n, o, m=model):
        return f"{{name: {n}, object: {o}, model: {m}, actuator: {{type: memory}}}}"

    path.write_text(f"""
name: t
actuators:
  helmet: {{type: memory, rate_hz: 2000{limits}}}
effects:
  brick: {{actuator: helmet, channel: 0, inline: {inline('brick', 'concrete-brick')}}}
  plate: {{actuator: helmet, channel: 0, inline: {inline('plate', 'steel-plate')}}}
  frame: {{inline: {inline('frame', 'plastic-frame', frame_model or model)}}}
engine: {{queue_size: {queue}, close_timeout_s: 5}}
{extra}""")
    return path


def test_impact_returns_while_the_worker_renders_on_another_thread(tmp_path, registry):
    playbacks = []
    engine = Engine(scene(tmp_path, model="{type: test-gated, gated: true}"), registry=registry,
                    on_played=playbacks.append)
    assert engine.impact("brick", 3.0, at=12.5) is True  # the render is held: a synchronous call would block here
    assert engine.stats()["rendered"] == 0
    GATE.set()
    stats = engine.close()
    assert stats["rendered"] == 1 and stats["pending"] == 0
    assert RENDER_THREADS and threading.get_ident() not in RENDER_THREADS
    played = engine.played()[0]
    assert played.at == 12.5 and played.object == "brick" and played.velocity == 3.0
    assert played.output == "actuators.helmet" and played.peak == pytest.approx(playbacks[0].signal.peak)
    assert not hasattr(played, "signal")  # the history keeps no samples
    assert playbacks[0].signal.rate_hz == 2000 and playbacks[0].summary() == played
    assert playbacks[0].delivery.impact.object == "concrete-brick"  # the effect's object, not the scene key
    assert playbacks[0].delivery.impact.at == 12.5  # the sender's time rides on the impact the model renders


def test_point_and_normal_ride_on_the_impact_and_bad_ones_are_refused(tmp_path, registry):
    playbacks = []
    engine = Engine(scene(tmp_path), registry=registry, on_played=playbacks.append)
    assert engine.impact("brick", 3.0, at=1.0, point=(0.0, 0.05, 0.12), normal=(0, 0, 2))
    # a point 1e160 m away overflowed the spatialiser's norms and played on two sites whatever its direction;
    # ("1", "2", "3") and (True, False, True) were taken for numbers
    for bad in ({"point": (0, 1)}, {"point": (0, float("nan"), 1)}, {"normal": (0, 0, 0)}, {"normal": "up"},
                {"point": (-1e160, 0, 0)}, {"point": (0, 11.0, 0)}, {"point": ("1", "2", "3")},
                {"point": (True, False, True)}):
        with pytest.raises(SignalError):
            engine.impact("brick", 3.0, **bad)
    engine.close()
    impact = playbacks[0].delivery.impact
    assert impact.point == (0.0, 0.05, 0.12) and impact.normal == (0.0, 0.0, 1.0) and impact.at == 1.0
    assert engine.played()[0].point == (0.0, 0.05, 0.12) and engine.played()[0].normal == (0.0, 0.0, 1.0)


def test_full_queue_drops_without_blocking_and_counts(tmp_path, registry):
    engine = Engine(scene(tmp_path, model="{type: test-gated, gated: true}", queue=3), registry=registry)
    results = [engine.impact("brick", 3.0) for _ in range(20)]
    # one impact is in the worker (held by the gate) or still queued; at most 4 accepted
    assert results[:3] == [True, True, True] and results.count(True) <= 4
    GATE.set()
    stats = engine.close()
    assert stats["submitted"] == 20
    assert stats["queued"] == results.count(True) and stats["dropped_queue_full"] == results.count(False)
    assert stats["rendered"] == stats["queued"]


def test_an_error_in_one_event_never_stops_the_engine(tmp_path, registry):
    engine = Engine(scene(tmp_path, model="{type: test-gated, fail_at: 4.0}"), registry=registry)
    for v in (3.0, 4.0, 3.5, 5.0, 3.2, 4.0):
        assert engine.impact("brick", v)
    stats = engine.close()
    assert stats["rendered"] == 3 and stats["failed"] == 3
    assert stats["errors"] == {"ValueError": 2, "SignalError": 1}
    assert [p.velocity for p in engine.played()] == [3.0, 3.5, 3.2]


def test_bad_calls_raise_at_once(tmp_path, registry):
    engine = Engine(scene(tmp_path), registry=registry)
    with pytest.raises(EffectError, match="unknown object 'anvil'"):
        engine.impact("anvil", 3.0)
    for v in (-1.0, float("nan"), "fast"):
        with pytest.raises(SignalError):
            engine.impact("brick", v)
    with pytest.raises(SignalError):
        engine.impact("brick", 3.0, at=float("inf"))
    with pytest.raises(SignalError, match="at must be <= 1000000000000.0"):  # past any clock: a file's frames overflow
        engine.impact("brick", 3.0, at=1e305)
    with pytest.raises(EffectError, match=r"unknown object \[1\]"):  # not a TypeError (unhashable)
        engine.impact([1], 3.0)
    with pytest.raises(SignalError, match="point must be three numbers"):  # not an OverflowError
        engine.impact("brick", 3.0, point=[10**400, 0, 0])
    for channel in (True, [0], 0.0):
        with pytest.raises(SignalError, match="channel must be a whole number"):
            engine.impact("brick", 3.0, channel=channel)
    with pytest.raises(EffectError, match="plays on channel 0, not 3"):
        engine.impact("brick", 3.0, channel=3)
    assert engine.impact("brick", 3.0, channel=0)
    engine.close()
    with pytest.raises(HapticfxError, match="closed"):
        engine.impact("brick", 3.0)
    assert engine.close()["rendered"] == 1  # closing twice is harmless


def test_many_threads_share_one_engine(tmp_path, registry):
    engine = Engine(scene(tmp_path, queue=100_000), registry=registry)
    results = []

    def hammer(k):
        results.extend(engine.impact(("brick", "plate", "frame")[(k + i) % 3], 2.0 + (i % 30) / 10) for i in range(300))

    threads = [threading.Thread(target=hammer, args=(k,)) for k in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    stats = engine.close(timeout=600)  # every queued impact is played, however long a loaded machine takes
    assert stats["submitted"] == 2400 == stats["queued"] == stats["rendered"] and all(results)
    shared = engine._outputs["actuators.helmet"].actuator
    own = engine._outputs["frame"].actuator
    assert shared.received == 1600 and own.received == 800
    # the memory output keeps the newest 16 MiB: 800 x 9600 float64 samples are 59 MiB
    assert own.released > 0 and len(own.played) + own.released == 800
    assert sum(s.samples.nbytes for s in own.played) <= 16 * 2**20


def test_shared_actuator_runs_its_own_limiter_over_all_its_effects(tmp_path, registry):
    engine = Engine(scene(tmp_path, queue=100, limits=", limits: {peak: 0.3, rms: 0.2}"), registry=registry)
    out = engine._outputs["actuators.helmet"]
    assert out.limiter is not None and engine._outputs["frame"].limiter is None
    for i in range(40):
        engine.impact("brick" if i % 2 else "plate", 5.0)
    engine.close()
    played = out.actuator.played
    assert len(played) == 40
    assert max(s.peak for s in played) <= 0.3 + 1e-12


def test_close_without_drain_cancels_what_is_queued(tmp_path, registry):
    engine = Engine(scene(tmp_path, model="{type: test-gated, gated: true}"), registry=registry)
    for _ in range(6):
        assert engine.impact("brick", 3.0)
    opener = threading.Timer(0.2, GATE.set)
    opener.start()
    stats = engine.close(drain=False)
    opener.join()  # a late timer must not open the gate during the next test
    assert stats["queued"] == 6 == stats["rendered"] + stats["cancelled"] + stats["failed"]
    assert stats["cancelled"] >= 5 and stats["pending"] == 0


def test_close_gives_up_on_a_stuck_render_after_its_timeout(tmp_path, registry):
    engine = Engine(scene(tmp_path, model="{type: test-gated, gated: true}"), registry=registry)
    for _ in range(3):
        engine.impact("brick", 3.0)
    stats = engine.close(timeout=0.3)  # the gate stays shut: the worker is stuck in render
    assert stats["cancelled"] == 2 and stats["rendered"] == 0
    GATE.set()


def test_wav_output_is_written_when_the_engine_closes(tmp_path, registry):
    from hapticfx.actuators.files import read_wav

    path = scene(tmp_path)
    with Engine(path, device=f"wav:{tmp_path / 'out.wav'}", registry=registry) as engine:
        engine.impact("brick", 3.0)
        engine.impact("frame", 3.0)
    # two outputs (the shared helmet and the frame's own): one file each
    files = sorted(p.name for p in tmp_path.glob("out-*.wav"))
    assert files == ["out-actuators_helmet.wav", "out-frame.wav"]
    rate, data = read_wav(tmp_path / "out-frame.wav")  # the frame's own memory actuator: 48 kHz
    lead = data.size - 9600  # the files line up: the frame's impact came a moment after the session's first
    assert rate == 48000 and 0 <= lead and not data[0, :lead].any() and np.isfinite(data).all()
    rate, data = read_wav(tmp_path / "out-actuators_helmet.wav")
    assert rate == 2000 and data.size == 400


def test_a_stand_in_file_the_user_wrote_or_a_directory_is_refused_when_the_engine_opens(tmp_path, registry):
    from hapticfx.actuators.files import read_wav, write_wav
    from hapticfx.errors import DeviceError

    path = scene(tmp_path)
    mine, folder = tmp_path / "mine-frame.wav", tmp_path / "dir-frame.wav"
    mine.write_text("precious")
    folder.mkdir()
    with pytest.raises(DeviceError, match=r"mine-frame.wav: exists and was not written by hapticfx; use --force "
                                          r"\(in Python: overwrite=True\)"):
        Engine(path, device=f"wav:{tmp_path / 'mine.wav'}", registry=registry)
    assert mine.read_text() == "precious"
    with pytest.raises(DeviceError, match="dir-frame.wav: is a directory, expected a file name"):
        Engine(path, device=f"wav:{tmp_path / 'dir.wav'}", registry=registry, overwrite=True)
    with Engine(path, device=f"wav:{tmp_path / 'mine.wav'}", registry=registry, overwrite=True) as engine:
        engine.impact("frame", 3.0)
    write_wav(mine, np.zeros(10), 48000)  # hapticfx's own: replaced without overwrite
    with Engine(path, device=f"wav:{tmp_path / 'mine.wav'}", registry=registry) as engine:
        engine.impact("frame", 3.0)
    assert read_wav(mine)[1].size > 10


def test_a_failing_actuator_open_closes_the_ones_already_opened(tmp_path, registry):
    from hapticfx.errors import DeviceError

    path = scene(tmp_path)
    with pytest.raises(DeviceError, match="does not exist"):
        Engine(path, device=f"wav:{tmp_path / 'missing-dir' / 'out.wav'}", registry=registry)


def test_hapticfx_Engine_is_exposed_lazily():
    code = (
        "import sys, hapticfx\n"
        "assert 'hapticfx.engine' not in sys.modules\n"
        "from hapticfx.engine import Engine\n"
        "assert hapticfx.Engine is Engine\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_raising_on_played_callback_is_counted_apart(tmp_path, registry):
    seen = []

    def callback(played):
        seen.append(played.object)
        raise KeyError("the caller's bug")

    engine = Engine(scene(tmp_path), on_played=callback, registry=registry)
    for _ in range(3):
        engine.impact("frame", 3.0)
    stats = engine.close()
    assert seen == ["frame"] * 3
    assert stats["rendered"] == 3 and stats["failed"] == 0 and stats["callback_errors"] == 3


def _wait_for(condition, timeout=10.0):
    """Poll ``condition`` until true (a state to reach, not a speed to meet); fails after ``timeout``."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "condition not reached"
        time.sleep(0.01)


def test_a_held_output_never_delays_another(tmp_path, registry):
    # The shared helmet's effects are held in render; the frame has an output (and worker) of its own.
    path = scene(tmp_path, model="{type: test-gated, gated: true}", frame_model="{type: test-gated}")
    engine = Engine(path, registry=registry)
    for _ in range(3):
        assert engine.impact("brick", 3.0)
    for _ in range(5):
        assert engine.impact("frame", 3.0)
    _wait_for(lambda: engine.stats()["outputs"]["frame"]["rendered"] == 5)
    stats = engine.stats()
    assert stats["outputs"]["actuators.helmet"]["rendered"] == 0  # still held
    assert stats["outputs"]["actuators.helmet"]["pending"] == 3
    GATE.set()
    stats = engine.close()
    assert stats["rendered"] == 8 and stats["pending"] == 0


def test_an_actuator_that_takes_the_time_of_receipt_gets_each_impacts(tmp_path, registry):
    path = scene(tmp_path)
    path.write_text(path.read_text().replace("helmet: {type: memory", "helmet: {type: test-timed"))
    engine = Engine(path, registry=registry)
    before = time.perf_counter()
    for v in (2.0, 3.0, 4.0):
        assert engine.impact("brick", v)
    engine.close()
    helmet = engine._outputs["actuators.helmet"].actuator
    assert isinstance(helmet, TimedMemory) and helmet.received == 3
    assert helmet.receipts == [p.received for p in engine.played() if p.output == "actuators.helmet"]
    assert before <= helmet.receipts[0] <= helmet.receipts[-1] <= time.perf_counter()


def test_channel_0_is_the_default_channel_of_an_entry_without_one(tmp_path, registry):
    engine = Engine(scene(tmp_path), registry=registry)
    assert engine.impact("frame", 3.0, channel=0)  # the scene sets no channel: the actuator's first
    with pytest.raises(EffectError, match="plays on channel 0, not 1"):
        engine.impact("frame", 3.0, channel=1)
    assert engine.close()["rendered"] == 1


def test_failures_are_logged_at_a_limited_rate_and_counted_by_reason(tmp_path, registry, caplog):
    engine = Engine(scene(tmp_path, model="{type: test-gated, fail_at: 4.0}", queue=500), registry=registry)
    with caplog.at_level("WARNING", logger="hapticfx.engine"):
        for _ in range(200):
            engine.impact("frame", 5.0)  # SignalError: a user-facing model error
        for _ in range(100):
            engine.impact("frame", 4.0)  # ValueError: a bug
        stats = engine.close()
    assert stats["failed"] == 300 and stats["errors"] == {"SignalError": 200, "ValueError": 100}
    assert stats["outputs"]["frame"]["errors"] == {"SignalError": 200, "ValueError": 100}
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 4, lines  # per kind: the first at once, the rest in one line at close
    assert sum("user-facing" in line for line in lines) == 2 and "199 more like it" in lines[-2] + lines[-1]
    tracebacks = [r for r in caplog.records if r.exc_info]
    assert len(tracebacks) == 1 and "a bug" in tracebacks[0].getMessage()


def test_close_cancels_what_is_queued_for_a_failing_device(tmp_path, registry):
    import time

    from hapticfx.errors import DeviceError

    engine = Engine(scene(tmp_path), registry=registry)
    out = engine._outputs["frame"]
    calls = []

    def failing_play(signal):  # stands in for a board that stopped answering (no hardware here)
        calls.append(1)
        if len(calls) > 1:
            time.sleep(0.3)  # its reply timeout
        raise DeviceError("no answer within 0.3 s")

    out.actuator.play = failing_play
    for _ in range(10):
        engine.impact("frame", 3.0)
    _wait_for(lambda: engine.stats()["outputs"]["frame"]["failed"] >= 1)
    stats = engine.close()
    frame = stats["outputs"]["frame"]
    assert frame["failing"].startswith("no answer")
    # not waited on: what was still queued is cancelled, not tried one timeout after another
    assert frame["cancelled"] >= 7 and frame["failed"] + frame["cancelled"] == 10 and frame["pending"] == 0


def test_a_head_whose_sites_share_one_file_is_refused(tmp_path):
    """Each site of a head on a WAV actuator wrote the whole file on close, so only one site's impacts (here, of
    the site not struck: silence) were left in it."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"""name: file-head
actuators:
  helmet: {{type: wav, path: {tmp_path / 'out.wav'}, rate_hz: 8000}}
head:
  actuator: helmet
  sites: {{crown: {{position: [0, 0, 0.13], channel: 0}}, back: {{position: [0, -0.1, 0.05], channel: 1}}}}
effects:
  plate: {{actuator: helmet, inline: {{name: e, object: steel-plate, model: {{type: kinetic-energy}},
           actuator: {{type: vibro-transducer}}}}}}
""")
    with pytest.raises(EffectError, match=r"head\.sites: the head's sites 'crown' and 'back' play into one output"):
        Engine(scene)
    assert not (tmp_path / "out.wav").exists()


@pytest.mark.parametrize("kwargs, said", [
    ({"queue_size": 1e12}, "queue_size must be a whole number in [1, 1,000,000]"),  # filled 235 MiB in 3 s
    ({"queue_size": 2.5}, "queue_size must be a whole number"),  # quietly 2
    ({"keep_last": 1e18}, "keep_last must be a whole number in [0, 1,000,000]"),
    ({"on_played": 5}, "on_played must be callable"),  # every impact then failed in its callback
    ({"device": True}, "device must be a name, an index or a stand-in"),  # was sound-card index 1
    ({"overwrite": "no"}, "overwrite must be True or False"),  # was true
])
def test_engine_arguments_that_would_misbehave_are_refused(tmp_path, registry, kwargs, said):
    with pytest.raises(HapticfxError, match=re.escape(said)):
        Engine(scene(tmp_path), registry=registry, **kwargs)


@pytest.mark.parametrize("given", [None, 123, b"scene.yaml", ["scene.yaml"]])
def test_a_scene_that_is_neither_a_path_nor_a_scene_is_an_effect_error(given):
    with pytest.raises(EffectError, match="expected a scene file's path or a Scene, got"):
        Engine(given)
