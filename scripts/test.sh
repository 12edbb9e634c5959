#!/usr/bin/env bash
# Run the test suite: starts the virtual sound card (PulseAudio null sink) the
# sound-card tests play into, then pytest; arguments go to pytest. A sound server
# this script started is stopped again when the tests end (however they end); one
# that was already running is left as it was.
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
"$PY" -m pytest -q "$@"
