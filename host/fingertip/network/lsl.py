"""Lab Streaming Layer: outlets per fingertip, so LabRecorder records it beside EEG, EMG and
motion capture with LSL's clock synchronisation.

Per fingertip ``<name>`` (stream names ``fingertip/<name>/<kind>``, source id
``fingertip-<name>-<kind>``):

- ``forces`` (type ``Force``): fx, fy, fz in newtons, one sample per frame;
- ``raw`` (type ``StrainCounts``): the channels' counts, then seq, device_time_us,
  arrival - stamp (s), timeout_mask, saturation_mask (double precision: every integer exact);
- ``audio`` (type ``Audio``): the microphone at its true rate, made at its first chunk;
- ``events`` (type ``Markers``, irregular, string): ``{"kind", "value", "detail"}`` JSON.

Timestamps are the stamps of the ROS messages in host monotonic seconds, which is LSL's own
``local_clock()`` on Linux (both CLOCK_MONOTONIC), so LSL's time correction maps them to the
receiver's clock. The device information goes into each stream's XML description.
"""
from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable

import numpy as np

from ..record import schemas as S
from ..record.timebase import NS, TimeBase
from . import require

log = logging.getLogger(__name__)

RAW_EXTRA = ("seq", "device_time_us", "arrival_minus_stamp_s", "timeout_mask",
             "saturation_mask")
AUDIO_FORMATS = {"S16LE": "int16", "S32LE": "int32", "F32LE": "float32"}


def stream_name(name: str, kind: str) -> str:
    return f"fingertip/{name}/{kind}"


class LslTransport:
    """The feed's transport over LSL (``pylsl``, the ``lsl`` extra)."""

    def __init__(self, timebase: TimeBase | None = None, channels: int = 4) -> None:
        self.lsl = require("pylsl", "Lab Streaming Layer (--transport lsl)")
        self.channels = channels
        self._outlets: dict[tuple[str, str], object] = {}
        self._info: dict[str, str] = {}
        self._lock = threading.Lock()
        self.timebase = timebase

    def _outlet(self, name: str, kind: str, stype: str, labels: list[str], units: str,
                rate: float, fmt: str):
        lsl = self.lsl
        info = lsl.StreamInfo(stream_name(name, kind), stype, len(labels), rate, fmt,
                              f"fingertip-{name}-{kind}")
        chans = info.desc().append_child("channels")
        for label in labels:
            ch = chans.append_child("channel")
            ch.append_child_value("label", label)
            ch.append_child_value("unit", units)
        info.desc().append_child_value("fingertip", self._info.get(name, "{}"))
        return lsl.StreamOutlet(info, 0, 360)

    def add_fingertip(self, name: str, info: dict | None = None) -> None:
        """Outlets for fingertip ``name``. With ``info`` (:func:`device_info`), forces and
        raw counts are regular streams at the device's frame rate with its channel count,
        and the description carries the device information; without, irregular."""
        lsl = self.lsl
        channels, rate = self.channels, lsl.IRREGULAR_RATE
        if info is not None:
            self._info[name] = json.dumps(info, default=str)
            dev = info.get("info") or {}
            channels = int(dev.get("channels") or channels)
            if dev.get("rate_sps"):
                rate = float(dev["rate_sps"]) / max(1, int(dev.get("decimation") or 1))
        counts = [f"ch{i}" for i in range(channels)]
        self._outlets[name, "wrench"] = self._outlet(
            name, "forces", "Force", ["fx", "fy", "fz"], "newtons", rate, "double64")
        self._outlets[name, "raw"] = self._outlet(
            name, "raw", "StrainCounts", counts + list(RAW_EXTRA), "counts", rate,
            "double64")
        self._outlets[name, "events"] = self._outlet(
            name, "events", "Markers", ["event"], "json", lsl.IRREGULAR_RATE, "string")

    def _t(self, stamp_ns: int) -> float:
        """A message stamp -> LSL time (host monotonic seconds)."""
        if self.timebase is None:
            self.timebase = TimeBase.measure()
        return self.timebase.to_monotonic(stamp_ns)

    def declare_audio(self, name: str, sample_rate: float, channels: int, encoding: str
                      ) -> None:
        """Make the audio outlet now, so inlets can connect before the first chunk."""
        with self._lock:
            if (name, "audio") not in self._outlets:
                self._outlets[name, "audio"] = self._outlet(
                    name, "audio", "Audio", [f"piezo{i}" for i in range(channels)],
                    "full scale", sample_rate, AUDIO_FORMATS[encoding])

    def wait_subscribers(self, n: int, timeout: float) -> bool:
        """Wait until every outlet has a consumer (LSL does not count them)."""
        deadline = time.monotonic() + timeout
        for out in list(self._outlets.values()):
            if not out.wait_for_consumers(max(0.0, deadline - time.monotonic())):
                return False
        return True

    def publish(self, name: str, kind: str, msg) -> None:
        if kind == "info":
            self._info[name] = msg
            return
        if kind == "audio":
            self.declare_audio(name, msg.sample_rate, msg.channels, msg.encoding)
            out = self._outlets[name, "audio"]
            x = np.frombuffer(msg.data, dtype=np.dtype(AUDIO_FORMATS[msg.encoding])
                              .newbyteorder("<")).reshape(-1, msg.channels)
            last = self._t(msg.stamp_ns) + (msg.frames - 1) / msg.sample_rate
            out.push_chunk(x.astype(x.dtype.newbyteorder("="), copy=False), last)
            return
        out = self._outlets[name, kind]
        t = self._t(msg.stamp_ns)
        if kind == "wrench":
            out.push_sample(list(msg.force), t)
        elif kind == "raw":
            out.push_sample([*msg.counts, msg.seq, msg.device_time_us,
                             (msg.arrival_ns - msg.stamp_ns) / NS, msg.timeout_mask,
                             msg.saturation_mask], t)
        elif kind == "events":
            out.push_sample([json.dumps({"kind": msg.kind, "value": msg.value,
                                         "detail": msg.detail})], t)

    def close(self) -> None:
        self._outlets.clear()


