"""Every hook has a test here (test_hook_<name>); a hook without one fails the suite."""

from __future__ import annotations

import inspect
import sys
from pathlib import Path

import pytest

from hapticfx import hookspecs
from hapticfx.errors import PluginError
from hapticfx.registry import Registry, create_plugin_manager, get_registry, reset_registry
from hfx_testdata import actuator_plugin, fake_distribution


def hook_names():
    return sorted(n for n, f in vars(hookspecs).items() if callable(f) and hasattr(f, "hapticfx_spec"))


def test_every_hook_has_a_test():
    tests = {name for name in globals() if name.startswith("test_hook_")}
    missing = [h for h in hook_names() if f"test_hook_{h}" not in tests]
    assert not missing, f"hooks without a test: {missing}"


def test_every_hook_is_documented_in_the_plugin_guide():
    from pathlib import Path

    guide = (Path(__file__).resolve().parents[1] / "docs" / "plugin-guide.md").read_text()
    missing = [h for h in hook_names() if f"`{h}" not in guide]
    assert not missing, f"hooks missing from docs/plugin-guide.md: {missing}"


def test_every_hook_has_a_docstring():
    for name in hook_names():
        assert (getattr(hookspecs, name).__doc__ or "").strip(), name


def test_no_pending_hook_implementations():
    pm, _ = create_plugin_manager()
    pm.check_pending()


class _Plugin:
    """A plugin object registering one component of each kind."""

    def __init__(self, suffix=""):
        self.suffix = suffix

    @hookspecs.hookimpl
    def register_reducers(self, register):
        from hapticfx.interfaces import Reducer

        class First(Reducer):
            name = "first-axis"

            def reduce(self, xyz):
                return xyz[..., 0]

        register("first-axis" + self.suffix, First)

    @hookspecs.hookimpl
    def register_interpolators(self, register):
        register("nearest" + self.suffix, "not callable")

    @hookspecs.hookimpl
    def register_models(self, register):
        register("kinetic-energy" + self.suffix, lambda params, context: None)

    @hookspecs.hookimpl
    def register_actuators(self, register):
        from hapticfx.actuators.virtual import MemoryActuator

        register("memory2" + self.suffix, MemoryActuator)


def _registry_with(plugin, name="test-plugin"):
    pm, infos = create_plugin_manager(entry_points=False)
    pm.register(plugin, name=name)
    return Registry(pm, infos)


def test_hook_register_reducers():
    class P:
        @hookspecs.hookimpl
        def register_reducers(self, register):
            _Plugin().register_reducers(register)

    reg = _registry_with(P())
    assert "first-axis" in reg.names("reducer")
    import numpy as np

    assert reg.create("reducer", "first-axis").reduce(np.ones((4, 3))).shape == (4,)
    assert reg.get("reducer", "first-axis").plugin == "test-plugin"


def test_hook_register_interpolators():
    class P:
        @hookspecs.hookimpl
        def register_interpolators(self, register):
            _Plugin().register_interpolators(register)

    with pytest.raises(PluginError, match="'test-plugin' registered interpolator 'nearest' with a factory that is not callable"):
        _registry_with(P())

    class Q:
        @hookspecs.hookimpl
        def register_interpolators(self, register):
            from hapticfx.interpolators.linear import LinearInterpolator

            register("linear-copy", LinearInterpolator)

    assert "linear-copy" in _registry_with(Q()).names("interpolator")


def test_hook_register_models():
    class P:
        @hookspecs.hookimpl
        def register_models(self, register):
            _Plugin().register_models(register)

    with pytest.raises(PluginError) as err:
        _registry_with(P())
    assert str(err.value) == (
        "model 'kinetic-energy' is registered twice: by plugin 'hapticfx.builtins.core' (hapticfx) "
        "and by plugin 'test-plugin' (registered at run time)"
    )


def test_hook_register_actuators():
    class P:
        @hookspecs.hookimpl
        def register_actuators(self, register):
            _Plugin().register_actuators(register)

    reg = _registry_with(P())
    assert "memory2" in reg.names("actuator")
    with pytest.raises(PluginError, match="unknown actuator 'nope'; installed: .*memory2"):
        reg.get("actuator", "nope")


