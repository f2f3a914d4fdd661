"""Class folders of real recordings that a Debian package ships: knocks on objects and
drum hits, recorded at 44.1 kHz by other people with other microphones.

Debian's ``hydrogen-drumkits`` (the Hydrogen drum machine's sample kits, GPL-2, GPL-2+ or
CC-BY-SA-3.0 by kit: docs/classifiers.md lists them) installs
real, dry recordings of single hits under ``/usr/share/hydrogen/data/drumkits``. Two tasks
fit the fingertip's knock classifier:

- ``knocks``: the kit "Gimme A Hand 1.0" (hand percussion: bongos, cajon, clave, cowbell,
  finger snap, hand clap, maraca, tambourine, water glasses, wood block), 13 objects, five
  hits each at five strengths (softest to hardest): few recordings per class, many classes;
- ``drums``: kick, snare, hi-hat, tom and cymbal from five acoustic kits recorded by
  different people in different rooms (BJA_Pacific, ForzeeStereo, The Black Pearl,
  ColomboAcousticDrumkit, Millo_MultiLayered3), unbalanced classes.

Nothing here is used to choose any default: these sets are only evaluated, and no file of
the package is shipped or committed (their licences apply to them, not to this
repository). ``make bench`` fetches the pinned package itself (``make drumkits``,
tools/fetch-drumkits.sh: ``apt-get download`` and ``dpkg-deb -x`` into build/drumkits, no
install needed); the folder is looked up in this order: the ``root`` argument (the bench
passes ``FINGERTIP_DRUMKITS``), build/drumkits, Debian's installed package.
"""
from __future__ import annotations

import logging
import re
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

KITS_IN_PACKAGE = Path("usr/share/hydrogen/data/drumkits")
FETCHED = Path(__file__).resolve().parents[2] / "build" / "drumkits" / KITS_IN_PACKAGE
"""Where ``make drumkits`` unpacks the package (build/ is not tracked)."""
DRUMKITS = Path("/") / KITS_IN_PACKAGE
"""Where ``apt-get install hydrogen-drumkits`` puts the kits."""
AUDIO = (".wav", ".flac", ".aiff", ".aif")
MAX_S = 1.0
"""Hits are cut to their first second (cymbals ring for several)."""

KNOCK_KIT = "Gimme A Hand 1.0"
DRUM_KITS = ("BJA_Pacific", "ForzeeStereo", "The Black Pearl 1.0", "ColomboAcousticDrumkit",
             "Millo_MultiLayered3")
DRUM_CLASSES = {
    # class: (file-name pattern, pattern that excludes: rim shots and bells are other sounds)
    "kick": (r"^(bd|kick)|kick|bassdrum", None),
    "snare": (r"^(sn|sd)|snare", r"rim|stick|off"),
    "hihat": (r"^(hh|ho)|hihat|hat", None),
    "tom": (r"^(tm|t1|t2|ft)|tom", None),
    "cymbal": (r"^(rd|cc|rc)|crash|ride|china|splash", r"bell|cup|choke"),
}


def find_root(root: str | Path | None = None) -> Path | None:
    """The drumkits folder: ``root`` when given (and only it, so that an explicit folder is
    never silently replaced by another copy), else the fetched copy under build/, else
    Debian's installed one; None when the chosen folder does not hold the kits."""
    candidates = [Path(root)] if root is not None else [FETCHED, DRUMKITS]
    return next((p for p in candidates if (p / KNOCK_KIT).is_dir()), None)


def _write(src: Path, dst: Path) -> bool:
    import soundfile as sf

    try:
        x, rate = sf.read(str(src), always_2d=True, dtype="float64")
    except (RuntimeError, sf.LibsndfileError) as e:  # a kit's odd file: skip, say so
        log.warning("skipped %s: %s", src, e)
        return False
    x = x[:int(MAX_S * rate), 0]
    if not len(x) or not np.any(x):
        return False
    dst.parent.mkdir(parents=True, exist_ok=True)
    sf.write(str(dst), x, int(rate), subtype="PCM_16")
    return True


def knock_set(out: str | Path, root: str | Path | None = None) -> dict[str, int]:
    """Write the hand-percussion knocks as class folders under ``out``; counts per class."""
    kit = (find_root(root) or DRUMKITS) / KNOCK_KIT
    counts: dict[str, int] = {}
    for f in sorted(kit.iterdir()):
        if f.suffix.lower() not in AUDIO:
            continue
        label = re.sub(r"-(Hardest|Hard|Med|Softest|Soft)$", "", f.stem).lower()
        if _write(f, Path(out) / label / (f.stem + ".wav")):
            counts[label] = counts.get(label, 0) + 1
    return counts


def drum_label(name: str) -> str | None:
    n = name.lower()
    for label, (pat, excl) in DRUM_CLASSES.items():
        if re.search(pat, n) and not (excl and re.search(excl, n)):
            return label
    return None


def drum_set(out: str | Path, root: str | Path | None = None) -> dict[str, int]:
    """Write kick/snare/hi-hat/tom/cymbal hits of five kits under ``out``; counts."""
    base = find_root(root) or DRUMKITS
    counts: dict[str, int] = {}
    for k, kit in enumerate(DRUM_KITS):
        for f in sorted((base / kit).iterdir()):
            label = drum_label(f.stem) if f.suffix.lower() in AUDIO else None
            if label and _write(f, Path(out) / label / f"kit{k}_{f.stem}.wav"):
                counts[label] = counts.get(label, 0) + 1
    return counts