class LslReceiver:
    """Inlets for fingertips ``names``; each sample re-encoded as the ROS 2 message a local
    recording holds and handed to ``on_message(name, kind, cdr_bytes)``."""

    def __init__(self, names: list[str], on_message: Callable[[str, str, bytes], None],
                 timebase: TimeBase | None = None) -> None:
        self.lsl = require("pylsl", "Lab Streaming Layer (--from lsl)")
        self.names = names
        self.on_message = on_message
        self.timebase = timebase or TimeBase.measure()
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._run, args=(n, k), daemon=True,
                                          name=f"lsl-{n}-{k}")
                         for n in names for k in ("raw", "forces", "events", "audio")]
        for t in self._threads:
            t.start()

    def _run(self, name: str, kind: str) -> None:
        lsl = self.lsl
        while not self._stop.is_set():
            found = lsl.resolve_byprop("name", stream_name(name, kind), 1, 1.0)
            if found:
                break
        else:
            return
        inlet = lsl.StreamInlet(found[0], max_buflen=360, recover=True,
                                processing_flags=lsl.proc_clocksync)
        # The first clock offset takes about half a second: take it before the data
        # connection opens (the publisher may be waiting for it to start streaming), so
        # that the first samples do not wait it out.
        from pylsl.util import TimeoutError as LslTimeout

        try:
            inlet.time_correction(timeout=5.0)
        except LslTimeout:
            log.warning("%s: no clock offset from the outlet yet", stream_name(name, kind))
        inlet.open_stream(timeout=10.0)
        info = inlet.info()
        rate, nch = info.nominal_srate(), info.channel_count()
        audio_fmt = {lsl.cf_int16: "S16LE", lsl.cf_int32: "S32LE",
                     lsl.cf_float32: "F32LE"}.get(info.channel_format(), "F32LE")
        first_index = 0
        while not self._stop.is_set():
            if kind == "audio":
                samples, stamps = inlet.pull_chunk(timeout=0.1)
            else:  # one at a time: pull_chunk would wait out its timeout, adding latency
                sample, stamp = inlet.pull_sample(timeout=0.1)
                samples, stamps = ([sample], [stamp]) if sample is not None else ([], [])
            if not stamps:
                continue
            if kind == "audio":
                x = np.asarray(samples, dtype=np.dtype(AUDIO_FORMATS[audio_fmt]))
                ns = self.timebase.to_ns(stamps[0])
                self.on_message(name, "audio", S.encode_audio(S.AudioMsg(
                    ns, name, first_index, len(stamps), nch, rate, rate, 0, audio_fmt,
                    x.astype(x.dtype.newbyteorder("<")).tobytes())))
                first_index += len(stamps)
                continue
            for v, t in zip(samples, stamps, strict=True):
                ns = self.timebase.to_ns(t)
                if kind == "forces":
                    data = S.encode_wrench(S.WrenchMsg(ns, name, (v[0], v[1], v[2])))
                    self.on_message(name, "wrench", data)
                elif kind == "raw":
                    c = len(v) - len(RAW_EXTRA)
                    seq, dev_us, arr, tmask, smask = v[c:]
                    self.on_message(name, "raw", S.encode_raw(S.RawMsg(
                        ns, name, int(seq), int(dev_us), ns + round(arr * NS),
                        tuple(int(x) for x in v[:c]), int(tmask), int(smask))))
                else:
                    e = json.loads(v[0])
                    self.on_message(name, "events", S.encode_event(S.EventMsg(
                        ns, name, e["kind"], float(e["value"]), e["detail"])))

    def close(self) -> None:
        self._stop.set()
        for t in self._threads:
            t.join(timeout=2)
