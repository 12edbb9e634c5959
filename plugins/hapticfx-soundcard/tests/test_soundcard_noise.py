"""The stderr filter: PortAudio/ALSA diagnostics hidden and counted, everything else forwarded in order."""

import os
import subprocess
import sys
import textwrap

CHILD = textwrap.dedent("""
    import os, sys, threading, time
    from hapticfx_soundcard.noise import NoiseFilter
    f = NoiseFilter()
    f.acquire()
    f.acquire()  # a second stream: one filter
    os.write(2, b"before\\n")
    os.write(2, b"Expression 'ret' failed in 'src/hostapi/alsa/pa_linux_alsa.c', line: 1736\\n")
    os.write(2, b"ALSA lib pulse.c:242:(pulse_connect) PulseAudio: Unable to connect: Connection refused\\n\\n")
    t = threading.Thread(target=lambda: print("from a thread", file=sys.stderr, flush=True)); t.start(); t.join()
    for piece in (b"ALSA lib x.c:1: y\\n", b"split", b" line\\n", b"part", b"Expression 'q' failed in 'src/q.c'\\n"):
        os.write(2, piece)  # one read each: the rest of a line whose start went out is never taken for noise
        time.sleep(0.05)
    os.write(2, b"\\rprogress 50%")  # no newline: forwarded at once, not held back
    os.write(2, b"\\nExpr")           # could still become a diagnostic: held until its end
    os.write(2, b"ession 'x' failed in 'src/y.c', line: 1\\nafter\\n")
    f.release()
    os.write(2, b"still filtered\\n")
    f.release()
    os.write(2, b"Expression 'z' failed in 'src/z.c', line: 2\\n")  # no stream any more: shown as it is
""")


def run(noise=None) -> str:
    """The child's stderr, bytes decoded as they are (a carriage return stays one)."""
    env = {k: v for k, v in os.environ.items() if k != "HAPTICFX_DEVICE_NOISE"}
    if noise:
        env["HAPTICFX_DEVICE_NOISE"] = noise
    done = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, env=env, timeout=30)
    assert done.returncode == 0, done.stderr
    return done.stderr.decode()


def test_diagnostics_are_hidden_and_summarised_in_one_line():
    lines = run().split("\n")
    assert lines[:6] == ["before", "from a thread", "split line", "partExpression 'q' failed in 'src/q.c'",
                         "\rprogress 50%", "after"]
    assert lines[6] == "still filtered"
    assert lines[7].startswith("hapticfx-soundcard: hid 4 line(s) of PortAudio/ALSA diagnostics (first: \"Expression 'ret'")
    assert lines[8] == "Expression 'z' failed in 'src/z.c', line: 2"


def test_show_leaves_stderr_alone():
    stderr = run("show")
    assert "Expression 'ret' failed" in stderr and "hid" not in stderr
