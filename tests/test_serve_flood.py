"""`hapticfx serve` as a real subprocess: 10,000 random and malformed datagrams, then valid impacts.

Targets 127.0.0.1 only. The output is a real WAV actuator, read back after shutdown.
"""

from __future__ import annotations

import json
import math
import random
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
from pythonosc.osc_message_builder import OscMessageBuilder
from hapticfx.actuators.files import read_wav

SCENE = """
name: flood
actuators:
  helmet: {{type: wav, path: {wav}, rate_hz: 8000}}
effects:
  concrete-brick:
    actuator: helmet
    inline: {{name: brick, object: concrete-brick, model: {{type: kinetic-energy}}, actuator: {{type: vibro-transducer}}}}
events:
  osc: {{host: 127.0.0.1, port: 0, max_datagram: 1024, rate_hz: {rate}, burst: {burst}}}
"""


def osc(address, *args) -> bytes:
    b = OscMessageBuilder(address)
    for a in args:
        b.add_arg(*a) if isinstance(a, tuple) else b.add_arg(a)
    return b.build().dgram


def malformed(rng: random.Random) -> list[tuple[str, bytes]]:
    """10,000 datagrams, each with the one drop reason it must get (known by construction)."""
    valid = osc("/hapticfx/impact", "concrete-brick", (3.8, "f"))
    makers = {
        "not_osc": [
            lambda: bytes([rng.choice([b for b in range(256) if b not in (0x2F, 0x23)])])
            + rng.randbytes(rng.randrange(0, 1000)),                        # random bytes, not '/' or '#'
            lambda: valid[: rng.choice([n for n in range(1, len(valid)) if n % 4])],   # cut mid-word
            lambda: valid[:-4],                                              # float argument missing
            lambda: valid + bytes(4),                                        # trailing bytes
            lambda: b"/" + rng.randbytes(rng.randrange(0, 40)).replace(b"\x00", b"\x01"),  # no terminator
        ],
        "oversize": [lambda: rng.randbytes(rng.randrange(1025, 8000))],
        "bundle": [lambda: _bundle(rng)],
        "wrong_address": [lambda: osc("/" + "".join(rng.choices("abcxyz/", k=rng.randrange(1, 30))), "concrete-brick", (3.8, "f"))],
        "wrong_types": [
            lambda: osc("/hapticfx/impact", "concrete-brick"),
            lambda: osc("/hapticfx/impact", (3.8, "f"), "concrete-brick"),
            lambda: osc("/hapticfx/impact", "concrete-brick", "fast"),
            lambda: osc("/hapticfx/impact", "concrete-brick", (3.8, "f"), (True, "T")),
        ],
        "bad_value": [
            lambda: osc("/hapticfx/impact", "concrete-brick", (-rng.uniform(0.1, 9), "f")),
            lambda: osc("/hapticfx/impact", "concrete-brick", (math.nan, "d")),
            lambda: osc("/hapticfx/impact", "concrete-brick", (math.inf, "f")),
            lambda: osc("/hapticfx/impact", "concrete-brick", (3.8, "f"), (-5, "i")),
        ],
        "unknown_object": [lambda: osc("/hapticfx/impact", "".join(rng.choices("qwerty-", k=rng.randrange(1, 60))), (3.8, "f"))],
    }
    out = []
    for _ in range(10_000):
        reason = rng.choice(list(makers))
        out.append((reason, rng.choice(makers[reason])()))
    return out


def _bundle(rng: random.Random) -> bytes:
    """A bundle that holds no message: empty, or its one element's size runs past its end."""
    b = OscBundleBuilder(IMMEDIATELY)
    b.add_content(OscMessageBuilder("/hapticfx/impact").build())
    whole = b.build().dgram
    return whole[:16] if rng.random() < 0.5 else whole[:-4]


