"""``Feed``: a fingertip's frames, forces, audio and events, as the messages a recording
holds, handed to a network transport the moment they exist.

The messages are built by the recorder's own functions (:func:`frame_message`,
:func:`audio_payload`, :mod:`fingertip.record.schemas`), so a subscriber receives what a
local recording of the same run stores. Frames are published on the fingertip's reader
thread (no queue: the latency is the transport's), audio on a pump thread per stream.
A transport failing on one message is counted, never raised into the device's thread.
"""
from __future__ import annotations

import json
import logging
import threading
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, Protocol

import numpy as np

from ..audio import AudioSource, Chunk
from ..device import Frame
from ..record import schemas as S
from ..record.encoding import audio_payload, device_info, frame_message, xyz
from ..record.timebase import TimeBase

log = logging.getLogger(__name__)

ForceModel = Callable[[Sequence[int]], Sequence[float]]


class Transport(Protocol):
    """Where a feed's messages go (DDS, Zenoh, LSL...)."""

    def add_fingertip(self, name: str, info: dict[str, Any] | None = None) -> None:
        """Declare fingertip ``name`` (its publishers are made here); ``info``: what its
        ``info`` topic will say (:func:`device_info`), for transports that describe a
        stream up front (LSL: channels, rate), None when unknown."""

    def publish(self, name: str, kind: str, msg: Any) -> None:
        """Publish ``msg`` (a :mod:`~fingertip.record.schemas` message object, or the info
        text) on ``/fingertip/<name>/<kind>``."""

    def close(self) -> None: ...


ENCODERS: dict[str, Callable[[Any], bytes]] = {
    "raw": S.encode_raw, "wrench": S.encode_wrench, "audio": S.encode_audio,
    "events": S.encode_event, "info": S.encode_string,
}
"""Topic kind -> the recorder's CDR encoder of its message object."""


