#!/usr/bin/env bash
# Run the test suite: starts the virtual sound card (PulseAudio null sink) the
# sound-card tests play into, then pytest; arguments go to pytest. A sound server
# this script started is stopped again when the tests end (however they end); one
# that was already running is left as it was.
# The tests run in parallel (pytest-xdist), one worker per processor and at most 4;
# HAPTICFX_TEST_WORKERS sets the number (0: in this process, one after another). A test
# module runs on one worker, so its module-scoped fixtures are made once.
# Each worker that records the sound card starts a null sink of its own.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
export HAPTICFX_XDG=${HAPTICFX_XDG:-/tmp/hapticfx-xdg}
running=no
if [ -f "$HAPTICFX_XDG/pulse/pid" ] && grep -qa pulseaudio "/proc/$(cat "$HAPTICFX_XDG/pulse/pid")/cmdline" 2>/dev/null; then
  running=yes
fi
XDG_RUNTIME_DIR=$(bash .ci/soundserver.sh | tail -n 1)
export XDG_RUNTIME_DIR
if [ "$running" = no ]; then
  trap 'bash .ci/soundserver.sh --stop >/dev/null' EXIT
fi
workers=${HAPTICFX_TEST_WORKERS:-$(( $(nproc) < 4 ? $(nproc) : 4 ))}
"$PY" -m pytest -q -n "$workers" --dist loadscope "$@"
