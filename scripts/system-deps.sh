#!/usr/bin/env bash
# Installs the Debian packages mpmpp builds against, only those that are missing.
# Eigen 3.4 and nlohmann-json come from Debian (design card), GoogleTest for ctest,
# ccache so the package and test builds compile each source once, clang-format for make lint,
# Chromium for the test that opens `mpmpp report`'s page in a real headless browser.
set -euo pipefail
need=()
for pkg in g++ make cmake libeigen3-dev nlohmann-json3-dev libgtest-dev python3-venv python3-dev chromium ccache clang-format; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || need+=("$pkg")
done
# A Python that already has venv and its headers (e.g. pyenv) makes the Debian python packages unnecessary.
if python3 -c 'import venv, ensurepip, sysconfig, os, sys; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' 2>/dev/null; then
  need=("${need[@]/python3-venv}"); need=("${need[@]/python3-dev}")
fi
command -v cmake >/dev/null && need=("${need[@]/cmake}")
pkgs=$(printf '%s\n' "${need[@]}" | grep -v '^$' || true)
[ -z "$pkgs" ] && exit 0
echo "installing Debian packages: $(echo $pkgs)"
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq $pkgs >/dev/null
