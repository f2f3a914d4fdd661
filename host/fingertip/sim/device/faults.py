"""Build faults of a first fingertip, for the virtual unit (and, by name, for simavr).

Each fault is what a new builder typically gets wrong, modelled where it happens:

- ``swapped-data``: the DOUT wires of two chips swapped (channel a reads chip b and back);
- ``reversed-gauge``: a bridge wired the wrong way round (A+ and A- swapped: the sign flips);
- ``open-bridge``: a broken gauge lead or a cold joint: the input sits at full scale;
- ``missing-chip``: a chip that never answers (no power, no DOUT, not soldered);
- ``stuck-dout``: DOUT shorted low: the chip always looks ready and reads 0;
- ``noisy-channel``: ten times the chip's noise (a bad ground or a long unshielded cable);
- ``loose-gauge``: a gauge glued badly: only 15 % of the strain reaches it;
- ``piezo-unplugged``, ``piezo-clipping``, ``piezo-humming``: the contact microphone's
  cable out, its preamp gain far too high, a ground loop (mains pick-up 40 times normal).

A fault spec is ``NAME`` or ``NAME:CHANNEL`` (``swapped-data:A,B``); :func:`parse_fault`
turns it into a :class:`Fault`. The simavr harness (firmware/sim) takes the strain faults
as its own commands (:func:`simavr_commands`): ``swap``, ``fault``, ``chip``, ``noise``.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ...errors import BadArgumentError

FAULTS: dict[str, str] = {
    "swapped-data": "DOUT lines of two chips swapped (default chips 0 and 1)",
    "reversed-gauge": "a bridge wired reversed, its sign flipped (default channel 2)",
    "open-bridge": "a bridge open (broken gauge lead): input at full scale (default 3)",
    "missing-chip": "a chip that never answers (default chip 1)",
    "stuck-dout": "a chip's DOUT stuck low: always ready, reads 0 (default chip 2)",
    "noisy-channel": "a channel with ten times the noise (default channel 0)",
    "loose-gauge": "a badly glued gauge: 15 % of the strain reaches it (default channel 1)",
    "piezo-unplugged": "the contact microphone's cable out: the card hears nothing",
    "piezo-clipping": "the piezo preamp's gain 40 times too high: taps clip",
    "piezo-humming": "a ground loop: mains hum 40 times the normal pick-up",
}
DEFAULT_CHANNELS: dict[str, tuple[int, ...]] = {
    "swapped-data": (0, 1), "reversed-gauge": (2,), "open-bridge": (3,),
    "missing-chip": (1,), "stuck-dout": (2,), "noisy-channel": (0,), "loose-gauge": (1,),
}
PIEZO_FAULTS = ("piezo-unplugged", "piezo-clipping", "piezo-humming")
NOISE_FACTOR = 10.0
LOOSE_TRANSFER = 0.15
OPEN_BRIDGE_COUNTS = float(1 << 24)
"""Far beyond full scale: the chip saturates at 0x7FFFFF."""
PIEZO_GAIN_FACTOR = 40.0
HUM_FACTOR = 40.0

CountsSource = Callable[[int], Sequence[float]]


@dataclass(frozen=True)
class Fault:
    name: str
    channels: tuple[int, ...] = ()

    def __str__(self) -> str:
        return self.name + (":" + ",".join(map(str, self.channels)) if self.channels else "")

    @property
    def piezo(self) -> bool:
        return self.name in PIEZO_FAULTS


def parse_fault(spec: str, channels: int = 4) -> Fault:
    """``NAME`` or ``NAME:CH`` or ``swapped-data:A,B`` -> :class:`Fault` (ValueError with
    the list of names when unknown)."""
    name, _, chans = spec.strip().partition(":")
    if name not in FAULTS:
        raise BadArgumentError(f"unknown fault {name!r}; known: {', '.join(FAULTS)}")
    if name in PIEZO_FAULTS:
        if chans:
            raise BadArgumentError(f"{name} takes no channel")
        return Fault(name)
    want = 2 if name == "swapped-data" else 1
    try:
        ch = tuple(int(c) for c in chans.split(",")) if chans else DEFAULT_CHANNELS[name]
    except ValueError:
        raise BadArgumentError(f"{spec!r}: channels must be numbers") from None
    if len(ch) != want or len(set(ch)) != want or not all(0 <= c < channels for c in ch):
        raise BadArgumentError(f"{spec!r}: {name} needs {want} distinct channel(s) in "
                               f"0..{channels - 1}")
    return Fault(name, ch)


def parse_faults(specs: Sequence[str], channels: int = 4) -> list[Fault]:
    return [parse_fault(s, channels) for s in specs]


def dead_mask(faults: Sequence[Fault]) -> int:
    """Chips that never become ready (for :attr:`VirtualFirmware.dead_mask`)."""
    return sum(1 << f.channels[0] for f in faults if f.name == "missing-chip")


def loosen(sensor, faults: Sequence[Fault]) -> None:
    """Make the loose gauges of ``faults`` transfer :data:`LOOSE_TRANSFER` of the strain
    (in the sensor's physics: the glue, not the numbers afterwards)."""
    chans = [f.channels[0] for f in faults if f.name == "loose-gauge"]
    if not chans:
        return
    transfer = np.array(sensor.unit.glue_transfer, dtype=float)
    transfer[chans] *= LOOSE_TRANSFER
    sensor.unit = dataclasses.replace(sensor.unit, glue_transfer=transfer)


def wrap_source(source: CountsSource, faults: Sequence[Fault], noise_rms: Sequence[float],
                seed: int = 0) -> CountsSource:
    """The chips' inputs as the faulty wiring presents them to the firmware."""
    chip = [f for f in faults if not f.piezo and f.name not in ("missing-chip", "loose-gauge")]
    if not chip:
        return source
    rng = np.random.default_rng([seed, 17])

    def faulty(t_us: int) -> tuple[float, ...]:
        v = list(source(t_us))
        for f in chip:
            c = f.channels
            if f.name == "swapped-data":
                v[c[0]], v[c[1]] = v[c[1]], v[c[0]]
            elif f.name == "reversed-gauge":
                v[c[0]] = -v[c[0]]
            elif f.name == "open-bridge":
                v[c[0]] = OPEN_BRIDGE_COUNTS + v[c[0]]
            elif f.name == "stuck-dout":
                v[c[0]] = 0.0
            elif f.name == "noisy-channel":
                extra = math.sqrt(NOISE_FACTOR ** 2 - 1) * float(noise_rms[c[0]])
                v[c[0]] += extra * float(rng.standard_normal())
        return tuple(v)

    return faulty


def audio_settings(faults: Sequence[Fault]) -> dict[str, float | bool]:
    """How the piezo faults change the audio chain: ``connected``, ``gain_factor``,
    ``hum_factor``."""
    names = {f.name for f in faults}
    return {"connected": "piezo-unplugged" not in names,
            "gain_factor": PIEZO_GAIN_FACTOR if "piezo-clipping" in names else 1.0,
            "hum_factor": HUM_FACTOR if "piezo-humming" in names else 1.0}


def simavr_commands(faults: Sequence[Fault], noise_counts: float) -> list[str]:
    """The harness commands that build ``faults`` into the simulated HX711s (the piezo is
    not on the Uno: its faults have no command). ``noise_counts``: the chips' normal noise
    rms (the noisy channel gets ten times it). Issue them after the inputs at rest are set:
    a loose gauge scales the input around its value at that moment."""
    out = []
    for f in faults:
        c = f.channels
        if f.name == "swapped-data":
            out.append(f"swap {c[0]} {c[1]}")
        elif f.name == "reversed-gauge":
            out.append(f"fault {c[0]} reversed")
        elif f.name == "open-bridge":
            out.append(f"fault {c[0]} open")
        elif f.name == "loose-gauge":
            out.append(f"fault {c[0]} loose")
        elif f.name == "missing-chip":
            out.append(f"chip {c[0]} absent")
        elif f.name == "stuck-dout":
            out.append(f"chip {c[0]} stuck_low")
        elif f.name == "noisy-channel":
            out.append(f"noise {c[0]} {NOISE_FACTOR * noise_counts:g}")
    return out
