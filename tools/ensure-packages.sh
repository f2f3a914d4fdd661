#!/usr/bin/env bash
# Install the Debian packages named on the command line that are missing.
# Idempotent: does nothing when all are present. Needs root or password-less sudo; otherwise
# it stops and lists what to install, so that nothing is half-done silently.
set -euo pipefail

missing=()
for pkg in "$@"; do
  status=$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$pkg")
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

echo "setup: installing Debian packages: ${missing[*]}"
if [[ $(id -u) -eq 0 ]]; then
  sudo=()
elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
  sudo=(sudo)
else
  echo "setup: these Debian packages are missing and I cannot install them (not root, no sudo):" >&2
  echo "  sudo apt-get install --no-install-recommends ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
# Refresh the package lists once a day at most: an old list can miss packages entirely.
lists=$(find /var/lib/apt/lists -maxdepth 1 -name '*Packages*' -mmin -1440 2>/dev/null | head -1)
if [[ -z "$lists" ]]; then
  "${sudo[@]}" apt-get -o DPkg::Lock::Timeout=900 update -q
fi
"${sudo[@]}" apt-get -o DPkg::Lock::Timeout=900 install -y -q --no-install-recommends "${missing[@]}"
