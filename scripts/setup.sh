#!/usr/bin/env bash
# Set up mirrorscan on a fresh Debian/Ubuntu machine: system libraries, a virtual environment in .venv, the package.
#   scripts/setup.sh          the tool
#   scripts/setup.sh --test   the tool and what the test suite needs (with the depth camera libraries: libfreenect,
#                             its replay driver and gcc for the Kinect test, OpenNI2, pyrealsense2; Debian's
#                             chromium for the browser tests, which are skipped where it cannot be installed)
set -euo pipefail
cd "$(dirname "$0")/.."

extras=""
packages=(libusb-1.0-0 libgomp1)
if [ "${1:-}" = "--test" ]; then
  extras="[test,devices]"
  # PyPI freenect builds (Cython, gcc, Python headers) against libfreenect-dev; OpenNI2's loader wants libOpenNI2.so.
  packages+=(libfreenect-dev libfreenect0.5 libusb-1.0-0-dev libopenni2-dev gcc python3-dev)
fi

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }

# open3d needs libusb-1.0-0 and libgomp1; the virtual environment needs python3-venv on Debian/Ubuntu.
missing=()
for pkg in "${packages[@]}"; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
python3 -c "import venv, ensurepip" >/dev/null 2>&1 || missing+=(python3-venv)
if [ ${#missing[@]} -gt 0 ]; then
  as_root apt-get update -q
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${missing[@]}"
fi

if [ "${1:-}" = "--test" ] && ! command -v chromium >/dev/null 2>&1; then
  # Debian's chromium; Ubuntu's is a snap wrapper that may not install in a container: the browser tests then skip.
  { as_root apt-get update -q && as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium; } \
    || echo "setup: chromium could not be installed; the browser tests will be skipped" >&2
fi

python3 -c 'import sys; sys.exit(sys.version_info < (3, 10))' || { echo "mirrorscan needs Python 3.10 or newer" >&2; exit 1; }
[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -e ".${extras}"
