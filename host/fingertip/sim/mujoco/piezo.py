"""The piezo as a stream: continuous 44.1 kHz blocks from what the physics steps report.

Each physics step pushes its time, the slip speed, the normal force, the touched material and
whether the nail or the skin carries the contact; contact onsets and releases push impacts.
Audio is rendered in fixed blocks of samples on the sound card's own clock: the step values
are interpolated to each sample's time, so the audio depends on the motion, not on the physics
step. The excitation goes through the virtual fingertip's chain (:class:`AudioChain`: cap
modes, piezo, high-pass, anti-alias; then its preamp, hum, noise, clipping and quantisation),
the linear part as a convolution with the chain's impulse response whose tail carries into the
next block.

Other things the nail presses on can sound too (a held box's contents hitting its walls):
each is a :class:`Path` into the same piezo, its force events and noise heard through that
thing's own modes and low-pass (``AudioChain.response``) and added before the preamp.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from .project import (
    AudioChain,
    FingertipParams,
    Material,
    good_fft_size,
    half_sine,
    material_named,
    place,
    smooth_noise,
)
from .texture import TextureStream

IR_SAMPLES = 4096
"""Impulse response length of the chain (93 ms; its slowest pole, the 80 Hz high-pass, has
decayed by 10^-20 by then)."""
STICK_MM_S = 1.0
"""Slip slower than this is the soft contact's regularisation creep, not sliding: silent."""
SKIN_TRANSMISSION = 0.4
"""A contact on the skin reaches the piezo weaker than one on the nail (the scenes' factor)."""


class BlockConvolver:
    """Block by block convolution with an impulse response of ``IR_SAMPLES`` (overlap-add
    at ``nfft`` points); each block's tail carries into the next."""

    def __init__(self, ir: np.ndarray, nfft: int) -> None:
        self.nfft = nfft
        self._spec = np.fft.rfft(ir, nfft)
        self.tail = np.zeros(len(ir) - 1)

    def block(self, x: np.ndarray, n: int) -> np.ndarray:
        """The ``n`` output samples of input block ``x`` (longer inputs ring into the tail)."""
        v = np.fft.irfft(np.fft.rfft(x, self.nfft) * self._spec, self.nfft)
        v[:len(self.tail)] += self.tail
        self.tail = v[n:n + len(self.tail)].copy()
        return v[:n]


class Path:
    """Force at the nail coming through something it presses on, with that thing's modes
    (``modes``: (Hz, damping, weight)) and low-pass: pulses (:meth:`event`) and a noise whose
    level follows the pushed values (:meth:`noise`), rendered with the stream's blocks."""

    def __init__(self, stream: PiezoStream, lowpass_hz: float | None, modes: tuple = (),
                 noise_corner_hz: float = 4000.0) -> None:
        self.fs = stream.fs
        ir = np.fft.irfft(stream.chain.response(np.fft.rfftfreq(IR_SAMPLES, 1 / self.fs),
                                                lowpass_hz, modes), IR_SAMPLES)
        self._conv = BlockConvolver(ir, stream.nfft)
        self._carry = np.zeros(0)
        self._events: list[tuple[float, float, np.ndarray]] = []
        self._levels: list[tuple[float, float]] = []
        self._rng = stream._path_rng()
        self.corner_hz = noise_corner_hz

    def event(self, t: float, amplitude_n: float, kernel: np.ndarray) -> None:
        """A force ``amplitude_n * kernel`` (kernel at the sound card's rate) from ``t``."""
        self._events.append((t, amplitude_n, kernel))

    def noise(self, t: float, level_n: float) -> None:
        """The noise's rms force at time ``t`` (interpolated between pushes, in time order)."""
        self._levels.append((t, level_n))

    def render(self, k0: int, n: int) -> np.ndarray:
        """Preamp-input volts of samples ``k0 .. k0 + n`` (called once per block, in order)."""
        fs = self.fs
        due = [e for e in self._events if e[0] * fs < k0 + n]
        self._events = [e for e in self._events if e[0] * fs >= k0 + n]
        longest = max([len(self._carry)] + [len(k) for _, _, k in due])
        f = np.zeros(n + longest)
        f[:len(self._carry)] += self._carry
        for t, amp, kern in due:  # an event before this block starts at its start
            f += place(len(f), np.array([max(0.0, t - k0 / fs)]), np.array([amp]), kern, fs)
        self._carry = f[n:].copy()
        f = f[:n]
        if self._levels:
            lt = np.array([v[0] for v in self._levels])
            ts = (k0 + np.arange(n)) / fs
            level = np.interp(ts, lt, [v[1] for v in self._levels], left=0.0, right=0.0)
            if level.any():
                f = f + level * smooth_noise(n, fs, self.corner_hz, self._rng)
            keep = max(0, int(np.searchsorted(lt, (k0 + n) / fs, side="right")) - 1)
            del self._levels[:keep]
        if not f.any() and not self._conv.tail.any():
            return np.zeros(n)
        return self._conv.block(f, n)