class Server:
    """`python -m hapticfx serve` in a subprocess, printing its counters every 0.1 s."""

    def __init__(self, tmp: Path, *, rate=0, burst=500):
        self.wav = tmp / "helmet.wav"
        scene = tmp / "scene.yaml"
        scene.write_text(SCENE.format(wav=self.wav, rate=rate, burst=burst))
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "hapticfx", "serve", str(scene), "--stats-every", "0.1"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )
        line = self.proc.stdout.readline()
        assert line.startswith("listening on 127.0.0.1:"), line + self.proc.stderr.read()
        self.port = int(line.split()[2].rsplit(":", 1)[1])
        self.last = None

    def wait_received(self, n: int, timeout: float = 20) -> dict:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.last = json.loads(self.proc.stdout.readline())
            b = self.last["bridge"]
            if b["received"] + (b["kernel_dropped"] or 0) >= n and self.last["engine"]["pending"] == 0:
                return self.last
        raise AssertionError(f"server saw {self.last} after {timeout} s")

    def stop(self) -> dict:
        self.proc.send_signal(signal.SIGTERM)
        out, err = self.proc.communicate(timeout=20)
        assert self.proc.returncode == 0, err
        return json.loads(out.strip().splitlines()[-1])


def test_flood_of_malformed_datagrams_then_a_valid_impact_is_rendered(tmp_path):
    rng = random.Random(20260521)
    datagrams = malformed(rng)
    server = Server(tmp_path)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
            for i, (_, data) in enumerate(datagrams):
                client.sendto(data, ("127.0.0.1", server.port))
                if i % 250 == 249:
                    # wait until the bridge has read everything sent so far: the kernel's buffer holds at most
                    # 250 datagrams at a time, however slowly a loaded machine runs the bridge's thread
                    server.wait_received(i + 1)
            server.wait_received(len(datagrams))
            client.sendto(osc("/hapticfx/impact", "concrete-brick", (3.8, "f")), ("127.0.0.1", server.port))
            server.wait_received(len(datagrams) + 1)
        final = server.stop()
    finally:
        if server.proc.poll() is None:
            server.proc.kill()
    bridge, engine = final["bridge"], final["engine"]
    assert bridge["kernel_dropped"] == 0, "the OS dropped datagrams: counts below would not be exact"
    assert bridge["received"] == len(datagrams) + 1
    assert bridge["received"] == bridge["accepted"] + bridge["dropped_total"]
    expected = {}
    for reason, _ in datagrams:
        expected[reason] = expected.get(reason, 0) + 1
    assert {k: v for k, v in bridge["dropped"].items() if v} == expected
    assert bridge["accepted"] == 1
    assert engine["rendered"] == 1 and engine["failed"] == 0
    rate, samples = read_wav(server.wav)
    samples = samples[0]
    assert rate == 8000 and samples.size > 0 and np.all(np.isfinite(samples))
    assert 0 < np.max(np.abs(samples)) <= 1.0


def test_rate_limited_flood_is_counted_and_serving_resumes(tmp_path):
    server = Server(tmp_path, rate=200, burst=50)
    valid = osc("/hapticfx/impact", "concrete-brick", (3.0, "f"))
    n = 3000
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
            for i in range(n):
                client.sendto(valid, ("127.0.0.1", server.port))
                if i % 500 == 499:
                    time.sleep(0.003)
            server.wait_received(n)
            time.sleep(0.3)  # the bucket refills
            client.sendto(valid, ("127.0.0.1", server.port))
            server.wait_received(n + 1)
        final = server.stop()
    finally:
        if server.proc.poll() is None:
            server.proc.kill()
    bridge, engine = final["bridge"], final["engine"]
    assert bridge["received"] + bridge["kernel_dropped"] == n + 1
    assert bridge["received"] == bridge["accepted"] + bridge["dropped_total"]
    assert bridge["dropped"]["rate_limited"] > n // 2
    # accepted impacts were queued or dropped by a full queue, then all rendered
    assert bridge["accepted"] == engine["queued"] == engine["rendered"]
    assert engine["rendered"] >= 2  # some of the burst, and the one after the bucket refilled


@pytest.mark.skipif(shutil.which("oscsend") is None, reason="oscsend (Debian liblo-tools) is not installed")
def test_oscsend_from_liblo_is_understood(tmp_path):
    server = Server(tmp_path)
    try:
        for args in (["sf", "concrete-brick", "3.8"], ["sfi", "concrete-brick", "4.2", "-1"],
                     ["sfid", "concrete-brick", "2.9", "-1", "12.25"], ["s", "concrete-brick"]):
            subprocess.run(["oscsend", "127.0.0.1", str(server.port), "/hapticfx/impact", *args], check=True)
        server.wait_received(4)
        final = server.stop()
    finally:
        if server.proc.poll() is None:
            server.proc.kill()
    bridge = final["bridge"]
    assert bridge["accepted"] == 3 and bridge["dropped"]["wrong_types"] == 1
    assert final["engine"]["rendered"] == 3


