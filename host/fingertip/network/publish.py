"""The ``fingertip publish`` session: fingertips (and their microphones, classifiers and
events) live on the network until Ctrl-C, SIGTERM, the end of a duration or of a replay.

:func:`publish` takes what :mod:`fingertip.network.publish_sources` opened: it declares the
publishers and services, waits for subscribers, attaches every source to the
:class:`~fingertip.network.feed.Feed` (and to a local recording), tares, starts, publishes
reconnects as events, stops and reports what was published. Lines meant for the user go to
``say``; the caller keeps ownership of everything opened and closes it.
"""
from __future__ import annotations

import contextlib
import json
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from ..audio.pcm import to_float
from ..device import FingertipError
from ..device.health import GoneReporter, gone_text, link_text
from ..record.encoding import device_info
from ..record.schemas import AUDIO_ENCODINGS
from .diagnostics import PERIOD_S, Health, encode_diagnostic_array
from .feed import Feed
from .hand import pump_hand_audio
from .stopper import Stopper

log = logging.getLogger("fingertip")


@dataclass
class PublishSettings:
    """How a publish session runs (the options of ``fingertip publish`` that shape it)."""

    transport_name: str = "dds"
    duration: float | None = None
    replay: bool = False
    sim_time: bool = False
    tare: int | None = None
    read_only: bool = False
    service_tare_samples: int = 16
    wait_subscribers: int | None = None
    wait_timeout: float = 10.0
    linger: float = 0.5
    audio_rate: float = 44100.0


def publish(transport: Any, sources: Sequence[Any], names: Sequence[str], *,
            settings: PublishSettings, force_model: Any = None,
            classifiers: Sequence[tuple[str, Any]] = (), audio: Any = None,
            hand_audio: Sequence[tuple[Any, list[str]]] = (), rec: Any = None,
            timebase: Any = None, say: Callable[[str], Any] = log.info) -> None:
    """Publish ``sources`` as ``names`` on ``transport`` until the session ends (see the
    module). ``rec``: a started local recorder that gets the same messages; ``timebase``:
    the host-to-ROS time mapping (a recording's own with --sim-time). Raises the device's
    and the audio's errors when a source cannot be tared or started."""
    feed = Feed(transport, timebase=timebase)
    try:
        _run(feed, transport, sources, names, settings, force_model, classifiers, audio,
             hand_audio, rec, say)
    finally:
        feed.close()


