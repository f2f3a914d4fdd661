#!/usr/bin/env bash
# Install KiCad 9 (kicad-cli + stock symbol and footprint libraries) from bookworm-backports,
# when kicad-cli 9 is missing. Idempotent: does nothing when `kicad-cli version` says 9.x and
# the stock libraries are present. The backports source line is added only when needed.
# Needs root or password-less sudo; otherwise it stops and prints what to run.
set -euo pipefail

PKGS=(kicad kicad-symbols kicad-footprints)
SYMDIR=/usr/share/kicad/symbols
FPDIR=/usr/share/kicad/footprints

have_kicad9() {
  command -v kicad-cli >/dev/null 2>&1 || return 1
  local v
  v=$(kicad-cli version 2>/dev/null | head -1 || true)
  [[ "$v" == 9.* ]] || return 1
  [[ -f "$SYMDIR/Device.kicad_sym" && -d "$FPDIR/Connector_FFC-FPC.pretty" ]]
}

if have_kicad9; then
  exit 0
fi

if [[ $(id -u) -eq 0 ]]; then
  sudo=()
elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
  sudo=(sudo)
else
  echo "pcb: KiCad 9 (kicad-cli) is missing and I cannot install it (not root, no sudo). Run:" >&2
  echo "  echo 'deb http://deb.debian.org/debian bookworm-backports main' |" \
       "sudo tee /etc/apt/sources.list.d/backports.list" >&2
  echo "  sudo apt-get update && sudo apt-get install --no-install-recommends" \
       "-t bookworm-backports ${PKGS[*]}" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive
codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")
if [[ "$codename" != "bookworm" ]]; then
  # Other releases (trixie and later) carry KiCad 9 in their main archive.
  echo "pcb: installing KiCad from the $codename archive"
  "${sudo[@]}" apt-get -o DPkg::Lock::Timeout=900 update -q
  "${sudo[@]}" apt-get -o DPkg::Lock::Timeout=900 install -y -q --no-install-recommends "${PKGS[@]}"
else
  list=/etc/apt/sources.list.d/backports.list
  if ! grep -rqs '^[^#]*bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
    echo "pcb: adding bookworm-backports to $list"
    echo 'deb http://deb.debian.org/debian bookworm-backports main' |
      "${sudo[@]}" tee -a "$list" >/dev/null
  fi
  echo "pcb: installing KiCad 9 from bookworm-backports (${PKGS[*]})"
  "${sudo[@]}" apt-get -o DPkg::Lock::Timeout=900 update -q
  "${sudo[@]}" apt-get -o DPkg::Lock::Timeout=900 install -y -q --no-install-recommends \
    -t bookworm-backports "${PKGS[@]}"
fi

if ! have_kicad9; then
  echo "pcb: KiCad 9 still missing after the install: kicad-cli version = " \
       "$(kicad-cli version 2>&1 | head -1)" >&2
  exit 1
fi
echo "pcb: kicad-cli $(kicad-cli version | head -1) ready"
