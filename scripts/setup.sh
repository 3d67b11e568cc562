#!/usr/bin/env bash
# Set up mirrorscan on a fresh Debian/Ubuntu machine: system libraries, a virtual environment in .venv, the package.
#   scripts/setup.sh          the tool
#   scripts/setup.sh --test   the tool and what the test suite needs
set -euo pipefail
cd "$(dirname "$0")/.."

extras=""
[ "${1:-}" = "--test" ] && extras="[test]"

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }

# open3d needs libusb-1.0-0 and libgomp1; the virtual environment needs python3-venv on Debian/Ubuntu.
missing=()
for pkg in libusb-1.0-0 libgomp1; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
python3 -c "import venv, ensurepip" >/dev/null 2>&1 || missing+=(python3-venv)
if [ ${#missing[@]} -gt 0 ]; then
  as_root apt-get update -q
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${missing[@]}"
fi

python3 -c 'import sys; sys.exit(sys.version_info < (3, 10))' || { echo "mirrorscan needs Python 3.10 or newer" >&2; exit 1; }
[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -e ".${extras}"
