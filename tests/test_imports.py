"""A scene that needs no neural model or hardware never imports torch, sounddevice or serial."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

HEAVY = ("torch", "sounddevice", "serial")


def _modules_after(code: str) -> set[str]:
    probe = textwrap.dedent(code) + textwrap.dedent("""
        import json, sys
        print(json.dumps(sorted(sys.modules)))
    """)
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return set(json.loads(r.stdout.strip().splitlines()[-1]))


def test_import_list_plugins_and_play_kinetic_energy(tmp_path):
    effect = tmp_path / "ke.yaml"
    effect.write_text("name: ke\nobject: concrete-brick\nmodel: {type: kinetic-energy}\n"
                      "actuator: {type: vibro-transducer}\n")
    mods = _modules_after(f"""
        import hapticfx
        from hapticfx.registry import get_registry
        from hapticfx.cli import build_app
        reg = get_registry(); list(reg); build_app()
        from hapticfx.pipeline import Pipeline
        with Pipeline.from_effect({str(effect)!r}, device="wav:{tmp_path / 'o.wav'}") as p:
            p.impact(velocity=3.0)
    """)
    loaded = [m for m in HEAVY if m in mods]
    assert not loaded, f"imported {loaded}"


def test_play_linear_data_driven_does_not_import_torch(tmp_path, tiny_dataset):
    effect = tmp_path / "dd.yaml"
    effect.write_text(f"name: dd\nobject: concrete-brick\nmodel: {{type: data-driven, dataset: {tiny_dataset}, "
                      "interpolator: linear}\nactuator: {type: memory}\n")
    mods = _modules_after(f"""
        from hapticfx.pipeline import Pipeline
        with Pipeline.from_effect({str(effect)!r}) as p:
            p.impact(velocity=3.3)
    """)
    assert not [m for m in HEAVY if m in mods]


def test_playing_the_shipped_data_driven_effects_imports_no_torch(tmp_path):
    """The main command's effect (ensemble-warp, served from its table) and the paper's ConvBiLSTM's (from its
    velocity table)."""
    from pathlib import Path

    effects = Path(__file__).resolve().parents[1] / "effects"
    for name in ("falling_brick.yaml", "falling_brick_convbilstm.yaml"):
        mods = _modules_after(f"""
            from hapticfx.cli import main
            try:
                main(["play", {str(effects / name)!r}, "--device", "wav:{tmp_path / 'o.wav'}"])
            except SystemExit as exc:
                assert exc.code == 0, exc.code
        """)
        assert not [m for m in HEAVY if m in mods], name
        assert "numpy.ma" not in mods, name  # 9 ms of a start; np.unique imports it


def test_a_contact_effect_served_from_its_shipped_table_loads_no_ode_solver(tmp_path):
    """scipy.integrate and scipy.signal (about 1 s of a start) are what a table is built with, not read with."""
    from pathlib import Path

    effect = Path(__file__).resolve().parents[1] / "effects" / "families" / "tapping.yaml"
    mods = _modules_after(f"""
        from hapticfx.pipeline import Pipeline
        with Pipeline.from_effect({str(effect)!r}, device="memory") as p:
            p.impact(velocity=0.3)
            assert p.model.describe()["served_from"] != "a table built at first use"
    """)
    assert not [m for m in ("scipy.integrate", "scipy.signal") if m in mods]


STUDY_HEAVY = ("pandas", "statsmodels", "selenium", "matplotlib")


def test_study_dependencies_stay_out_of_import_cli_and_play(tmp_path):
    """The `study` commands are registered on every start: their analysis and browser libraries load only when used."""
    effect = tmp_path / "ke.yaml"
    effect.write_text("name: ke\nobject: concrete-brick\nmodel: {type: kinetic-energy}\nactuator: {type: memory}\n")
    mods = _modules_after(f"""
        import hapticfx
        from hapticfx.registry import get_registry
        from hapticfx.cli import build_app
        import typer
        list(get_registry())
        typer.main.get_command(build_app())
        from hapticfx.pipeline import Pipeline
        with Pipeline.from_effect({str(effect)!r}) as p:
            p.impact(velocity=3.0)
    """)
    assert "hapticfx.study.commands" in mods  # the probe did reach the study plugin
    loaded = [m for m in STUDY_HEAVY if m in mods]
    assert not loaded, f"imported {loaded}"