def test_serve_errors_are_one_line_and_exit_2(tmp_path):
    missing = subprocess.run([sys.executable, "-m", "hapticfx", "serve", str(tmp_path / "nope.yaml")],
                             capture_output=True, text=True, timeout=60)
    assert missing.returncode == 2 and missing.stderr.strip().count("\n") == 0
    assert "nope.yaml: file not found" in missing.stderr
    (tmp_path / "ok.yaml").write_text(SCENE.format(wav=tmp_path / "o.wav", rate=0, burst=1))
    no_dir = subprocess.run([sys.executable, "-m", "hapticfx", "serve", str(tmp_path / "ok.yaml"), "--log",
                             str(tmp_path / "absent" / "log.jsonl")], capture_output=True, text=True, timeout=60)
    assert no_dir.returncode == 2 and "--log" in no_dir.stderr and "does not exist" in no_dir.stderr
    assert "Traceback" not in no_dir.stderr
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        (tmp_path / "s.yaml").write_text(SCENE.format(wav=tmp_path / "o.wav", rate=0, burst=1))
        busy = subprocess.run([sys.executable, "-m", "hapticfx", "serve", str(tmp_path / "s.yaml"), "--port", str(port)],
                              capture_output=True, text=True, timeout=60)
    assert busy.returncode == 2 and f"cannot listen for OSC on 127.0.0.1:{port}" in busy.stderr
    assert "Traceback" not in busy.stderr



