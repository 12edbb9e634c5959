#!/usr/bin/env bash
# Run the test suite: starts the virtual sound card (PulseAudio null sink) the
# sound-card tests play into, then pytest. Arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
XDG_RUNTIME_DIR=$(bash .ci/soundserver.sh | tail -n 1)
export XDG_RUNTIME_DIR
exec "$PY" -m pytest -q "$@"
