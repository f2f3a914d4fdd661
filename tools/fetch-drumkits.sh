#!/usr/bin/env bash
# Fetch Debian's hydrogen-drumkits into a folder of this checkout, for the vibration bench's
# figures on real recordings (tests/bench/public_sets.py). Its kits are GPL-2, GPL-2+ or
# CC-licensed, kit by kit (docs/classifiers.md names those used). Evaluation only: nothing
# from it is shipped, committed or used to choose a default, and `make test` never needs it.
#
# Usage: tools/fetch-drumkits.sh [DEST]   (default build/drumkits; the kits end up under
# DEST/usr/share/hydrogen/data/drumkits). The version is pinned so that the bench's figures
# come from the same files on every machine; apt-get checks the download against the
# archive's signed index. Never fails the build: when the package cannot be had it prints one
# warning line and exits 0, and the bench then skips those figures.
set -uo pipefail

VERSION="2017.09.19~dfsg-1"
DEST="${1:-build/drumkits}"
KITS="$DEST/usr/share/hydrogen/data/drumkits"

warn() {
  echo "WARNING: hydrogen-drumkits $VERSION not fetched ($1); the vibration bench will" \
       "skip its real-recording figures" >&2
  exit 0
}

# Already there and the pinned version: nothing to do (the unpacked kits are 220 MB).
if [[ -f "$DEST/.version" && "$(cat "$DEST/.version")" == "$VERSION" \
      && -d "$KITS/Gimme A Hand 1.0" ]]; then
  exit 0
fi
command -v apt-get >/dev/null && command -v dpkg-deb >/dev/null || warn "no apt-get/dpkg-deb"

mkdir -p "$(dirname "$DEST")" || warn "cannot create $(dirname "$DEST")"
tmp=$(mktemp -d "$DEST.part.XXXXXX") || warn "cannot create a folder beside $DEST"
trap 'rm -rf "$tmp"' EXIT
chmod 755 "$tmp"  # apt's _apt user writes the download here when run as root

echo "fetching hydrogen-drumkits $VERSION (143 MB, GPL kits, evaluation only) into $DEST"
if ! (cd "$tmp" && apt-get download -q "hydrogen-drumkits=$VERSION") >"$tmp/log" 2>&1; then
  warn "$(grep -m1 '^E:' "$tmp/log" || tail -n1 "$tmp/log")"
fi
deb=$(find "$tmp" -maxdepth 1 -name 'hydrogen-drumkits_*.deb' | head -n1)
[[ -n "$deb" ]] || warn "apt-get download left no .deb"
# Unpack beside the destination, then swap it in: an interrupted run leaves no half folder
# that the bench would take for the kits.
dpkg-deb -x "$deb" "$tmp/root" 2>"$tmp/log" || warn "dpkg-deb -x: $(tail -n1 "$tmp/log")"
[[ -d "$tmp/root/usr/share/hydrogen/data/drumkits/Gimme A Hand 1.0" ]] \
  || warn "the package holds no usr/share/hydrogen/data/drumkits"
echo "$VERSION" >"$tmp/root/.version"
rm -rf "$DEST" && mv "$tmp/root" "$DEST" || warn "cannot move the kits into $DEST"
echo "hydrogen-drumkits $VERSION unpacked: $KITS"
