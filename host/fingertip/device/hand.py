"""``Hand``: several fingertips under finger names.

Either one device per finger (four Unos, four sound cards), or one 16-channel device whose
channels are split into fingers. User code sees the same thing both ways: frames tagged with
the finger they belong to, holding only that finger's channels.
"""
from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace

from ..errors import BadArgumentError
from ..protocol import MAX_CHANNELS
from .errors import FingertipError, NotConnected, check_tare_samples
from .fingertip import Fingertip
from .frames import Frame


@dataclass(frozen=True, slots=True)
class FingerFrame:
    finger: str
    frame: Frame


class Hand:
    """Fingertips by finger name. ``fingers`` maps a name to a :class:`Fingertip`, or to
    ``(fingertip, channels)`` when several fingers share one device. ``queue_size=0``: no
    queue of finger frames, for consumers that take them by callback (a publisher, a
    recorder): :meth:`read` and :meth:`frames` then raise, and no overruns are counted for
    frames nobody was going to read."""

    def __init__(self, fingers: Mapping[str, Fingertip | tuple[Fingertip, Sequence[int]]],
                 queue_size: int = 16384) -> None:
        if not fingers:
            raise BadArgumentError("a hand needs at least one finger")
        self._fingers: dict[str, tuple[Fingertip, tuple[int, ...] | None]] = {}
        for name, spec in fingers.items():
            if isinstance(spec, Fingertip):
                self._fingers[name] = (spec, None)
            else:
                dev, chans = spec
                self._fingers[name] = (dev, _channels(name, chans))
        _check_sharing(self._fingers)
        self._devices: list[Fingertip] = []
        for dev, _ in self._fingers.values():
            if dev not in self._devices:
                self._devices.append(dev)
        self._queue: deque[FingerFrame] | None = (deque(maxlen=queue_size) if queue_size
                                                   else None)
        self._cond = threading.Condition()
        self._latest: dict[str, Frame] = {}
        self.overruns = 0
        self._callbacks: list[Callable[[str, Frame], None]] = []
        for dev in self._devices:
            dev.add_callback(self._make_callback(dev))

    @classmethod
    def from_ports(cls, ports: Mapping[str, str], **kw) -> Hand:
        """One device per finger, by port: ``Hand.from_ports({"index": "/dev/ttyACM0"})``."""
        return cls({name: Fingertip(port, name=name, **kw) for name, port in ports.items()})

    @classmethod
    def from_serial_numbers(cls, serials: Mapping[str, str], **kw) -> Hand:
        """One device per finger, by the USB serial number of each Arduino."""
        return cls({name: Fingertip(serial_number=sn, name=name, **kw)
                    for name, sn in serials.items()})

    @classmethod
    def split(cls, device: Fingertip, groups: Mapping[str, Sequence[int]],
              queue_size: int = 16384) -> Hand:
        """One multi-channel device whose channels are split into fingers."""
        return cls({name: (device, chans) for name, chans in groups.items()},
                   queue_size=queue_size)

    @property
    def fingers(self) -> list[str]:
        return list(self._fingers)

    @property
    def devices(self) -> list[Fingertip]:
        """Each device once (a split device serves several fingers)."""
        return list(self._devices)

    def device(self, finger: str) -> Fingertip:
        if finger not in self._fingers:
            raise KeyError(f"no finger named {finger!r} (this hand has "
                           f"{', '.join(self._fingers)})")
        return self._fingers[finger][0]

    def channels_of(self, finger: str) -> tuple[int, ...] | None:
        """The device channels of ``finger`` (None: the whole device is this finger's)."""
        self.device(finger)  # KeyError with the fingers this hand has
        return self._fingers[finger][1]

    def add_callback(self, fn: Callable[[str, Frame], None]) -> None:
        """Call ``fn(finger, frame)`` for every finger frame, on the devices' reader
        threads (keep it short: a recorder's queue, not processing)."""
        with self._cond:
            self._callbacks.append(fn)

    def remove_callback(self, fn: Callable[[str, Frame], None]) -> None:
        with self._cond:
            if fn in self._callbacks:
                self._callbacks.remove(fn)

    def _make_callback(self, dev: Fingertip):
        targets = [(name, chans) for name, (d, chans) in self._fingers.items() if d is dev]

        queue = self._queue

        def on_frame(frame: Frame) -> None:
            with self._cond:
                for name, chans in targets:
                    f = frame if chans is None else _select(frame, chans)
                    if queue is not None:
                        if len(queue) == queue.maxlen:
                            self.overruns += 1
                        queue.append(FingerFrame(name, f))
                    self._latest[name] = f
                    for fn in self._callbacks:
                        fn(name, f)
                self._cond.notify_all()

        return on_frame

    # --- life cycle and commands for all fingers ------------------------------------------

    def open(self) -> Hand:
        opened = []
        try:
            for dev in self._devices:
                dev.open()
                opened.append(dev)
            for name, (dev, chans) in self._fingers.items():
                if chans is not None and max(chans) >= dev.channels:
                    need = max(max(c) for d, c in self._fingers.values()
                               if d is dev and c is not None) + 1
                    raise BadArgumentError(
                        f"finger {name!r} uses channel {max(chans)}, but {dev.name} has "
                        f"{dev.channels} (0..{dev.channels - 1}): this hand needs {need} "
                        f"channels on it (flash the {need}-channel firmware: "
                        f"`fingertip flash --channels {need}`)"
                        if need in (4, 16) else
                        f"finger {name!r} uses channel {max(chans)}, but {dev.name} has "
                        f"{dev.channels} (0..{dev.channels - 1})")
        except BaseException:
            for dev in opened:
                dev.close()
            raise
        return self

    def close(self) -> None:
        for dev in self._devices:
            dev.close()

    def __enter__(self) -> Hand:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self) -> None:
        for dev in self._devices:
            dev.start()

    def stop(self) -> None:
        for dev in self._devices:
            dev.stop()

    def tare(self, samples: int = 16) -> None:
        samples = check_tare_samples(samples)  # before any thread: one clear error
        # Taring all devices in parallel: each waits samples/rate seconds on its own.
        errors: list[BaseException] = []

        def one(dev: Fingertip) -> None:
            try:
                dev.tare(samples=samples)
            except BaseException as e:  # re-raised below, in the caller's thread
                errors.append(e)

        threads = [threading.Thread(target=one, args=(d,)) for d in self._devices]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        if errors:
            raise errors[0]

    @property
    def status(self) -> dict[str, str]:
        return {name: d.status for name, (d, _) in self._fingers.items()}

    # --- frames ---------------------------------------------------------------------------

    def latest(self) -> dict[str, Frame]:
        """The newest frame of each finger seen so far."""
        with self._cond:
            return dict(self._latest)

    def read(self, timeout: float | None = None) -> FingerFrame | None:
        """The next frame of any finger, or None after ``timeout`` seconds without one.
        Raises :class:`NotConnected` when every device is closed and no frame is left."""
        queue = self._queue
        if queue is None:
            raise FingertipError("this hand was made with queue_size=0: its frames go to "
                                 "callbacks only (add_callback), nothing queues them to read")
        with self._cond:
            if not queue:
                self._check_open()
                self._cond.wait(timeout)
            if not queue:
                self._check_open()
            return queue.popleft() if queue else None

    def _check_open(self) -> None:
        if all(d.status == "closed" for d in self._devices):
            raise NotConnected("the hand's devices are closed (or were never opened): "
                               "call open() first (or use `with Hand(...)`)")

    def frames(self, timeout: float | None = None) -> Iterator[FingerFrame]:
        while (f := self.read(timeout)) is not None:
            yield f