@pytest.mark.parametrize("args, said", [
    (["--duration", "1", "--stats-every", "nan"], "Invalid value for '--stats-every': nan is not a finite number"),
    (["--duration", "nan"], "Invalid value for '--duration': nan is not a finite number"),
    (["--duration", "inf"], "Invalid value for '--duration': inf is not a finite number"),
    (["--duration", "0"], "Invalid value for '--duration': 0.0 is not in the range"),
])
def test_serve_refuses_a_duration_or_stats_period_that_is_not_a_finite_positive_number(tmp_path, args, said):
    (tmp_path / "s.yaml").write_text(SCENE.format(wav=tmp_path / "o.wav", rate=0, burst=1))
    r = subprocess.run([sys.executable, "-m", "hapticfx", "serve", str(tmp_path / "s.yaml"), "--device", "memory",
                        "--port", "0", *args], capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and said in r.stderr and "listening on" not in r.stdout, (r.stdout, r.stderr)


def test_serve_checks_at_start_that_its_file_output_can_be_made(tmp_path):
    (tmp_path / "a-file").write_text("not a folder")
    wav = tmp_path / "a-file" / "o.wav"
    (tmp_path / "s.yaml").write_text(SCENE.format(wav=tmp_path / "o.wav", rate=0, burst=1))
    r = subprocess.run([sys.executable, "-m", "hapticfx", "serve", str(tmp_path / "s.yaml"), "--device", f"wav:{wav}",
                        "--port", "0", "--duration", "1"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 2 and "listening on" not in r.stdout, (r.stdout, r.stderr)
    assert r.stderr == f"hapticfx: error: {wav}: cannot write in {wav.parent} (Not a directory)\n"

def test_serve_refuses_at_start_an_output_it_would_replace_or_cannot_write(tmp_path):
    """A --device wav:/csv: file or --log file the user wrote, or a directory: one line, exit 2, before it
    listens, and the file as it was; --force replaces a file (its own log is replaced without it)."""
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE.format(wav=tmp_path / "o.wav", rate=0, burst=1))
    mine, log, folder = tmp_path / "mine.wav", tmp_path / "mylog.txt", tmp_path / "outdir.wav"
    mine.write_text("precious\n")
    log.write_text("my notes\n")
    folder.mkdir()

    def serve(*args):
        return subprocess.run([sys.executable, "-m", "hapticfx", "serve", str(scene), "--port", "0", "--duration",
                               "0.1", *map(str, args)], capture_output=True, text=True, timeout=60)

    for args, said in ((("--device", f"wav:{mine}"), f"{mine}: exists and was not written by hapticfx; use --force"),
                       (("--device", f"csv:{log}"), f"{log}: exists and was not written by hapticfx; use --force"),
                       (("--device", "memory", "--log", log), f"{log}: exists and was not written by hapticfx; use --force"),
                       (("--device", f"wav:{folder}", "--force"), f"{folder}: is a directory, expected a file name"),
                       (("--device", "memory", "--log", folder, "--force"), f"{folder}: is a directory, expected a file name")):
        r = serve(*args)
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and "listening on" not in r.stdout, (args, r.stderr)
        assert r.stderr.startswith(f"hapticfx: error: {said}"), (args, r.stderr)
    assert (mine.read_text(), log.read_text()) == ("precious\n", "my notes\n")
    r = serve("--device", "memory", "--log", log, "--force")
    assert r.returncode == 0 and log.read_text() == "", r.stderr
    log.write_text(_played_log_line())
    assert serve("--device", "memory", "--log", log).returncode == 0  # a log serve wrote is its own


def test_serve_that_cannot_listen_leaves_the_last_sessions_log_as_it_was(tmp_path):
    """The log was opened (emptied) once the outputs opened, before the port was bound: a port in use, or a
    remote host refused, left an empty log where the last session's was."""
    import socket

    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE.format(wav=tmp_path / "o.wav", rate=0, burst=1))
    log = tmp_path / "last.jsonl"
    log.write_text(_played_log_line())
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", 0))
        for args in (("--port", str(busy.getsockname()[1])), ("--port", "0", "--host", "0.0.0.0")):
            r = subprocess.run([sys.executable, "-m", "hapticfx", "serve", str(scene), "--device", "memory", "--log",
                                str(log), "--duration", "0.1", *args], capture_output=True, text=True, timeout=60)
            assert r.returncode == 2 and r.stderr.count("\n") == 1, (args, r.stderr)
            assert log.read_text() == _played_log_line(), args


def _played_log_line() -> str:
    from types import SimpleNamespace

    from hapticfx.builtins.scene import _played_line

    return _played_line(SimpleNamespace(object="brick", velocity=3.0, at=None, point=None, normal=None, output="o",
                                        peak=0.5, duration_s=0.1, latency_s=0.001)) + "\n"


def test_bench_serve_runs_and_reports_median_and_p99():
    out = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "serve", "--impacts", "10", "--interval-ms", "0"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "| serve: datagram arrival -> actuator" in out.stdout and "p99 ms" in out.stdout
    assert '"accepted": 20' in out.stderr  # 10 warm-up + 10 timed, none dropped



def test_bench_flood_that_cannot_start_serve_says_why_in_one_line(tmp_path):
    (tmp_path / "s.yaml").write_text(SCENE.format(wav=tmp_path / "o.wav", rate=0, burst=1))
    for args, said in (([str(tmp_path / "nope.yaml")], f"{tmp_path / 'nope.yaml'}: file not found"),
                       ([str(tmp_path / "s.yaml"), "--device", f"wav:{tmp_path}/absent/o.wav", "--seconds", "1"],
                        f"directory {tmp_path}/absent does not exist")):
        r = subprocess.run([sys.executable, "-m", "hapticfx", "bench", "flood", *args], capture_output=True, text=True,
                           timeout=60)
        assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
        assert r.stderr.startswith("hapticfx: error: serve did not start: ") and said in r.stderr

def test_serve_that_cannot_write_its_file_output_exits_2(tmp_path):
    """Files capped at 4 kB (RLIMIT_FSIZE: the OS refuses the write, as a full disk does)."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE.format(wav=tmp_path / "helmet.wav", rate=0, burst=500))
    code = ("import resource, signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); "
            "resource.setrlimit(resource.RLIMIT_FSIZE, (4000, 4000)); "
            "from hapticfx.cli import main; main(sys.argv[1:])")
    proc = subprocess.Popen([sys.executable, "-c", code, "serve", str(scene), "--duration", "3"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert line.startswith("listening on 127.0.0.1:"), line + proc.stderr.read()
    port = int(line.split()[2].rsplit(":", 1)[1])
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
        for _ in range(5):
            client.sendto(osc("/hapticfx/impact", "concrete-brick", (3.0, "f")), ("127.0.0.1", port))
            time.sleep(0.05)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 2, (out, err)
    # the file output holds the last 2 s of its timeline before writing them: the write fails at close
    assert "1 output(s) could not be finished" in err and "File too large" in err and "Traceback" not in err
    assert not (tmp_path / "helmet.wav").exists()
    assert not list(tmp_path.glob(".helmet.wav*"))  # nor its temporary file