def _run(feed: Feed, transport: Any, sources: Sequence[Any], names: Sequence[str],
         settings: PublishSettings, force_model: Any, classifiers: Sequence[tuple[str, Any]],
         audio: Any, hand_audio: Sequence[tuple[Any, list[str]]], rec: Any,
         say: Callable[[str], Any]) -> None:
    s = settings
    # Publishers first, so that subscribers can find them.
    for src, name in zip(sources, names, strict=True):
        feed.add_fingertip(name, force_model, device_info(src, name))
    _serve_services(s, transport, feed, rec, sources, names)
    if audio is not None and hasattr(transport, "declare_audio"):
        transport.declare_audio(names[0], audio.sample_rate, audio.channels,
                                AUDIO_ENCODINGS[audio.dtype.name])
    if s.replay and s.sim_time and hasattr(transport, "declare_clock"):
        transport.declare_clock()
    _wait_subscribers(s, transport)
    for src, name in zip(sources, names, strict=True):
        feed.attach(src, name, force_model)
        if rec is not None:
            rec.attach(src, name, force_model=force_model)
    if s.replay:
        _replay_extras(s, sources[0], names[0], feed, transport, force_model)
    for src, name in zip(sources, names, strict=True):
        if s.tare and hasattr(src, "tare"):
            offsets = src.tare(samples=s.tare)
            _event(feed, rec, name, "tare", float(s.tare), json.dumps(list(offsets)))
    if audio is not None:
        feed.pump_audio(audio, names[0], also=_audio_consumers(
            feed, rec, names[0], classifiers, audio.sample_rate))
    pump_hand_audio(feed, transport, hand_audio, also=_audio_consumers(
        feed, rec, "", [], s.audio_rate))
    for src, name in zip(sources, names, strict=True):
        src.start()
        if not s.replay:  # a replay publishes the events it recorded
            _event(feed, rec, name, "start")
    say(f"publishing {', '.join(names)} over {s.transport_name}"
        + (f" for {s.duration:g} s" if s.duration else " (Ctrl-C to stop)"))
    reconnects = {n: getattr(src.stats, "reconnects", 0)
                  for src, n in zip(sources, names, strict=True)}
    health = Diagnostics(feed, transport, sources, names)
    gone = GoneReporter()
    with Stopper(s.duration) as stopper:
        while stopper.wait():
            if s.replay and sources[0].ended:
                break
            health.tick(time.monotonic())
            for src, name in zip(sources, names, strict=True):
                dev = getattr(src, "device", src)  # a hand's finger: its device
                gone.check(name, getattr(dev, "gone_s", None), getattr(dev, "port", ""))
                r = getattr(src.stats, "reconnects", 0)
                if r != reconnects[name]:
                    reconnects[name] = r
                    _event(feed, rec, name, "reconnect", float(r))
    health.close()
    for src, name in zip(sources, names, strict=True):
        with contextlib.suppress(FingertipError):
            src.stop()
        if not s.replay:
            _event(feed, rec, name, "stop")
    for a in [audio] + [src for src, _ in hand_audio]:
        if a is not None:
            a.stop()
    feed.close()
    time.sleep(s.linger)  # reliable messages still in flight reach their readers
    say(summary_line(feed, transport))
    for src, name in zip(sources, names, strict=True):
        if not s.replay and hasattr(src, "stats"):  # a device's link (a replay has none)
            dev = getattr(src, "device", src)
            say(f"{name}: {link_text(src.stats)}"
                + gone_text("the device", getattr(dev, "gone_s", None)))


class Diagnostics:
    """``/diagnostics`` once a :data:`~.diagnostics.PERIOD_S`, one status per fingertip,
    on transports that carry it (DDS, Zenoh; not LSL)."""

    def __init__(self, feed: Feed, transport: Any, sources: Sequence[Any],
                 names: Sequence[str]) -> None:
        self.feed = feed
        self._publish = getattr(transport, "publish_diagnostics", None)
        self._healths = [(src, Health(src, name)) for src, name in zip(sources, names,
                                                                        strict=True)]
        self._next = 0.0
        if self._publish is not None:
            for src, h in self._healths:
                src.add_callback(h.on_frame)

    def tick(self, now: float) -> None:
        if self._publish is None or now < self._next:
            return
        self._next = now + PERIOD_S
        statuses = [h.update(now, audio_overruns_frames=self.feed.audio_lost[h.name])
                    for _, h in self._healths]
        try:
            self._publish(encode_diagnostic_array(self.feed.timebase.to_ns(now), statuses))
        except Exception as e:  # a network hiccup must not end the session
            log.debug("publishing /diagnostics failed: %s", e)

    def close(self) -> None:
        if self._publish is not None:
            for src, h in self._healths:
                with contextlib.suppress(ValueError):
                    src.remove_callback(h.on_frame)


def _replay_extras(s: PublishSettings, rp: Any, name: str, feed: Feed, transport: Any,
                   force_model: Any) -> None:
    """A replay also publishes its recorded forces (unless a force model recomputes them),
    events and audio; with --sim-time, /clock follows the recording's time."""
    if force_model is None:
        rp.add_wrench_callback(lambda w: feed.wrench(name, w.host_time, w.force, w.torque))
    rp.add_event_callback(lambda e: feed.event(name, e.kind, e.value, host_time=e.time,
                                               detail=e.detail))
    from ..record.reader import RecordingError

    try:
        audio = rp.audio()
    except RecordingError:  # a recording without audio
        audio = None
    if audio is not None:
        feed.pump_audio(audio, name)
    if s.sim_time:
        clock = getattr(transport, "publish_clock", None)
        if clock is None:
            log.warning("--sim-time: this transport has no /clock; stamps are the "
                        "recording's")
        else:
            rp.add_callback(lambda f: clock(feed.timebase.to_ns(f.host_time)))


