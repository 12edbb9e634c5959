"""The command line end to end, in subprocesses, as a user runs it."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hapticfx.actuators.files import read_wav

from hfx_testdata import fake_distribution

REPO = Path(__file__).resolve().parents[1]
KE = "name: brick-ke\nobject: concrete-brick\nvelocity_mps: 3.8\nmodel: {type: kinetic-energy}\nactuator: {type: %s}\n"


def hfx(*args, cwd=None, env=None):
    return subprocess.run([sys.executable, "-m", "hapticfx", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env={**os.environ, **(env or {})})


def test_play_to_wav_writes_non_silent_file_at_actuator_rate(tmp_path, write_effect):
    effect = write_effect(KE % "memory")
    out = tmp_path / "brick.wav"
    r = hfx("play", effect, "--device", f"wav:{out}")
    assert r.returncode == 0, r.stderr
    rate, data = read_wav(out)
    assert rate == 48000 and data.shape[0] == 1
    assert np.max(np.abs(data)) > 0.05
    assert f"WAV file {out}" in r.stdout


@pytest.mark.parametrize("suffix", [".wav", ".csv", ".png"])
def test_render_formats(tmp_path, write_effect, suffix):
    out = tmp_path / f"r{suffix}"
    r = hfx("render", write_effect(KE % "memory"), "--out", out, "--velocity", "2.5")
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 100
    if suffix == ".csv":
        header, first = out.read_text().splitlines()[:2]
        assert header == "t_s,profile_fraction" and first == "0,0"
    if suffix == ".png":
        assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_render_unknown_suffix(tmp_path, write_effect):
    r = hfx("render", write_effect(KE % "memory"), "--out", tmp_path / "x.mp3")
    assert r.returncode == 2
    assert "unknown output type '.mp3'; use .wav, .csv or .png" in r.stderr
    assert not (tmp_path / "x.mp3").exists()


def test_nan_velocity_on_the_command_line(write_effect):
    r = hfx("play", write_effect(KE % "memory"), "--velocity", "nan", "--device", "memory")
    assert r.returncode == 2 and r.stderr.strip() == "hapticfx: error: velocity must be finite, got nan"


def test_wav_into_missing_directory_leaves_nothing(tmp_path, write_effect):
    r = hfx("play", write_effect(KE % "memory"), "--device", f"wav:{tmp_path}/no/such/dir/x.wav")
    assert r.returncode == 2 and "does not exist" in r.stderr
    assert list(tmp_path.iterdir()) == [tmp_path / "effect.yaml"]


def plugin_whose_open_raises(tmp_path, name: str, imports: str, raises: str) -> dict:
    """The environment of an installed (entry-point) actuator plugin ``name`` whose open() runs ``raises``."""
    site = tmp_path / "site"
    site.mkdir()
    fake_distribution(site, dist=f"hfx-{name}", version="0.1", entry_point=name, module=f"hfx_{name}", source=f'''
        from hapticfx.hookspecs import hookimpl
        from hapticfx.actuators.virtual import MemoryActuator
        {imports}

        class Failing(MemoryActuator):
            """An actuator whose open() fails."""
            name = "{name}"
            def open(self):
                {raises}

        @hookimpl
        def register_actuators(register):
            register("{name}", Failing)
    ''')
    return {"PYTHONPATH": f"{site}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "HAPTICFX_PLUGINS": name}


@pytest.fixture
def deviceless_plugin(tmp_path):
    """An installed actuator plugin whose device is absent: open() raises DeviceError.

    A stand-in for a sound card on a machine without one; the real sound-card plugin's own
    behaviour with no device is tested in plugins/hapticfx-soundcard.
    """
    return plugin_whose_open_raises(tmp_path, "absent", "from hapticfx.errors import DeviceUnavailable",
                                    'raise DeviceUnavailable("no audio output device found")')


def test_play_without_device_writes_wav_and_png(tmp_path, write_effect, deviceless_plugin):
    effect = write_effect(KE % "absent")
    r = hfx("play", effect, cwd=tmp_path, env=deviceless_plugin)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("no output device (no audio output device found); wrote the impact to "
                               "hapticfx-brick-ke-3.80mps.wav and hapticfx-brick-ke-3.80mps.png instead")
    assert "--device wav:PATH" in lines[0]
    rate, data = read_wav(tmp_path / "hapticfx-brick-ke-3.80mps.wav")
    assert rate == 48000 and np.max(np.abs(data)) > 0.05
    assert (tmp_path / "hapticfx-brick-ke-3.80mps.png").stat().st_size > 1000


@pytest.mark.parametrize("name", ["x/../../../escaped", "a\\0b", "two\\nlines", "n" * 300])
def test_headless_play_keeps_the_effects_name_from_making_its_file_names(tmp_path, write_effect, deviceless_plugin,
                                                                          name):
    """The name goes into the default file names: a '/' must not lead out of the folder, a NUL byte, a newline or
    300 characters must not break the write or the one line it prints."""
    effect = write_effect(f'name: "{name}"\nobject: concrete-brick\nvelocity_mps: 3.8\nmodel: {{type: kinetic-energy}}\n'
                          "actuator: {type: absent}\n")
    here = tmp_path / "a" / "b" / "c"
    here.mkdir(parents=True)
    r = hfx("play", effect, cwd=here, env=deviceless_plugin)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert len(r.stdout.strip().splitlines()) == 1, r.stdout
    written = sorted(p.name for p in here.iterdir())
    assert [Path(n).suffix for n in written] == [".png", ".wav"] and all(len(n) < 100 for n in written), written
    assert all(n in r.stdout for n in written)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "effect.yaml", "site"]


def test_headless_play_writes_both_files_or_neither(tmp_path, write_effect, deviceless_plugin):
    """The PNG fails after the WAV is written: a folder where it goes, or a full disk (simulated: the picture's
    write raises ENOSPC, as a full disk does). No WAV is left, the one already there is as it was, and the
    error names the file."""
    from hapticfx.actuators.files import write_wav

    effect = write_effect(KE % "absent")
    wav, png = tmp_path / "hapticfx-brick-ke-3.80mps.wav", tmp_path / "hapticfx-brick-ke-3.80mps.png"
    png.mkdir()
    r = hfx("play", effect, "--force", cwd=tmp_path, env=deviceless_plugin)
    assert (r.returncode, r.stderr) == (2, f"hapticfx: error: {png.name}: is a directory, expected a file name\n")
    assert not wav.exists()
    png.rmdir()
    write_wav(wav, np.full(100, 0.5), 48000)  # an earlier run's, say
    before = wav.read_bytes()
    full = ("import errno, sys; from matplotlib.figure import Figure\n"
            "def savefig(*a, **k): raise OSError(errno.ENOSPC, 'No space left on device')\n"
            "Figure.savefig = savefig\nfrom hapticfx.cli import main; main(sys.argv[1:])")
    r = subprocess.run([sys.executable, "-c", full, "play", str(effect)], capture_output=True, text=True, cwd=tmp_path,
                       env={**os.environ, **deviceless_plugin})
    assert (r.returncode, r.stderr) == (2, f"hapticfx: error: {png.name}: No space left on device\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([wav.name, "effect.yaml", "site"])
    assert wav.read_bytes() == before


def test_play_with_explicit_absent_device_is_an_error(write_effect, deviceless_plugin):
    r = hfx("play", write_effect(KE % "absent"), "--device", "3", env=deviceless_plugin)
    assert r.returncode == 2 and r.stderr.strip() == "hapticfx: error: no audio output device found"


def test_an_actuator_whose_open_raises_is_one_line_from_serve_and_play(tmp_path):
    """A plugin's bug in open() (not a HapticfxError), in an Engine (serve) or a pipeline (play): one line
    naming the file, the output and the actuator, exit 2, no traceback."""
    env = plugin_whose_open_raises(tmp_path, "broken", "", 'raise RuntimeError("port handle is None")')
    effect = tmp_path / "e.yaml"
    effect.write_text(KE % "broken")
    scene = tmp_path / "s.yaml"
    scene.write_text("name: s\neffects:\n  brick: e.yaml\n")
    for args, where in ((("serve", scene, "--port", "0", "--duration", "0.1"), f"{scene}: brick"),
                        (("play", effect), f"{effect}: actuator")):
        r = hfx(*args, env=env)
        assert (r.returncode, r.stderr) == (2, f"hapticfx: error: {where}: actuator 'broken' failed to open: "
                                               "RuntimeError: port handle is None\n"), args


def test_plugins_lists_builtins():
    r = hfx("plugins")
    assert r.returncode == 0
    rows = [line.split() for line in r.stdout.splitlines()]
    assert rows[0] == ["kind", "name", "plugin", "distribution", "version"]
    assert ["model", "kinetic-energy", "hapticfx.builtins.core", "hapticfx"] == rows[[r[1] for r in rows].index("kinetic-energy")][:4]


def test_info_says_what_it_loads_readable_or_as_json(write_effect):
    path = write_effect(KE % "memory")
    r = hfx("info", path)
    assert r.returncode == 0, r.stderr
    assert "model:\n  model: kinetic-energy" in r.stdout and "  rate hz: 48000" in r.stdout
    info = json.loads(hfx("info", path, "--json").stdout)
    assert info["model"]["model"] == "kinetic-energy" and info["actuator"]["rate_hz"] == 48000.0


def test_help_explains_devices():
    r = hfx("play", "--help")
    assert r.returncode == 0 and "wav:PATH" in r.stdout and "headless" in r.stdout


def test_usage_error_is_clean_exit_2():
    r = hfx("play", "--bogus")
    assert r.returncode == 2 and "No such option: --bogus" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.parametrize("args, line", [
    (("bench", "interpolators", "--protocol", "nope"),
     "hapticfx: error: --protocol: unknown protocol 'nope'; one of: lovo, looo, paper, generalisation"),
    (("bench", "safety", "--only", "nope"), "hapticfx: error: --only: unknown case(s): nope; --list shows them"),
])
def test_a_bench_option_out_of_its_list_is_one_error_line_before_any_work(args, line):
    r = hfx(*args)
    assert r.returncode == 2 and r.stderr.strip() == line and r.stdout == ""


@pytest.mark.parametrize("args", [
    ["bench", "isolation", "--interval-ms", "nan", "-n", "4", "--repeats", "1"],
    ["bench", "serve", "--interval-ms", "nan", "--impacts", "10"],
    ["bench", "fuzz", "effect", "--inputs", "1", "--time-limit", "nan"],
    ["bench", "flood", "scenes/earthquake_room.yaml", "--device", "memory", "--seconds", "nan"],
    ["bench", "flood", "scenes/earthquake_room.yaml", "--device", "memory", "--rate", "inf"],
    ["bench", "texture", "--fill", "nan"],
    ["export", "effects/falling_brick.yaml", "-f", "ahap", "-o", "x.ahap", "--tolerance", "nan"],
])
def test_a_number_option_with_a_range_refuses_nan_and_infinity(tmp_path, args):
    option, value = next((a, b) for a, b in zip(args, args[1:]) if b in ("nan", "inf"))
    args = [str(REPO / a) if a.endswith(".yaml") else a for a in args]
    r = subprocess.run([sys.executable, "-m", "hapticfx", *args], capture_output=True, text=True, cwd=tmp_path,
                       timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert f"Invalid value for '{option}': {value} is not a finite number." in r.stderr
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_while_the_command_starts_is_one_line_not_a_traceback():
    """A Ctrl-C before the command line interface is imported: a KeyboardInterrupt raised when typer is
    looked up stands in for a signal at that instant (a real one cannot be timed to it). The command's
    entry point is the one pyproject.toml installs."""
    import tomllib

    scripts = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["hapticfx"] == "hapticfx.launch:main"
    stand_in = ("import sys\n"
                "class CtrlC:\n"
                "    def find_spec(self, name, path=None, target=None):\n"
                "        if name == 'typer':\n"
                "            raise KeyboardInterrupt\n"
                "sys.meta_path.insert(0, CtrlC())\n"
                "from hapticfx.launch import main\n"
                "main()\n")
    r = subprocess.run([sys.executable, "-c", stand_in, "--help"], capture_output=True, text=True, timeout=60)
    assert (r.returncode, r.stderr, r.stdout) == (130, "aborted\n", "")


def test_version_names_hapticfx_and_its_plugins():
    r = hfx("--version")
    assert r.returncode == 0 and r.stdout.startswith("hapticfx 0.1.0") and "hapticfx-soundcard" in r.stdout


def test_help_lists_the_common_commands_first_and_completion_works():
    import os
    import subprocess
    import sys

    listed = [line.split()[0] for line in hfx("--help").stdout.split("Commands:")[1].splitlines()
              if line.strip() and not line.startswith("   ")]  # a summary's wrapped lines are indented further
    assert listed[:5] == ["play", "render", "validate", "info", "serve"]
    done = subprocess.run([sys.executable, "-m", "hapticfx"], capture_output=True, text=True, env={
        **os.environ, "COMP_WORDS": "hapticfx pl", "COMP_CWORD": "1", "_HAPTICFX_COMPLETE": "complete_bash"})
    assert done.stdout.split() == ["play", "plugins"]


def test_a_start_builds_only_the_command_it_runs(monkeypatch):
    """`hapticfx play ...` converts `play` alone to click; the root's help, an unknown name and completion keep
    every command (their lists and suggestions need them)."""
    import typer

    from hapticfx.cli import build_app, narrowed

    monkeypatch.delenv("_HAPTICFX_COMPLETE", raising=False)

    def names(argv):
        return sorted(typer.main.get_command(narrowed(build_app(), argv)).commands)

    every = names([])
    assert {"play", "bench", "data", "train", "devices"} <= set(every)
    assert names(["--debug", "play", "x.yaml", "--device", "memory"]) == ["play"]
    assert names(["bench", "render", "--repeats", "3"]) == ["bench"]
    assert names(["--help"]) == names(["plya"]) == every
    typo = hfx("plya")
    assert typo.returncode == 2 and "No such command 'plya'. Did you mean 'play'?" in typo.stderr
    monkeypatch.setenv("_HAPTICFX_COMPLETE", "complete_bash")
    assert names(["play"]) == every


def test_a_velocity_outside_the_recorded_range_is_warned_about(tmp_path):
    effect = REPO / "effects" / "falling_brick.yaml"
    outside = hfx("render", effect, "--velocity", "9", "--out", tmp_path / "a.png")
    inside = hfx("render", effect, "--velocity", "4", "--out", tmp_path / "b.png")
    assert outside.returncode == inside.returncode == 0
    assert outside.stderr.startswith("hapticfx: warning: 9 m/s is outside the recorded 2.42-5.24 m/s of concrete-brick")
    assert inside.stderr == ""


def test_an_object_the_effect_does_not_describe_is_an_error(tmp_path):
    r = hfx("render", REPO / "effects" / "falling_brick_kinetic.yaml", "--object", "banana", "--out", tmp_path / "a.png")
    assert r.returncode == 2 and "object 'banana' is neither the effect's object (concrete-brick)" in r.stderr
    assert not (tmp_path / "a.png").exists()


def test_the_python_wave_module_reads_what_render_writes(tmp_path):
    import wave

    r = hfx("render", REPO / "effects" / "falling_brick.yaml", "--out", tmp_path / "brick.wav")
    assert r.returncode == 0, r.stderr
    with wave.open(str(tmp_path / "brick.wav")) as w:
        assert (w.getframerate(), w.getsampwidth(), w.getnchannels()) == (48000, 3, 1) and w.getnframes() == 24000


def test_validate_checks_scenes_and_studies_as_serve_and_study_run_load_them(tmp_path):
    files = [REPO / "scenes" / "earthquake_room.yaml", REPO / "studies" / "paper_study2.yaml",
             REPO / "effects" / "falling_brick.yaml"]
    r = hfx("validate", *files)
    assert r.returncode == 0, r.stderr
    assert [line.split(" (")[1].split()[0] for line in r.stdout.splitlines()] == ["scene", "study", "effect"]
    listed = json.loads(hfx("validate", *files, "--json").stdout)
    assert [(x["kind"], x["ok"]) for x in listed] == [("scene", True), ("study", True), ("effect", True)]
    # an object that names its actuator as a list: one line, exit 2, from validate and from serve alike
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"name: x\nactuators:\n  helmet: {{type: memory}}\neffects:\n"
                     f"  concrete-brick: {{effect: {REPO / 'effects' / 'falling_brick.yaml'}, actuator: [helmet]}}\n")
    for args in (("validate", scene), ("serve", scene, "--port", "0")):
        r = hfx(*args)
        assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
        assert r.stderr.strip().splitlines() == [
            f"hapticfx: error: {scene}: effects.concrete-brick.actuator: unknown actuator ['helmet']; "
            "the scene's actuators: helmet"]
    bad = json.loads(hfx("validate", scene, "--json").stdout)
    assert bad[0]["ok"] is False and "unknown actuator ['helmet']" in bad[0]["error"]


def test_validate_parses_each_file_once(monkeypatch):
    """`validate` parsed every YAML file twice: once to tell a scene, study or effect apart, once to load it."""
    from collections import Counter

    from typer.testing import CliRunner

    import hapticfx.effect
    import hapticfx.scene
    import hapticfx.study.spec
    from hapticfx.cli import build_app

    parsed, read_yaml = Counter(), hapticfx.effect.read_yaml

    def counted(path):
        parsed[Path(path).resolve()] += 1
        return read_yaml(path)

    for module in (hapticfx.effect, hapticfx.scene, hapticfx.study.spec):
        monkeypatch.setattr(module, "read_yaml", counted)
    files = [REPO / "scenes" / "earthquake_room.yaml", REPO / "studies" / "paper_study2.yaml",
             REPO / "effects" / "falling_steel_plate_convbilstm.yaml"]  # none names another of the three
    result = CliRunner().invoke(build_app(), ["validate", *map(str, files)])
    assert result.exit_code == 0, result.output
    assert [parsed[f.resolve()] for f in files] == [1, 1, 1]


def test_render_replaces_the_csv_it_wrote_and_not_another(tmp_path, write_effect):
    effect, out = write_effect(KE % "memory"), tmp_path / "t.csv"
    for _ in range(2):
        r = hfx("render", effect, "--out", out)
        assert r.returncode == 0, r.stderr
    mine = tmp_path / "mine.csv"
    mine.write_text("a,b\n1,2\n")
    r = hfx("render", effect, "--out", mine)
    assert r.returncode == 2 and "exists and was not written by hapticfx; use --force" in r.stderr
    assert mine.read_text() == "a,b\n1,2\n"


def test_a_write_that_fails_names_the_output_not_its_hidden_temporary(tmp_path, write_effect):
    (tmp_path / "afile").write_text("x")
    r = hfx("render", write_effect(KE % "memory"), "-o", tmp_path / "afile" / "x.csv")
    assert r.returncode == 2 and r.stderr == f"hapticfx: error: {tmp_path / 'afile' / 'x.csv'}: Not a directory\n"


def test_schema_replaces_the_schema_it_wrote_and_not_another_file(tmp_path):
    out = tmp_path / "effect.schema.json"
    for _ in range(2):
        r = hfx("schema", "--out", out)
        assert r.returncode == 0, r.stderr
    mine = tmp_path / "user.json"
    mine.write_text('{"precious": true}\n')
    r = hfx("schema", "-o", mine)
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert "user.json: exists and was not written by hapticfx; use --force" in r.stderr
    assert mine.read_text() == '{"precious": true}\n'
    r = hfx("schema", "-o", mine, "--force")
    assert r.returncode == 0 and mine.read_text() == out.read_text()


def test_plugins_and_study_check_print_json():
    listed = json.loads(hfx("plugins", "--json").stdout)
    assert {"kind": "model", "name": "kinetic-energy", "plugin": "hapticfx.builtins.core", "distribution": "hapticfx"}.items() \
        <= next(x for x in listed if x["name"] == "kinetic-energy").items()
    check = json.loads(hfx("study", "check", REPO / "studies" / "paper_study2.yaml", "--json", "--trials").stdout)
    assert check["study"] == "paper-study-2-matching-similarity" and len(check["tasks"]) == 6
    assert sum(t["trials"] + t["practice"] for t in check["tasks"]) == len(check["schedule"])


def _every_command():
    """``(name, click command)`` of every command and group below ``hapticfx``, with the plugins' commands."""
    import typer

    from hapticfx.cli import build_app

    def walk(command, path):
        for name, sub in getattr(command, "commands", {}).items():
            yield " ".join([*path, name]), sub
            yield from walk(sub, [*path, name])

    return list(walk(typer.main.get_command(build_app()), []))


