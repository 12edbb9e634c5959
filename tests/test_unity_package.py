"""examples/unity/ as Unity would take it: the package's layout, its C# compiled with Mono's mcs against a
stand-in for the UnityEngine types it uses (tests/unity/UnityEngine.cs; Unity itself cannot run here), and
a console program that sends what the package sends to a running `hapticfx serve`."""

from __future__ import annotations

import json
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "examples" / "unity"
STANDIN = ROOT / "tests" / "unity"
MCS, MONO = shutil.which("mcs"), shutil.which("mono")

needs_mono = pytest.mark.skipif(MCS is None or MONO is None,
                                reason="Mono's mcs is not installed (scripts/install.sh --test installs mono-mcs)")


def test_the_package_is_laid_out_as_unity_loads_it():
    meta = json.loads((PACKAGE / "package.json").read_text())
    assert re.fullmatch(r"[a-z0-9-]+(\.[a-z0-9-]+){2,}", meta["name"]) and meta["unity"] == "2019.4"
    asmdefs = list((PACKAGE / "Runtime").glob("*.asmdef"))
    assert [json.loads(a.read_text())["name"] for a in asmdefs] == ["Hapticfx.Runtime"]
    for cs in (PACKAGE / "Runtime").glob("*.cs"):  # Unity attaches a MonoBehaviour whose class names its file
        classes = re.findall(r"public (?:static )?class (\w+)", cs.read_text())
        assert classes == [cs.stem], (cs.name, classes)
    readme = (PACKAGE / "README.md").read_text()
    for step in ("Add package from disk", "HapticfxOscClient", "HapticfxObject", "package.json"):
        assert step in readme


def _build(tmp: Path, *defines: str) -> Path:
    def mcs(*args):
        out = subprocess.run([MCS, "-warnaserror+", *args], capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stdout + out.stderr

    mcs("-target:library", f"-out:{tmp / 'UnityEngine.dll'}", str(STANDIN / "UnityEngine.cs"))
    mcs("-target:library", f"-r:{tmp / 'UnityEngine.dll'}", f"-out:{tmp / 'Hapticfx.Runtime.dll'}",
        *(f"-define:{d}" for d in defines), *map(str, sorted((PACKAGE / "Runtime").glob("*.cs"))))
    mcs(f"-r:{tmp / 'UnityEngine.dll'}", f"-r:{tmp / 'Hapticfx.Runtime.dll'}", f"-out:{tmp / 'SendImpacts.exe'}",
        str(STANDIN / "SendImpacts.cs"))
    return tmp / "SendImpacts.exe"


@pytest.mark.engines
@needs_mono
def test_it_compiles_for_unity_2020_2_and_later_too(tmp_path):
    _build(tmp_path, "UNITY_2020_2_OR_NEWER")  # Time.fixedTimeAsDouble instead of 2019.4's float fixedTime


@pytest.mark.engines
@needs_mono
def test_what_unity_sends_is_what_hapticfx_serve_plays(tmp_path):
    exe = _build(tmp_path)
    log = tmp_path / "impacts.jsonl"
    serve = subprocess.Popen([sys.executable, "-m", "hapticfx", "serve", str(ROOT / "scenes" / "earthquake_room.yaml"),
                              "--port", "0", "--device", "memory", "--log", str(log)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = serve.stdout.readline()
        assert line.startswith("listening on 127.0.0.1:"), line + serve.stderr.read()
        port = line.split()[2].rsplit(":", 1)[1]
        sent = subprocess.run([MONO, str(exe), port], capture_output=True, text=True, timeout=60)
        assert sent.returncode == 0 and "sent 3" in sent.stdout, sent.stdout + sent.stderr
        time.sleep(0.5)
    finally:
        serve.send_signal(signal.SIGTERM)
        out, err = serve.communicate(timeout=60)
    assert serve.returncode == 0, err
    bridge = json.loads(out.strip().splitlines()[-1])["bridge"]
    assert bridge["accepted"] == 3 and bridge["dropped_total"] == 0
    played = {p["object"]: p for p in map(json.loads, log.read_text().splitlines())}
    brick, plate, beam = played["concrete-brick"], played["steel-plate"], played["wood-beam"]
    assert brick["velocity"] == pytest.approx(3.8, abs=1e-6) and brick["at"] == 1.25 and brick["point"] is None
    assert plate["at"] == 2.5 and plate["point"] == pytest.approx([0.01, 0.02, 0.13], abs=1e-7)
    assert plate["normal"] == [0.0, 0.0, 1.0]
    # the component: 3.5 m/s down along a normal tilted 36.9 degrees from vertical -> 2.8 m/s along it; the
    # head faces world +x, so the world +x side of the contact is its front (+y in the head frame)
    assert beam["velocity"] == pytest.approx(2.8, abs=1e-5) and beam["at"] == 3.75
    assert beam["point"] == pytest.approx([0.0, 0.078, 0.104], abs=1e-6)
    assert beam["normal"] == pytest.approx([0.0, 0.6, 0.8], abs=1e-6)