@dataclass
class Block:
    """Samples of the piezo (float32, 1.0 = full scale) from simulation time ``t0``."""

    samples: np.ndarray
    t0: float
    fs: int


class PiezoStream:
    """One fingertip's contact microphone, rendered in blocks of ``block`` samples."""

    def __init__(self, params: FingertipParams, seed: int | None = 0, *, block: int = 4096,
                 hum: bool = True, noise: bool = True, default_material: str = "tpu") -> None:
        self.chain = AudioChain(params, hum=hum, noise=noise)
        self.fs = self.chain.fs
        self.block = block
        ss = np.random.SeedSequence(seed)
        self._rng, self._tex_ss = np.random.default_rng(ss.spawn(1)[0]), ss
        nfft = IR_SAMPLES
        self.ir = np.fft.irfft(self.chain.response(np.fft.rfftfreq(nfft, 1 / self.fs)), nfft)
        self.nfft = good_fft_size(block + nfft - 1)
        self._conv = BlockConvolver(self.ir, self.nfft)
        self.default_material = material_named(default_material)
        self._textures: dict[str, TextureStream] = {}
        self._lowpass: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._impact_carry = np.zeros(0)
        self._t: list[float] = []
        self._v: list[float] = []
        self._n: list[float] = []
        self._g: list[float] = []
        self._m: list[Material | None] = []
        self._impacts: list[tuple[float, float, float]] = []
        self.next_sample = 0
        self.blocks: list[Block] = []
        self.paths: list[Path] = []

    def add_path(self, lowpass_hz: float | None, modes: tuple = ()) -> Path:
        """A new :class:`Path` into this piezo (events and noise through other modes)."""
        self.paths.append(Path(self, lowpass_hz, modes))
        return self.paths[-1]

    def _path_rng(self) -> np.random.Generator:
        # Its own stream (not spawned from the textures' sequence: their sounds stay as
        # they were in scenes without paths).
        ss = self._tex_ss
        return np.random.default_rng(np.random.SeedSequence(
            ss.entropy, spawn_key=(*ss.spawn_key, 0xB0C5, len(self.paths))))

    # --- input from the physics steps ------------------------------------------------------

    def push(self, t: float, slip_mm_s: float, normal_n: float, mat: Material | None,
             nail: bool) -> None:
        """The contact state at simulation time ``t`` (s), in time order."""
        self._t.append(t)
        self._v.append(slip_mm_s if slip_mm_s >= STICK_MM_S else 0.0)
        self._n.append(normal_n)
        self._g.append(1.0 if nail else SKIN_TRANSMISSION)
        self._m.append(mat)

    def impact(self, t: float, amplitude_n: float, duration_s: float) -> None:
        """A half-sine force pulse at the nail (contact make: > 0, break: < 0)."""
        self._impacts.append((t, amplitude_n, duration_s))

    # --- rendering -------------------------------------------------------------------------

    def render(self, upto_s: float | None = None) -> list[Block]:
        """Render every whole block the pushed steps cover (up to ``upto_s`` if given: the
        caller may still add impacts before the latest step); returns the new blocks."""
        new: list[Block] = []
        if not self._t:
            return new
        end = self._t[-1] if upto_s is None else min(upto_s, self._t[-1])
        while (self.next_sample + self.block) / self.fs <= end:
            new.append(self._render_block())
        self.blocks.extend(new)
        return new

    def read(self) -> list[Block]:
        """The blocks rendered since the last read."""
        out, self.blocks = self.blocks, []
        return out

    def _texture(self, mat: Material) -> TextureStream:
        tex = self._textures.get(mat.name)
        if tex is None:
            child = self._tex_ss.spawn(1)[0]
            tex = self._textures[mat.name] = TextureStream(
                mat, self.fs, np.random.default_rng(child))
        return tex

    def _soft(self, mat: Material, x: np.ndarray) -> np.ndarray:
        """The material's own low-pass (soft surfaces), two one-pole stages with state."""
        if not mat.lowpass_hz:
            return x
        if mat.name not in self._lowpass:
            a = math.exp(-2 * math.pi * mat.lowpass_hz / self.fs)
            self._lowpass[mat.name] = (np.array([(1 - a) ** 2]), np.array([1, -2 * a, a * a]),
                                       np.zeros(2))
        b, a, zi = self._lowpass[mat.name]
        y, zf = lfilter(b, a, x, zi=zi)
        self._lowpass[mat.name] = (b, a, zf)
        return y

    def _render_block(self) -> Block:
        n, fs, k0 = self.block, self.fs, self.next_sample
        ts = (k0 + np.arange(n)) / fs
        t = np.asarray(self._t)
        speed = np.interp(ts, t, self._v)
        normal = np.interp(ts, t, self._n)
        gain = np.interp(ts, t, self._g)
        step = np.clip(np.searchsorted(t, ts, side="right") - 1, 0, len(t) - 1)
        excite = np.zeros(n)
        for mat in {m.name: m for m in self._m if m is not None}.values():
            own = np.fromiter((m is not None and m.name == mat.name for m in self._m), bool,
                              len(self._m))[step]
            v = np.where(own, speed, 0.0)
            tex = self._texture(mat)
            if v.any() or tex.carry.any():
                excite += self._soft(mat, tex.block(v, normal) * gain)
        excite += self._impact_block(k0, n)
        v_in = self._conv.block(excite, n).copy()
        for path in self.paths:
            v_in += path.render(k0, n)
        out = self.chain.finish(v_in, k0, self._rng).samples
        self.next_sample = k0 + n
        # Keep the last step before the next block: interpolation needs it.
        keep = max(0, int(np.searchsorted(t, (k0 + n) / fs, side="right")) - 1)
        if keep:
            for lst in (self._t, self._v, self._n, self._g, self._m):
                del lst[:keep]
        return Block(out, k0 / fs, fs)

    def _impact_block(self, k0: int, n: int) -> np.ndarray:
        due = [imp for imp in self._impacts if imp[0] * self.fs < k0 + n]
        self._impacts = [imp for imp in self._impacts if imp[0] * self.fs >= k0 + n]
        longest = max([len(self._impact_carry)]
                      + [len(half_sine(d, self.fs)) for _, _, d in due])
        out = np.zeros(n + longest)
        out[:len(self._impact_carry)] += self._impact_carry
        for t, amp, dur in due:  # an onset refined to before this block starts at its start
            out += place(len(out), np.array([max(0.0, t - k0 / self.fs)]), np.array([amp]),
                         half_sine(dur, self.fs), self.fs)
        self._impact_carry = out[n:].copy()
        return out[:n]
