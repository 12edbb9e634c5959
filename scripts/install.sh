#!/usr/bin/env bash
# Install hapticfx and its first-party plugins on a fresh Debian/Ubuntu machine.
#   scripts/install.sh          system libraries (apt, when run as root) + hapticfx + plugins (no torch)
#   scripts/install.sh --test   the same, plus what the tests need (torch CPU build, virtual sound server,
#                               socat, oscsend, godot3-server, mono-mcs)
# Uses the active Python (a virtual environment if one is active).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}

apt_packages=(libportaudio2 libpulse0)   # sounddevice needs PortAudio; the sound-card `queue` option libpulse
if [ "${1:-}" = "--test" ]; then
  # PulseAudio null sink for the sound-card tests, socat for serial pairs, liblo-tools for oscsend.
  # gcc-avr, avr-libc, arduino-core-avr: the solenoid sketch is compiled for the Uno in a test.
  apt_packages+=(pulseaudio pulseaudio-utils libasound2-plugins socat liblo-tools gcc-avr avr-libc arduino-core-avr)
  # The study page is tested in Debian's headless chromium through selenium.
  apt_packages+=(chromium chromium-driver)
  # The engine examples: Godot 3 headless runs examples/godot/; Mono's C# compiler builds examples/unity/.
  apt_packages+=(godot3-server mono-mcs)
fi
apt_get() {
  # apt-get that waits for another package manager (unattended-upgrades, a second install) to let go
  # of its locks instead of failing: apt itself waits on dpkg's lock, and a run that still could not
  # get one is tried again, for up to 15 minutes.
  local waited=0 out
  while true; do
    if out=$(apt-get -o DPkg::Lock::Timeout=120 "$@" 2>&1); then return 0; fi
    if grep -qiE "could not get lock|unable to acquire|is held by process" <<<"$out" && [ "$waited" -lt 900 ]; then
      echo "install: another package manager holds apt's lock; waiting (${waited} s so far)"
      sleep 15
      waited=$((waited + 15))
      continue
    fi
    echo "$out" | tail -n 20 >&2
    return 1
  done
}

if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null; then
  missing=()
  for p in "${apt_packages[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "install: apt-get install ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt_get update -qq
    apt_get install -y -qq --no-install-recommends "${missing[@]}"
    echo "install: installed ${missing[*]}"
  else
    echo "install: system packages already there: ${apt_packages[*]}"
  fi
else
  echo "install: not root; make sure these system packages are installed: ${apt_packages[*]}"
fi

extra="" neural=""
if [ "${1:-}" = "--test" ]; then
  # The tests train networks: torch, CPU build, installed first so that hapticfx-neural[train]'s `torch>=2.3`
  # is already met (a plain resolve from PyPI takes a CUDA build of several GB; nothing here needs a GPU).
  cpu_index=https://download.pytorch.org/whl/cpu
  if [ "$(uname -s)" = "Linux" ] && "$PY" -c "import urllib.request as u; u.urlopen('$cpu_index/torch/', timeout=5)" 2>/dev/null; then
    "$PY" -m pip install -q --disable-pip-version-check --index-url "$cpu_index" "torch>=2.3"
    echo "install: torch $("$PY" -W ignore -c 'import torch; print(torch.__version__)') (CPU build) from $cpu_index"
  else
    # PyTorch's index is unreachable: the default index. torch 2.13.0 is the release this project was
    # tested with (pip takes a CPU wheel when one is on its find-links, as on the project's machines).
    "$PY" -m pip install -q --disable-pip-version-check "torch==2.13.0"
    echo "install: torch $("$PY" -W ignore -c 'import torch; print(torch.__version__)') from the default index ($cpu_index unreachable)"
  fi
  extra="[test,earthquake,docs,study,ogg]" neural="[train]"
fi
# Playing effects needs no torch: learned interpolators are served from their velocity tables.
"$PY" -m pip install -q --disable-pip-version-check -e ".${extra}" \
  -e "plugins/hapticfx-neural${neural}" -e plugins/hapticfx-soundcard -e plugins/hapticfx-solenoid
echo "install: done ($("$PY" -m hapticfx plugins | tail -n +2 | awk '{print $4}' | sort -u | tr '\n' ' '))"
