"""The study page against what another site or a broken client sends: real HTTP over raw sockets to the real
server on 127.0.0.1 (DNS rebinding is a foreign Host header on a loopback connection)."""

from __future__ import annotations

import json
import socket

import pytest

from hapticfx.study.server import StudyServer, loopback_name, loopback_origin


def _raw(server, request: bytes) -> tuple[int, dict[str, str], bytes]:
    """Send ``request`` as it is and read the whole answer: (status, headers, body)."""
    host, port = server.httpd.server_address[:2]
    with socket.create_connection((host, port), timeout=10) as sock:
        sock.sendall(request)
        sock.shutdown(socket.SHUT_WR)
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    headers = dict(line.split(": ", 1) for line in lines[1:])
    return int(lines[0].split()[1]), headers, body


def _request(server, method: str, path: str, *, host: str | None = None, body: dict | None = None,
             token: str | None = None, extra: dict | None = None) -> tuple[int, bytes]:
    port = server.httpd.server_address[1]
    headers = {"Host": f"127.0.0.1:{port}" if host is None else host}
    if token:
        headers["X-Study-Token"] = token
    data = b""
    if body is not None:
        data = json.dumps(body).encode()
        headers.update({"Content-Type": "application/json", "Content-Length": str(len(data))})
    headers.update(extra or {})
    head = f"{method} {path} HTTP/1.1\r\n" + "".join(f"{k}: {v}\r\n" for k, v in headers.items()) + "Connection: close\r\n\r\n"
    status, _, answer = _raw(server, head.encode("latin-1") + data)
    return status, answer


def _start_trial(server):
    assert _request(server, "POST", "/api/proceed", body={"trial": 0, "screen": "instructions"}, token=server.token)[0] == 200


@pytest.mark.parametrize("host", ["rebind.evil.example", "rebind.evil.example:8000", "evil.localhost.example",
                                  "192.168.1.20", "0.0.0.0", "localhost.evil.example", "[::2]", ""])
def test_a_foreign_host_gets_403_and_never_the_token(served, host):
    session, server, player = served
    for path in ("/", "/app.js", "/api/state"):
        status, body = _request(server, "GET", path, host=host, token=server.token)
        assert status == 403 and server.token.encode() not in body
    _start_trial(server)
    status, _ = _request(server, "POST", "/api/play", host=host, body={"trial": 0, "slot": "stimulus"}, token=server.token)
    assert status == 403
    assert player.engine.stats()["submitted"] == 0  # nothing played
    assert server.errors == []


@pytest.mark.parametrize("origin", ["http://rebind.evil.example", "http://rebind.evil.example:8000", "null",
                                    "https://127.0.0.1", "http://127.0.0.1/x", "file://"])
def test_a_foreign_origin_gets_403_and_plays_nothing(served, origin):
    session, server, player = served
    _start_trial(server)
    status, _ = _request(server, "POST", "/api/play", body={"trial": 0, "slot": "stimulus"}, token=server.token,
                         extra={"Origin": origin})
    assert status == 403
    assert _request(server, "GET", "/", extra={"Origin": origin})[0] == 403
    assert player.engine.stats()["submitted"] == 0


def test_loopback_names_are_served(served):
    session, server, player = served
    port = server.httpd.server_address[1]
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", "localhost", f"[::1]:{port}", "127.0.0.2", "LOCALHOST"):
        status, body = _request(server, "GET", "/", host=host)
        assert status == 200 and server.token.encode() in body
    _start_trial(server)
    status, _ = _request(server, "POST", "/api/play", body={"trial": 0, "slot": "stimulus"}, token=server.token,
                         extra={"Origin": f"http://localhost:{port}"})
    assert status == 200
    assert player.engine.stats()["submitted"] >= 1


def test_every_api_route_needs_the_token(served):
    session, server, player = served
    status, body = _request(server, "GET", "/api/state")
    assert status == 403 and b"P05" not in body
    assert _request(server, "GET", "/api/state", token="forged")[0] == 403
    for path in ("/api/proceed", "/api/play", "/api/answer", "/api/nothing"):
        assert _request(server, "POST", path, body={"trial": 0, "screen": "instructions"})[0] == 403
    assert _request(server, "GET", "/api/nothing")[0] == 403
    status, body = _request(server, "GET", "/api/state", token=server.token)
    assert status == 200 and json.loads(body)["participant"] == "P05"


@pytest.mark.parametrize("length", ["abc", "-5", "1e3", "99999999999999999999", "", " 12 x"])
def test_a_malformed_content_length_gets_400_and_no_traceback(served, capfd, length):
    session, server, player = served
    port = server.httpd.server_address[1]
    request = (f"POST /api/proceed HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nX-Study-Token: {server.token}\r\n"
               f"Content-Type: application/json\r\nContent-Length: {length}\r\nConnection: close\r\n\r\n"
               '{"trial": 0, "screen": "instructions"}').encode()
    status, _, body = _raw(server, request)
    assert status == 400 and "error" in json.loads(body)
    assert _request(server, "GET", "/api/state", token=server.token)[0] == 200  # still serving
    out, err = capfd.readouterr()
    assert "Traceback" not in out + err
    assert server.errors == [] and session.state()["screen"] == "instructions"


@pytest.mark.parametrize("body", [b"\xff\xfe", b"[1, 2]", b'{"trial": true}', b'"text"', b"{" * 40])
def test_a_malformed_body_gets_400(served, capfd, body):
    session, server, player = served
    port = server.httpd.server_address[1]
    request = (f"POST /api/play HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nX-Study-Token: {server.token}\r\n"
               f"Content-Type: application/json\r\nContent-Length: {len(body)}\r\nConnection: close\r\n\r\n").encode() + body
    assert _raw(server, request)[0] == 400
    assert "Traceback" not in "".join(capfd.readouterr())
    assert player.engine.stats()["submitted"] == 0 and server.errors == []


def test_a_token_header_in_another_charset_is_refused_not_crashed(served, capfd):
    session, server, _ = served
    port = server.httpd.server_address[1]
    request = (f"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n".encode() + b"X-Study-Token: \xe9t\xe9\r\n"
               + b"Connection: close\r\n\r\n")
    assert _raw(server, request)[0] == 403
    assert "Traceback" not in "".join(capfd.readouterr()) and server.errors == []


def test_the_server_binds_loopback_only(served):
    session, _, _ = served
    with pytest.raises(Exception, match="loopback address only"):
        StudyServer(session, host="0.0.0.0")


def test_loopback_names():
    assert all(map(loopback_name, ["localhost", "127.0.0.1:80", "[::1]", "[::1]:8080", "127.1.2.3"]))
    assert not any(map(loopback_name, [None, "", "example.com", "[::1", "127.0.0.1:x", "::1:80:1", "10.0.0.1"]))
    assert loopback_origin("http://localhost:9000") and loopback_origin("http://[::1]:80")
    assert not any(map(loopback_origin, ["null", "https://localhost", "http://localhost/", "localhost"]))