def test_hook_register_formats(tmp_path):
    import numpy as np

    from hapticfx.formats import Decoded, Format
    from hapticfx.signal import Signal

    class Raw(Format):
        name, suffixes, holds = "raw", (".raw",), frozenset({"waveform"})

        def write(self, path, signal, options):
            path.write_bytes(signal.samples.astype("<f8").tobytes())

        def read(self, path, device, *, rate_hz):
            return Decoded(Signal(np.frombuffer(path.read_bytes(), "<f8"), rate_hz))

    class P:
        @hookspecs.hookimpl
        def register_formats(self, register):
            register("raw", Raw)

    reg = _registry_with(P())
    assert {"haptic", "ahap", "android", "hjif", "raw"} <= set(reg.names("format"))
    from hapticfx.formats import format_for

    assert format_for(tmp_path / "x.RAW", reg).name == "raw" and format_for(tmp_path / "x.haptic", reg).name == "haptic"

    class Q:
        @hookspecs.hookimpl
        def register_formats(self, register):
            register("haptic", Raw)

    with pytest.raises(PluginError, match="format 'haptic' is registered twice"):
        _registry_with(Q())


def test_hook_register_commands():
    import typer
    from typer.testing import CliRunner

    class P:
        @hookspecs.hookimpl
        def register_commands(self, bench):
            @bench.command("hello")
            def hello():
                """Say hello."""
                typer.echo("hello from a plugin")

    pm, _ = create_plugin_manager(entry_points=False)
    pm.register(P(), name="cmd-plugin")
    app, bench, data = typer.Typer(), typer.Typer(), typer.Typer()
    app.add_typer(bench, name="bench")

    @app.callback()
    def root():
        """root"""

    pm.hook.register_commands(app=app, bench=bench, data=data)
    result = CliRunner().invoke(app, ["bench", "hello"])
    assert result.exit_code == 0 and "hello from a plugin" in result.output


def test_builtins_go_through_the_plugin_manager():
    reg = get_registry()
    assert reg.get("model", "kinetic-energy").plugin == "hapticfx.builtins.core"
    assert reg.get("actuator", "wav").distribution == "hapticfx"
    assert "hapticfx.builtins.core" in [name for name, _ in reg.pm.list_name_plugin()]


@pytest.fixture
def third_party(tmp_path, monkeypatch):
    """A real distribution on sys.path: a .dist-info with an entry point in group `hapticfx`."""
    fake_distribution(tmp_path, dist="hfx-thirdparty", version="1.2.3", entry_point="buzz", module="hfx_thirdparty",
                      source=actuator_plugin("Buzz", "buzz"))
    monkeypatch.syspath_prepend(str(tmp_path))
    yield
    sys.modules.pop("hfx_thirdparty", None)


def test_third_party_plugin_from_entry_point_metadata(third_party, monkeypatch):
    monkeypatch.delenv("HAPTICFX_PLUGINS", raising=False)
    reset_registry()
    reg = get_registry()
    r = reg.get("actuator", "buzz")
    assert (r.plugin, r.distribution, r.version) == ("buzz", "hfx-thirdparty", "1.2.3")


def test_allow_list_env_var(third_party, monkeypatch):
    monkeypatch.setenv("HAPTICFX_PLUGINS", "")
    reset_registry()
    assert "buzz" not in get_registry().names("actuator")
    assert "wav" in get_registry().names("actuator")  # built-ins always load
    monkeypatch.setenv("HAPTICFX_PLUGINS", "buzz")
    reset_registry()
    assert "buzz" in get_registry().names("actuator")