class Feed:
    """Publish fingertips through ``transport``; ``timebase`` maps host monotonic time to
    the Unix-epoch stamps (default: measured now, as a recorder does)."""

    def __init__(self, transport: Transport, timebase: TimeBase | None = None) -> None:
        self.transport = transport
        self.timebase = timebase or TimeBase.measure()
        if hasattr(transport, "timebase"):  # LSL stamps: the same clock mapping as ours
            transport.timebase = self.timebase
        self._counts: Counter[tuple[str, str]] = Counter()
        self.errors: Counter[str] = Counter()
        self.audio_lost: Counter[str] = Counter()
        """Fingertip -> audio frames its microphone lost (the chunks' ``lost_before``)."""
        self._lock = threading.Lock()
        self._models: dict[str, ForceModel | None] = {}
        self._forces: dict[str, Callable[[Sequence[int]], tuple[float, float, float]]] = {}
        self._detach: list[Callable[[], None]] = []
        self._pumps: list[threading.Thread] = []
        self._stop = threading.Event()
        self._told: set[str] = set()

    def add_fingertip(self, name: str, force_model: ForceModel | None = None,
                      info: dict[str, Any] | None = None) -> None:
        """Declare fingertip ``name``; ``info`` (:func:`device_info` of its source) lets
        the transport describe its streams before the first frame."""
        S.check_name(name)
        if name in self._models:
            raise ValueError(f"a fingertip named {name!r} is already published")
        self._set_model(name, force_model)
        self.transport.add_fingertip(name, info)

    def _set_model(self, name: str, model: ForceModel | None) -> None:
        self._models[name] = model
        if model is None:
            self._forces.pop(name, None)
            return
        # A ForceModel hands over Python floats directly; any other callable's output is
        # converted per frame.
        fast = getattr(model, "estimate_xyz", None)
        self._forces[name] = fast if callable(fast) else (lambda counts: xyz(model(counts)))

    def attach(self, fingertip: Any, name: str, force_model: ForceModel | None = None) -> None:
        """Publish every frame of ``fingertip`` (a Fingertip, a Replay: any frame source
        with callbacks), its info now, and forces if a model is given."""
        info = device_info(fingertip, name)
        if name not in self._models:  # not declared beforehand with add_fingertip
            self.add_fingertip(name, force_model, info)
        self._set_model(name, force_model)
        self.info(name, info)

        def on_frame(frame: Frame, _n: str = name) -> None:
            self.frame(_n, frame)
        fingertip.add_callback(on_frame)
        self._detach.append(lambda: fingertip.remove_callback(on_frame))

    # --- messages ----------------------------------------------------------------------------

    def _send(self, name: str, kind: str, msg: Any) -> None:
        try:
            self.transport.publish(name, kind, msg)
        except Exception as e:  # a network hiccup must not reach the device's thread
            with self._lock:
                self.errors[kind] += 1
            self._tell_once(f"{kind}-{name}", "%s %s: publishing failed (%s)", name, kind, e)
        else:
            with self._lock:  # several threads publish (readers, audio pump, services)
                self._counts[name, kind] += 1

    @property
    def published(self) -> Counter[str]:
        """Messages published so far, per topic name."""
        with self._lock:
            return Counter({S.topic(n, k): c for (n, k), c in self._counts.items() if c})

    def frame(self, name: str, frame: Frame) -> None:
        raw = frame_message(name, frame, self.timebase)
        self._send(name, "raw", raw)
        force_of = self._forces.get(name)
        if force_of is None:
            return
        try:
            force = force_of(frame.counts)
        except Exception as e:  # one frame the model cannot take: count it, go on
            with self._lock:
                self.errors["force_model"] += 1
            self._tell_once(f"model-{name}", "%s: force model failed (%s)", name, e)
            return
        self._send(name, "wrench", S.WrenchMsg(raw.stamp_ns, name, force))

    def wrench(self, name: str, host_time: float, force: Sequence[float],
               torque: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        self._send(name, "wrench", S.WrenchMsg(self.timebase.to_ns(host_time), name,
                                               xyz(force), xyz(torque)))

    def audio(self, name: str, chunk: Chunk) -> None:
        payload = audio_payload(chunk.samples)
        if payload is None:
            with self._lock:
                self.errors["audio"] += 1
            self._tell_once(f"audio-{name}", "%s: audio of this dtype cannot be published", name)
            return
        encoding, data = payload
        if chunk.lost_before:
            with self._lock:
                self.audio_lost[name] += chunk.lost_before
        self._send(name, "audio", S.AudioMsg(
            self.timebase.to_ns(chunk.host_time), name, chunk.first_index, chunk.frames,
            chunk.channels, float(chunk.sample_rate), float(chunk.host_rate),
            chunk.lost_before, encoding, data))

    def event(self, name: str, kind: str, value: float = 0.0, *,
              host_time: float | None = None, detail: str = "") -> None:
        t = time.monotonic() if host_time is None else host_time
        self._send(name, "events", S.EventMsg(self.timebase.to_ns(t), name, str(kind),
                                              float(value), str(detail)))

    def info(self, name: str, info: Any) -> None:
        self._send(name, "info", info if isinstance(info, str) else json.dumps(info, default=str))

    def pump_audio(self, source: AudioSource, name: str, max_seconds: float = 0.1,
                   also: Callable[[str, Chunk], Any] | None = None,
                   min_seconds: float = 0.02) -> threading.Thread:
        """Read ``source`` on a thread and publish its chunks until :meth:`close` (and hand
        each to ``also(name, chunk)``, e.g. a local recorder's ``write_audio``).

        Chunks hold at least ``min_seconds`` of audio while the source runs: a sound card
        delivers blocks of a few ms, and each message costs the same wake-up, encoding and
        write whatever its length (rmw and audio_common users take 20 ms chunks in their
        stride). It adds at most ``min_seconds`` to the audio's latency; sample indices and
        host times are those of the card either way."""
        return self.pump_audio_split(source, [name], max_seconds, also, split=False,
                                     min_seconds=min_seconds)

    def pump_audio_split(self, source: AudioSource, names: Sequence[str],
                         max_seconds: float = 0.1,
                         also: Callable[[str, Chunk], Any] | None = None, *,
                         split: bool = True, min_seconds: float = 0.02) -> threading.Thread:
        """As :meth:`pump_audio` for a multi-channel source whose channel k is the
        microphone of fingertip ``names[k]`` (one 4-input interface for a hand): each
        channel is published on its own fingertip's audio topic."""
        if split and source.channels < len(names):
            raise ValueError(f"{source.name} has {source.channels} channel(s) for "
                             f"{len(names)} fingertips")
        if not source.running and not source.finished:
            source.start()
        max_frames = max(1, int(source.sample_rate * max_seconds))
        min_s = max(0.0, min(min_seconds, max_seconds))
        min_frames = int(source.sample_rate * min_s)

        def deliver(name: str, chunk: Chunk) -> None:
            self.audio(name, chunk)
            if also is not None:
                also(name, chunk)

        def publish(chunk: Chunk) -> None:
            if not split:
                deliver(names[0], chunk)
            else:
                for k, name in enumerate(names):
                    deliver(name, replace(chunk, samples=chunk.samples[:, k:k + 1]))

        def wait_for(chunk: Chunk, index: int) -> None:
            # Until frame ``index`` has been captured (plus a moment for the card to hand
            # over its block); never longer than min_s, whatever clock a replayed chunk's
            # times are on.
            due = chunk.time_of(index) + 0.002
            self._stop.wait(min(min_s, max(0.0, due - time.monotonic())))

        def pump() -> None:
            held: Chunk | None = None  # read, short of min_frames, waiting for the rest
            held_until = 0.0
            try:
                while not self._stop.is_set():
                    wait = 0.05 if held is None else min(0.05, held_until - time.monotonic())
                    chunk = source.read(max_frames, timeout=max(0.0, wait))
                    if chunk is None:
                        if source.finished:
                            break
                        if held is not None and time.monotonic() >= held_until:
                            publish(held)
                            held = None
                        continue
                    if held is not None:
                        joined = _joined(held, chunk, max_frames)
                        if joined is None:
                            publish(held)
                        else:
                            chunk = joined
                        held = None
                    if min_frames and source.running:
                        # A card handed its block over late (a busy host): the rest of
                        # min_frames is due soon, so hold this part for up to min_s.
                        if chunk.frames < min_frames:
                            held, held_until = chunk, time.monotonic() + min_s
                            wait_for(chunk, chunk.first_index + min_frames)
                            continue
                        publish(chunk)
                        wait_for(chunk, chunk.end_index + min_frames)
                    else:
                        publish(chunk)
                if held is not None:  # read from the card: published, never dropped
                    publish(held)
            except Exception as e:  # a broken sound card is an event, not a dead publisher
                log.error("audio %s: %s", ", ".join(names), e)
                for name in names:
                    self.event(name, "audio_error", detail=str(e))

        t = threading.Thread(target=pump, daemon=True, name=f"feed-audio-{names[0]}")
        self._pumps.append(t)
        t.start()
        return t

    def close(self) -> None:
        """Stop the pumps, detach from the sources; the transport is the caller's."""
        for d in self._detach:
            try:
                d()
            except ValueError:
                pass
        self._detach.clear()
        self._stop.set()
        for t in self._pumps:
            t.join(timeout=1.0)

    def _tell_once(self, key: str, msg: str, *args: Any) -> None:
        if key not in self._told:
            self._told.add(key)
            log.warning(msg, *args)


def _joined(a: Chunk, b: Chunk, max_frames: int) -> Chunk | None:
    """``a`` then ``b`` as one chunk, when ``b`` follows on without a gap and both fit."""
    if (b.first_index != a.end_index or b.lost_before or a.channels != b.channels
            or a.frames + b.frames > max_frames):
        return None
    return replace(a, samples=np.concatenate([a.samples, b.samples]))