def test_command_lists_show_whole_phrases_not_cut_ones():
    """Click cut each command's summary at a fixed width ('Check effect files (or haptic files: .haptic,
    .ahap,...'); the lists show the first sentence up to its first colon or semicolon instead."""
    from hapticfx.cli import summary

    listed = dict(_every_command())
    assert {"validate", "bench", "bench fuzz", "data pick", "study check"} <= set(listed)
    for name, command in listed.items():
        text = command.get_short_help_str(limit=45)
        assert text.endswith(".") and not text.endswith("..."), (name, text)
    assert summary("Fuzz the input gates: every mutant (a, b: c) must be refused.\n\nMore.") == "Fuzz the input gates."
    assert summary("Check files (or haptic files: .ahap, ...), scenes; then more") == "Check files (or haptic files: .ahap, ...), scenes."


# Labels typer makes from a parameter's Python type: a user cannot tell what to type from them.
MACHINE_LABEL = re.compile(r"<[^<>]*>|list\[|Path\]|\b(INTEGER|FLOAT|TEXT)( RANGE)?\b")


def test_every_option_label_says_what_to_type():
    """Every option of every command (``bench ...``, ``data ...``, ``study ...`` and the plugins' included) shows a
    label in words (COUNT, M/S, SECONDS, DIR, 0-1...), not typer's ``<int range>`` or ``<list[Path]>``."""
    from typer.testing import CliRunner

    from hapticfx.cli import build_app

    app = build_app()
    commands = _every_command()
    assert {"play", "bench formats", "data synth", "study run", "train"} <= {name for name, _ in commands}
    labelled = 0
    for name, command in [("", None), *commands]:
        text = CliRunner().invoke(app, [*name.split(), "--help"], terminal_width=200).output
        usage, _, listing = text.partition("Options:")
        assert "Usage:" in usage, (name, text)
        labels = [line.strip().split("  ")[0] for line in listing.splitlines() if line.startswith("  -")]
        for label in labels + [line for line in usage.splitlines() if line.startswith("Usage:")]:
            assert not MACHINE_LABEL.search(label), f"hapticfx {name} --help: {label!r}"
        labelled += sum(" " in label.split(", ")[-1] for label in labels)
    assert labelled > 100  # the walk reached the options that take a value


def test_ctrl_c_while_the_command_line_starts_is_one_word_not_a_traceback(monkeypatch, capsys):
    """Before click runs the command (the plugins being registered), Ctrl-C is a KeyboardInterrupt, not Abort."""
    import hapticfx.cli as cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_app", interrupted)
    with pytest.raises(SystemExit) as exit_:
        cli.main(["plugins"])
    assert exit_.value.code == 130 and capsys.readouterr().err.strip() == "aborted"