def _audio_consumers(feed: Feed, rec: Any, name: str, classifiers: Sequence[tuple[str, Any]],
                     sample_rate: float) -> Callable[[str, Any], None] | None:
    """What else each audio chunk feeds: the local recording, the classifiers (whose
    predictions are published as ``material`` / ``shake`` events)."""
    lives = [(kind, clf.live(sample_rate)) for kind, clf in classifiers]
    if rec is None and not lives:
        return None

    def consume(_name: str, chunk: Any) -> None:
        if rec is not None:
            rec.write_audio(_name, chunk)
        if not lives:
            return
        x = to_float(chunk.samples[:, 0])
        for kind, live in lives:
            for p in live.feed(x, chunk.first_index, chunk):
                _prediction_event(feed, rec, name, kind, p)
    return consume


def _prediction_event(feed: Feed, rec: Any, name: str, kind: str, p: Any) -> None:
    """A classifier's prediction: value = its probability, detail = the prediction (JSON)."""
    detail = json.dumps(p.to_dict())
    t = p.host_time if p.host_time is not None else time.monotonic()
    if kind == "shake":
        feed.event(name, "shake", p.probability, host_time=t, detail=detail)
    else:
        feed.event(name, "material", p.probability, host_time=t, detail=detail)
    if rec is not None:
        rec.write_event(name, kind, p.probability, host_time=t, detail=detail)


def _event(feed: Feed, rec: Any, name: str, kind: str, value: float = 0.0,
           detail: str = "") -> None:
    """An event on the network and, when recording locally too, in the file (same time)."""
    t = time.monotonic()
    feed.event(name, kind, value, host_time=t, detail=detail)
    if rec is not None:
        rec.write_event(name, kind, value, host_time=t, detail=detail)


def _serve_services(s: PublishSettings, transport: Any, feed: Feed, rec: Any,
                    sources: Sequence[Any], names: Sequence[str]) -> None:
    """Tare services, unless read-only (then nothing on the network changes the device)."""
    if s.read_only or not hasattr(transport, "serve_tare"):
        return
    for src, name in zip(sources, names, strict=True):
        if not hasattr(src, "tare"):
            continue  # a replay has nothing to tare

        def tare(_src=src, _name=name) -> tuple[bool, str]:
            offsets = _src.tare(samples=s.service_tare_samples)
            _event(feed, rec, _name, "tare", float(s.service_tare_samples),
                   json.dumps(list(offsets)))
            return True, "tare offsets: " + ", ".join(map(str, offsets))
        transport.serve_tare(name, tare)


def _wait_subscribers(s: PublishSettings, transport: Any) -> None:
    if not s.wait_subscribers:
        return
    wait = getattr(transport, "wait_subscribers", None)
    if wait is None:
        return
    if not wait(s.wait_subscribers, timeout=s.wait_timeout):
        log.warning("only some of the %d subscribers expected came within %g s: publishing "
                    "anyway", s.wait_subscribers, s.wait_timeout)


def summary_line(feed: Feed, transport: Any) -> str:
    """What was published, per kind, with the errors and the services' requests."""
    pub = sum(feed.published.values())
    errs = dict(feed.errors)
    parts = ", ".join(f"{k} {v}" for k, v in sorted(feed.published.items()))
    line = f"published {pub} messages ({parts})"
    if errs:
        line += f"; errors {errs}"
    for service, st in getattr(transport, "services", {}).items():
        line += f"; {service}: {st.text()}"
    return line