def _channels(finger: str, chans: Sequence[int]) -> tuple[int, ...]:
    out = tuple(chans)
    if not out:
        raise BadArgumentError(f"finger {finger!r} has no channels")
    for c in out:
        if isinstance(c, bool) or not isinstance(c, int) or not 0 <= c < MAX_CHANNELS:
            raise BadArgumentError(f"finger {finger!r}: channel {c!r} is not in "
                                   f"0..{MAX_CHANNELS - 1}")
    if len(set(out)) != len(out):
        raise BadArgumentError(f"finger {finger!r} lists a channel twice: {out}")
    return out


def _check_sharing(fingers: Mapping[str, tuple[Fingertip, tuple[int, ...] | None]]) -> None:
    """A device serves one finger whole, or several fingers with disjoint channels."""
    owner: dict[tuple[int, int], str] = {}
    whole: dict[int, str] = {}
    for name, (dev, chans) in fingers.items():
        key = id(dev)
        if chans is None:
            other = whole.get(key) or next((f for (k, _), f in owner.items() if k == key),
                                           None)
            if other is not None:
                raise BadArgumentError(f"fingers {other!r} and {name!r} share one device: give "
                                 f"each its channels (Hand.split)")
            whole[key] = name
            continue
        if key in whole:
            raise BadArgumentError(f"fingers {whole[key]!r} and {name!r} share one device: give "
                             f"each its channels (Hand.split)")
        for c in chans:
            if (key, c) in owner:
                raise BadArgumentError(f"channel {c} is given to both {owner[(key, c)]!r} and "
                                 f"{name!r}")
            owner[(key, c)] = name


def _select(frame: Frame, chans: tuple[int, ...]) -> Frame:
    def bits(mask: int) -> int:
        return sum(1 << i for i, c in enumerate(chans) if mask >> c & 1)

    return replace(frame, counts=tuple(frame.counts[c] for c in chans),
                   timeout_mask=bits(frame.timeout_mask),
                   saturation_mask=bits(frame.saturation_mask))
