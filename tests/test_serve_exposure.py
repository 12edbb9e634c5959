"""Who can reach `hapticfx serve`: loopback unless --allow-remote (with a warning), and the shared secret.

Datagrams go over loopback only (a test sends no traffic to any other address, this machine's own network
address included); what the bridge does with a datagram from another machine is tested by handing its
datagram handler the sender's address, as the receiving thread does.
"""

from __future__ import annotations

import socket
import subprocess
import sys

import pytest
from pythonosc.osc_message_builder import OscMessageBuilder

from hapticfx.errors import HapticfxError
from hapticfx.osc import OscBridge, check_secret

SECRET = "s3cret-Token_0123456789"
SCENE = """
name: exposed
effects:
  concrete-brick:
    inline: {{name: brick, object: concrete-brick, model: {{type: kinetic-energy}}, actuator: {{type: memory}}}}
events:
  osc: {{host: {host}, port: 0}}
"""


def osc(address: str, obj: str = "concrete-brick", velocity: float = 3.8) -> bytes:
    b = OscMessageBuilder(address)
    b.add_arg(obj)
    b.add_arg(velocity, "f")
    return b.build().dgram


def _serve(tmp_path, *args, host="127.0.0.1"):
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE.format(host=host))
    return subprocess.Popen([sys.executable, "-m", "hapticfx", "serve", str(scene), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("where", [("--host", "0.0.0.0"), ("scene",)])
def test_serve_refuses_an_address_beyond_loopback_without_the_flag(tmp_path, where):
    args = ["--duration", "5", *where] if where[0] == "--host" else ["--duration", "5"]
    proc = _serve(tmp_path, *args, host="0.0.0.0" if where == ("scene",) else "127.0.0.1")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 2, (out, err)
    assert "listening on" not in out
    assert err.count("\n") == 1 and "0.0.0.0:0 listens beyond this machine" in err and "--allow-remote" in err
    assert "Traceback" not in err


def test_allow_remote_listens_with_a_warning_and_loopback_senders_still_play(tmp_path):
    proc = _serve(tmp_path, "--host", "0.0.0.0", "--allow-remote", "--duration", "3")
    line = proc.stdout.readline()
    assert line.startswith("listening on 0.0.0.0:"), line + proc.stderr.read()
    port = int(line.split()[2].rsplit(":", 1)[1])
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:
        client.sendto(osc("/hapticfx/impact"), ("127.0.0.1", port))
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "warning: listening on 0.0.0.0:" in err and "with no secret" in err and "--secret-file" in err
    assert '"accepted": 1' in out and '"rendered": 1' in out


def _counting_bridge(**kw):
    got = []
    bridge = OscBridge(lambda m, t: got.append(m) or True, ["concrete-brick"], port=0, rate_hz=0, **kw)
    return bridge, got


def test_without_a_secret_other_machines_play_plain_messages_and_prefixed_ones_are_unauthorized():
    bridge, got = _counting_bridge(host="0.0.0.0", allow_remote=True)
    with bridge:
        assert bridge.handle(osc("/hapticfx/impact"), 0.0, "192.0.2.7") is None
        assert bridge.handle(osc(f"/{SECRET}/hapticfx/impact"), 0.0, "192.0.2.7") == "unauthorized"
        stats = bridge.stats()
    assert len(got) == 1 and stats["accepted"] == 1 and stats["dropped"]["unauthorized"] == 1


def test_the_secret_by_sender_address():
    bridge, got = _counting_bridge(secret=SECRET)
    with bridge:
        assert bridge.handle(osc("/hapticfx/impact"), 0.0, "127.0.0.1") is None
        assert bridge.handle(osc("/hapticfx/impact"), 0.0, "192.0.2.7") == "unauthorized"
        assert bridge.handle(osc(f"/{SECRET}/hapticfx/impact"), 0.0, "192.0.2.7") is None
        assert bridge.handle(osc(f"/{SECRET[:-1]}/hapticfx/impact"), 0.0, "192.0.2.7") == "unauthorized"
        assert bridge.handle(osc(f"/{SECRET}/hapticfx/other"), 0.0, "192.0.2.7") == "wrong_address"
        assert bridge.handle(osc(f"/a/{SECRET}/hapticfx/impact"), 0.0, "192.0.2.7") == "wrong_address"
    assert len(got) == 2


def test_the_bridge_refuses_a_remote_address_unless_allowed():
    with pytest.raises(HapticfxError, match="listens beyond this machine"):
        OscBridge(lambda m, t: True, [], host="0.0.0.0", port=0)
    for bad in ("short", "x" * 129, "has/slash-0123456789", "spaces are not ok 0123"):
        with pytest.raises(HapticfxError, match="16 to 128 letters") as err:
            check_secret(bad)
        assert bad not in str(err.value)


def test_serve_reads_the_secret_from_a_file_and_says_what_is_wrong_with_it(tmp_path):
    good, short = tmp_path / "secret", tmp_path / "short"
    good.write_text(SECRET + "\n")
    short.write_text("abc\n")
    for path, expected in ((tmp_path / "missing", "missing: file not found"), (short, "short: the first line: expected 16")):
        proc = _serve(tmp_path, "--secret-file", str(path), "--duration", "1")
        out, err = proc.communicate(timeout=60)
        assert proc.returncode == 2 and expected in err and err.count("\n") == 1 and "abc" not in err, err
    proc = _serve(tmp_path, "--host", "0.0.0.0", "--allow-remote", "--secret-file", str(good), "--duration", "1")
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "/<secret>/hapticfx/impact" in err and SECRET not in err + out
