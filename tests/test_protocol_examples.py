"""Every example of docs/protocol.md, sent to a running `hapticfx serve` of the scene it names."""

from __future__ import annotations

import json
import re
import shlex
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "protocol.md"


def examples() -> list[tuple[str, list[str], str]]:
    """(language, the `hapticfx serve` command, the block's body) for each example block that names a scene."""
    out = []
    for lang, body in re.findall(r"```(sh|python)\n(.*?)```", DOC.read_text(), flags=re.S):
        first = body.splitlines()[0].lstrip("# ").strip()
        if first.startswith("hapticfx serve "):
            out.append((lang, shlex.split(first), body))
    return out


def serve(command: list[str], tmp_path: Path) -> tuple[subprocess.Popen, int]:
    args = [a.replace("out/", f"{tmp_path}/") for a in command[1:]]
    proc = subprocess.Popen([sys.executable, "-m", "hapticfx", *args, "--port", "0"], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert line.startswith("listening on 127.0.0.1:"), line + proc.stderr.read()
    return proc, int(line.split()[2].rsplit(":", 1)[1])


def test_the_page_has_examples_for_every_kind_of_message():
    found = examples()
    assert len(found) >= 3 and {lang for lang, _, _ in found} == {"sh", "python"}
    text = " ".join(body for _, _, body in found)
    assert "sfidfff" in text and "OscBundleBuilder" in text


@pytest.mark.parametrize("lang, command, body", examples(), ids=[f"{lang}-{i}" for i, (lang, _, _) in enumerate(examples())])
def test_protocol_example_runs_against_its_scene(lang, command, body, tmp_path):
    if lang == "sh" and shutil.which("oscsend") is None:
        pytest.skip("oscsend (Debian liblo-tools) is not installed")
    proc, port = serve(command, tmp_path)
    try:
        if lang == "sh":
            sends = [shlex.split(line.replace("localhost 9000", f"127.0.0.1 {port}"))
                     for line in body.splitlines() if line.startswith("oscsend ")]
            for argv in sends:
                subprocess.run(argv, check=True, timeout=30)
        else:
            subprocess.run([sys.executable, "-c", body.replace("9000", str(port))], check=True, timeout=60)
    finally:
        import time

        time.sleep(0.5)  # let the last datagram arrive before the server is told to stop
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    final = json.loads(out.strip().splitlines()[-1])
    bridge, engine = final["bridge"], final["engine"]
    assert bridge["dropped_total"] == 0, bridge["dropped"]
    expected = len(sends) if lang == "sh" else body.count('"/hapticfx/impact"') if "Bundle" not in body else 2
    assert bridge["accepted"] == expected and engine["rendered"] == expected and engine["failed"] == 0
    for arg in command:
        if arg.startswith("wav:"):
            assert (tmp_path / Path(arg[4:]).name).stat().st_size > 44
