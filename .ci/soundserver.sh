#!/usr/bin/env bash
# Start a headless PulseAudio with one null sink ("vsink", 48 kHz stereo) whose
# monitor records back what was played; idempotent. Prints the XDG_RUNTIME_DIR
# that clients must export. Recipe and settle time: docs/soundcard.md.
#   HAPTICFX_XDG   runtime dir to use (default /tmp/hapticfx-xdg); a second dir
#                  gives a second, independent server (the fault tests kill theirs).
#   --stop         stop the server of that dir and its keep-alive player instead.
set -euo pipefail

for tool in pulseaudio pactl pacat; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "soundserver: '$tool' not found; apt-get install -y libportaudio2 pulseaudio pulseaudio-utils libasound2-plugins" >&2
    exit 3
  fi
done

export XDG_RUNTIME_DIR="${HAPTICFX_XDG:-/tmp/hapticfx-xdg}"
mkdir -p "$XDG_RUNTIME_DIR"
chmod 700 "$XDG_RUNTIME_DIR"
# pactl must not autospawn a default daemon (no null sink) when ours is not running yet.
printf 'autospawn = no\n' > "$XDG_RUNTIME_DIR/client.conf"
export PULSE_CLIENTCONFIG="$XDG_RUNTIME_DIR/client.conf"

keepalive() {
  # Silent keep-alive stream: without it the first stream stalls 0.6-1.2 s and loses its start.
  nohup pacat --playback -d vsink --latency-msec=5 --raw --format=s16le --channels=2 --rate=48000 \
    </dev/zero >/dev/null 2>&1 &
  echo $! > "$XDG_RUNTIME_DIR/keepalive.pid"
  sleep 2.5
}

ours() {  # is pid $1 still the program $2 (and not a recycled pid)?
  grep -qa "$2" "/proc/$1/cmdline" 2>/dev/null
}
stop_server() {
  # Its pid files go too: a killed daemon can linger as a zombie where nothing reaps it,
  # and PulseAudio would take that pid for a running daemon.
  local pid
  if [ -f "$XDG_RUNTIME_DIR/keepalive.pid" ]; then
    pid="$(cat "$XDG_RUNTIME_DIR/keepalive.pid")"
    if ours "$pid" pacat; then kill "$pid" 2>/dev/null || true; fi
    rm -f "$XDG_RUNTIME_DIR/keepalive.pid"
  fi
  if [ -f "$XDG_RUNTIME_DIR/pulse/pid" ]; then
    pid="$(cat "$XDG_RUNTIME_DIR/pulse/pid")"
    if ours "$pid" pulseaudio; then kill -CONT "$pid" 2>/dev/null || true; kill "$pid" 2>/dev/null || true; fi
    sleep 0.3
    rm -f "$XDG_RUNTIME_DIR/pulse/pid"
  fi
}

if [ "${1:-}" = "--stop" ]; then
  stop_server
  exit 0
fi

if pactl info >/dev/null 2>&1 && pactl list short sinks 2>/dev/null | grep -q vsink; then
  if ! grep -qa pacat "/proc/$(cat "$XDG_RUNTIME_DIR/keepalive.pid" 2>/dev/null)/cmdline" 2>/dev/null; then
    keepalive
  fi
  echo "$XDG_RUNTIME_DIR"
  exit 0
fi

cat > "$XDG_RUNTIME_DIR/null.pa" <<'PA'
load-module module-native-protocol-unix auth-anonymous=1
load-module module-null-sink sink_name=vsink rate=48000 channels=2
set-default-sink vsink
set-default-source vsink.monitor
PA

stop_server  # a stale daemon on this dir (sink unloaded, or not answering) is replaced

# Running as root is allowed headless; PulseAudio only warns about it.
if ! pulseaudio --daemonize=yes --exit-idle-time=-1 --disallow-exit -n \
  -F "$XDG_RUNTIME_DIR/null.pa" --log-target=file:"$XDG_RUNTIME_DIR/pulse.log" >/dev/null 2>&1; then
  echo "soundserver: pulseaudio failed to start:" >&2
  tail -n 5 "$XDG_RUNTIME_DIR/pulse.log" >&2 || true
  exit 1
fi

for _ in $(seq 1 100); do
  pactl info >/dev/null 2>&1 && break
  sleep 0.05
done
if ! pactl info >/dev/null 2>&1; then
  echo "soundserver: PulseAudio did not answer within 5 s; see $XDG_RUNTIME_DIR/pulse.log" >&2
  exit 1
fi

keepalive
echo "$XDG_RUNTIME_DIR"
