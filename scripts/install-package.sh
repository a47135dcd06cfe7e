#!/usr/bin/env bash
# Builds and installs the mpmpp package (C++ engine + Python layer, with the test extras) into
# the virtual environment of PYTHON, showing the compiler's progress as it goes: pip -q hides
# minutes of compiling, and pip -v buries them in its own output. The full log is kept.
#
# scikit-build-core gives `cmake -E capabilities` 5 s to answer and reads a timeout as "no
# CMake" (the limit is not configurable). The `cmake` on PATH is often a wrapper (a pyenv shim
# starting Python, pip's cmake entry point) that takes 0.7 s idle and far more on a loaded
# machine, while the binary behind it answers in 10 ms. So scikit-build-core gets the binary
# itself (CMAKE_EXECUTABLE, as cmake reports it), run once beforehand so it is not cold; a
# build that still failed on the probe alone is retried once.
#
#   scripts/install-package.sh PYTHON [LOG]
set -euo pipefail
PY=$1
LOG=${2:-build/install.log}
mkdir -p "$(dirname "$LOG")"
PROBE_FAILED='Could not find CMake|CMake version undetermined'
PROGRESS='^\s*\[ *[0-9]+(%|/[0-9]+)\]'  # make's "[ 42%] ..." and ninja's "[7/31] ..."

if [ -z "${CMAKE_EXECUTABLE:-}" ]; then
  CMAKE_EXECUTABLE=$(echo 'message("${CMAKE_COMMAND}")' | cmake -P /dev/stdin 2>&1)
fi
export CMAKE_EXECUTABLE
"$CMAKE_EXECUTABLE" -E capabilities >/dev/null

shown=0
show_progress() {
  local n
  n=$(grep -Ec "$PROGRESS" "$LOG" || true)
  if [ "$n" -gt "$shown" ]; then
    grep -E "$PROGRESS" "$LOG" | sed -n "$((shown + 1)),${n}p" | sed 's/^\s*/  /'
    shown=$n
  fi
}

for attempt in 1 2; do
  echo "building and installing mpmpp for $PY (the C++ engine takes minutes on 2 cores; log: $LOG)"
  "$PY" -m pip install -v --no-build-isolation ".[test]" >"$LOG" 2>&1 &
  pid=$!
  shown=0
  while kill -0 "$pid" 2>/dev/null; do
    sleep 3
    show_progress
  done
  if wait "$pid"; then
    show_progress
    echo "installed mpmpp"
    exit 0
  fi
  if [ "$attempt" = 1 ] && grep -Eq "$PROBE_FAILED" "$LOG"; then
    echo "scikit-build-core's CMake probe timed out; retrying once"
    continue
  fi
  tail -n 40 "$LOG"
  exit 1
done