def test_broken_plugin_names_itself(tmp_path, monkeypatch):
    fake_distribution(tmp_path, dist="hfx-broken", version="0.1", entry_point="broken", module="hfx_broken",
                      source="raise RuntimeError('boom')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("HAPTICFX_PLUGINS", "broken")
    with pytest.raises(PluginError, match=r"plugin 'broken' \(hfx_broken\) failed to load: boom"):
        create_plugin_manager()


def test_hookspecs_are_grouped_and_typed():
    for name in hook_names():
        sig = inspect.signature(getattr(hookspecs, name))
        assert all(p.annotation is not inspect.Parameter.empty for p in sig.parameters.values()), name


def test_first_party_names_are_what_their_distributions_register():
    from hapticfx.registry import FIRST_PARTY, get_registry

    registered = {(r.kind, r.name): r.distribution for r in get_registry() if r.distribution != "hapticfx"}
    assert {k: v for k, v in registered.items() if v in set(FIRST_PARTY.values())} == FIRST_PARTY


def test_a_missing_plugin_names_the_distribution_to_install(tmp_path):
    import os
    import subprocess
    import sys

    effect = tmp_path / "e.yaml"
    # the solenoid: the core knows the sound-card actuators' specs (tests/test_core_only.py), not the solenoid's
    effect.write_text("name: e\nobject: concrete-brick\nmodel: {type: kinetic-energy}\nactuator: {type: solenoid}\n")
    r = subprocess.run([sys.executable, "-m", "hapticfx", "render", str(effect), "--out", str(tmp_path / "x.wav")],
                       capture_output=True, text=True, env={**os.environ, "HAPTICFX_PLUGINS": ""})
    # the command that works: the plugins are installed from the source tree, they are not on PyPI
    root = Path(__file__).resolve().parents[1]
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1, r.stderr
    assert f"it comes with hapticfx-solenoid: pip install {root / 'plugins' / 'hapticfx-solenoid'};" in r.stderr


def test_outside_a_source_tree_the_hint_says_where_the_plugin_is(monkeypatch, tmp_path):
    from hapticfx import registry

    monkeypatch.setattr(registry, "__file__", str(tmp_path / "site-packages" / "hapticfx" / "registry.py"))
    assert registry.install_hint("hapticfx-solenoid") == ("pip install ./plugins/hapticfx-solenoid in hapticfx's "
                                                          "source tree (it is not on PyPI)")


@pytest.mark.parametrize("model, used, plugin", [
    ("{type: data-driven, interpolator: fx-half}", {"fx-half"}, "hapticfx.builtins.core"),
    ("{type: contact, reducer: fx-norm, table: false}", {"fx-norm"}, "hapticfx.builtins.physics"),
    ("{type: fx-kinetic}", set(), "test-plugin"),
])
def test_a_pipeline_builds_from_the_registry_it_is_given(tmp_path, model, used, plugin):
    """An interpolator, a reducer or a model that only the given registry holds is found and used, and
    describe() names the model's plugin from it."""
    import numpy as np

    from hapticfx.interfaces import Interpolator, Reducer
    from hapticfx.models.kinetic import KineticEnergyModel
    from hapticfx.pipeline import Pipeline

    calls = set()

    class Half(Interpolator):
        name = "fx-half"

        def interpolate(self, lower, upper, velocity):
            calls.add(self.name)
            return 0.5 * (lower.samples + upper.samples)

    class Norm(Reducer):
        name = "fx-norm"

        def reduce(self, xyz):
            calls.add(self.name)
            return np.linalg.norm(xyz, axis=-1)

    class P:
        @hookspecs.hookimpl
        def register_interpolators(self, register):
            register("fx-half", Half)

        @hookspecs.hookimpl
        def register_reducers(self, register):
            register("fx-norm", Norm)

        @hookspecs.hookimpl
        def register_models(self, register):
            register("fx-kinetic", KineticEnergyModel)

    path = tmp_path / "e.yaml"
    path.write_text(f"name: e\nobject: concrete-brick\nmodel: {model}\nactuator: {{type: memory}}\n")
    with Pipeline.from_effect(path, registry=_registry_with(P())) as pipeline:
        pipeline.impact(velocity=3.3)  # between two recorded velocities
        info = pipeline.describe()
    assert calls == used and info["model"]["plugin"].startswith(f"{plugin} (")
