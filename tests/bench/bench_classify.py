"""Vibration classifiers on the virtual fingertip: accuracy, and what it costs.

- Material: the paper's seven materials, 100 slides each (16 mm at 10-40 mm/s, 0.5-2 N:
  `fingertip sim dataset vibration --kind materials`), 44.1 kHz; 5-fold cross-validation by
  recording (every slide tested once by a model that never saw it); the same slides at
  8 kHz for robustness.
- Shake: the paper's protocol, 20 shakes of 5.6 s per class (screws, rubber bands, empty),
  one split by recording (15 held-out shakes), CNN and MLP on the same split, majority vote
  over 10 Hz predictions. Then a harder set where the two can differ: 30 shakes per class
  with a lighter grip (0.5-2 N), random background rumble and 8 kHz recordings.
- STFT: our strided numpy/scipy.fft STFT against scipy.signal.ShortTimeFFT on the same
  frames (2048-sample Hann windows every 512 samples on 1 s of 44.1 kHz audio), same run.

Latencies are p50 over repeated single predictions with onnxruntime on one thread.
"""
from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

SEED = 0


def _pin() -> None:
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass


def _write_dataset(out: Path, kind: str, n: int, seed: int) -> None:
    try:
        from fingertip.sim.dataset import write_vibration
    except ImportError:  # the dataset writer is optional here: same scenes, by hand
        _write_by_hand(out, kind, n, seed)
        return
    write_vibration(out, kind=kind, recordings_per_class=n, seed=seed, progress=False)


def _write_by_hand(out: Path, kind: str, n: int, seed: int) -> None:
    import soundfile as sf

    from fingertip.sim.physics import BOX_CONTENTS, PAPER_SEVEN, BoxShake, Slide, simulate

    classes = PAPER_SEVEN if kind == "materials" else BOX_CONTENTS
    for ci, c in enumerate(classes):
        (out / c).mkdir(parents=True, exist_ok=True)
        for k in range(n):
            rng = np.random.default_rng([seed, ci, k])
            if kind == "materials":
                speed = float(np.exp(rng.uniform(np.log(10), np.log(40))))
                normal = float(np.exp(rng.uniform(np.log(0.5), np.log(2))))
                scene = Slide(c, speed_mm_s=speed, normal_n=normal, duration=16 / speed,
                              seed=int(rng.integers(1 << 30)))
            else:
                scene = BoxShake(c, grip_n=float(rng.uniform(1, 2)),
                                 seed=int(rng.integers(1 << 30)))
            x = simulate(scene, seed=k).audio.samples
            sf.write(out / c / f"{c}_{k:04d}.wav", x, 44100, subtype="PCM_16")


def _resampled_copy(src: Path, dst: Path, rate: int) -> None:
    import soundfile as sf
    from scipy.signal import resample_poly

    for f in sorted(src.glob("*/*.wav")):
        x, fs = sf.read(f, dtype="float64")
        (dst / f.parent.name).mkdir(parents=True, exist_ok=True)
        sf.write(dst / f.parent.name / f.name, resample_poly(x, rate, fs), rate,
                 subtype="PCM_16")


def _write_hard_shakes(out: Path, n: int, seed: int) -> None:
    """Lighter grip, background rumble (a random level, the same for every class), 8 kHz."""
    import soundfile as sf
    from scipy.signal import lfilter, resample_poly

    from fingertip.sim.physics import BOX_CONTENTS, BoxShake, simulate

    for ci, c in enumerate(BOX_CONTENTS):
        (out / c).mkdir(parents=True, exist_ok=True)
        for k in range(n):
            rng = np.random.default_rng([seed, 99, ci, k])
            scene = BoxShake(c, grip_n=float(rng.uniform(0.5, 2.0)),
                             seed=int(rng.integers(1 << 30)))
            x = simulate(scene, seed=k).audio.samples.astype(np.float64)
            rumble = lfilter([1.0], [1.0, -0.98], rng.normal(size=len(x)))
            x += rumble / rumble.std() * 0.002 * 10 ** (rng.uniform(0, 20) / 20)
            sf.write(out / c / f"{c}_{k:04d}.wav", resample_poly(x, 80, 441), 8000,
                     subtype="FLOAT")


def _stft_speed() -> dict[str, float]:
    from scipy.signal import ShortTimeFFT
    from scipy.signal.windows import hann

    from fingertip.models.vibration.features import FeatureConfig
    from fingertip.models.vibration.spectrogram import Spectrogrammer, Stft

    fs = 44100
    x = np.random.default_rng(1).normal(0, 0.1, fs).astype(np.float32)
    cfg = FeatureConfig(canonical_rate=48000, win_s=2048 / fs, hop_s=512 / fs).for_rates([fs])
    ours = Stft(fs, cfg, np.float32)
    assert ours.win == 2048 and ours.hop == 512
    sft = ShortTimeFFT(hann(2048, sym=False), 512, fs)
    k = ours.n_frames(len(x))
    feats = Spectrogrammer(FeatureConfig().for_rates([fs]))

    def best(fn, n: int) -> float:
        for _ in range(3):
            fn()
        times = []
        for _ in range(n):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return statistics.median(times) * 1e3

    t_ours = best(lambda: ours.band_power(x), 200)
    t_scipy = best(lambda: np.abs(sft.stft(x, p0=0, p1=k)) ** 2, 50)
    t_feats = best(lambda: feats(x, fs), 100)
    # Our own frames: 16 kHz working rate, 512-sample windows every 186 samples.
    x16 = np.random.default_rng(2).normal(0, 0.1, 16000).astype(np.float32)
    ours16 = Stft(16000, FeatureConfig().for_rates([16000]), np.float32)
    sft16 = ShortTimeFFT(hann(512, sym=False), 186, 16000)
    k16 = ours16.n_frames(len(x16))
    t16 = best(lambda: ours16.band_power(x16), 300)
    t16s = best(lambda: np.abs(sft16.stft(x16, p0=0, p1=k16)) ** 2, 100)
    return {"stft_ms_per_second_of_audio": round(t_ours, 4),
            "stft_scipy_shorttimefft_ms_per_second_of_audio": round(t_scipy, 4),
            "stft_speedup_vs_scipy": round(t_scipy / t_ours, 2),
            "stft_16k_ms_per_second_of_audio": round(t16, 4),
            "stft_16k_scipy_shorttimefft_ms_per_second_of_audio": round(t16s, 4),
            "stft_16k_speedup_vs_scipy": round(t16s / t16, 2),
            "features_ms_per_second_of_audio": round(t_feats, 4)}


def run() -> dict[str, float]:
    from fingertip.models.vibration.classify import load_folder, paired_difference
    from fingertip.models.vibration.material import train_material
    from fingertip.models.vibration.shake import train_shake

    _pin()
    out: dict[str, float] = {}
    out.update(_stft_speed())
    with tempfile.TemporaryDirectory(prefix="bench_classify_") as tmp:
        root = Path(tmp)
        # --- material -----------------------------------------------------------------
        _write_dataset(root / "materials", "materials", 100, SEED)
        ds = load_folder(root / "materials")
        r = train_material(ds, root / "material_model", folds=5, seed=SEED, plot=False)
        w = r.evaluation.windows
        a, b, k = w.most_confused()
        errors = int(w.confusion.sum() - np.trace(w.confusion))
        out.update({
            "material_accuracy": round(w.accuracy, 4),
            "material_recording_accuracy": round(r.evaluation.recordings.accuracy, 4),
            "material_min_recall": round(min(w.recall.values()), 4),
            "material_copper_wax_share_of_errors": round(
                k / errors if errors and {a, b} == {"copper_tape", "wax_paper"} else 0.0, 4),
            "material_latency_ms": round(r.report["timing"]["latency_1s_audio_44k1_ms"]["p50"],
                                         4),
            "material_model_latency_ms": round(r.report["timing"]["latency_model_ms"]["p50"],
                                               4),
        })
        _resampled_copy(root / "materials", root / "materials_8k", 8000)
        r8 = train_material(root / "materials_8k", root / "material_model_8k", folds=5,
                            seed=SEED, plot=False)
        out["material_accuracy_8khz"] = round(r8.evaluation.windows.accuracy, 4)

        # --- shake (the paper's protocol) ---------------------------------------------------
        _write_dataset(root / "shake", "shake", 20, SEED)
        s = train_shake(root / "shake", root / "shake_model", seed=SEED, plot=False)
        for name, res in s.results.items():
            out[f"shake_accuracy_{name}"] = round(res.evaluation.recordings.accuracy, 4)
            out[f"shake_window_accuracy_{name}"] = round(res.evaluation.windows.accuracy, 4)
            out[f"shake_latency_ms_{name}"] = round(res.cost["latency_model_ms"]["p50"], 4)
            out[f"shake_latency_audio_ms_{name}"] = round(
                res.cost["latency_window_audio_ms"]["p50"], 4)
            out[f"shake_params_{name}"] = int(res.cost["parameters"])
            out[f"shake_train_s_{name}"] = round(res.cost["train_s"], 2)
        worth = s.verdict.startswith("CNN worth it")
        out["shake_accuracy"] = out["shake_accuracy_cnn" if worth else "shake_accuracy_mlp"]
        out["shake_cnn_worth_it"] = int(worth)

        # --- shake, harder: lighter grip, rumble, 8 kHz -----------------------------------
        _write_hard_shakes(root / "shake_hard", 30, SEED)
        h = train_shake(root / "shake_hard", root / "shake_hard_model", seed=SEED,
                        test_fraction=1 / 3, plot=False)
        for name, res in h.results.items():
            out[f"shake_hard_accuracy_{name}"] = round(res.evaluation.recordings.accuracy, 4)
            out[f"shake_hard_window_accuracy_{name}"] = round(
                res.evaluation.windows.accuracy, 4)
            out[f"shake_hard_train_s_{name}"] = round(res.cost["train_s"], 2)
        d, se, _ = paired_difference(h.results["cnn"].evaluation,
                                     h.results["mlp"].evaluation)
        out["shake_hard_cnn_minus_mlp_points"] = round(100 * d, 2)
        out["shake_hard_cnn_minus_mlp_se_points"] = round(100 * se, 2)
        out["shake_hard_cnn_worth_it"] = int(h.verdict.startswith("CNN worth it"))
    return out


DESCRIPTION = {
    "material_accuracy": ("material classification, 7 materials x 100 simulated slides, "
                          "5-fold cross-validation by recording, per 0.5 s window (paper: "
                          "95.49 %)", (">=", 0.955)),
    "material_recording_accuracy": ("same, per slide (majority vote of its windows)", None),
    "material_min_recall": ("same, lowest per-class recall (windows)", None),
    "material_copper_wax_share_of_errors": ("share of all material errors that are copper "
                                            "tape <-> wax paper (the paper's main confusion)",
                                            None),
    "material_latency_ms": ("1 s of 44.1 kHz audio -> resampling, STFT, bands, 6 windows, "
                            "MLP (onnxruntime), p50", ("<", 20.0)),
    "material_model_latency_ms": ("material MLP alone, one window (onnxruntime, p50)", None),
    "material_accuracy_8khz": ("material accuracy on the same slides resampled to 8 kHz "
                               "(bands up to 3.6 kHz)", None),
    "shake_accuracy": ("box contents by shaking, majority vote per shake, 15 held-out shakes "
                       "(paper: 94.64 %); the model the CNN-vs-MLP verdict recommends",
                       (">=", 0.95)),
    "shake_accuracy_cnn": ("same, small ResNet CNN (numpy-trained, ONNX)", None),
    "shake_accuracy_mlp": ("same, MLP on pooled window features", None),
    "shake_window_accuracy_cnn": ("CNN, per 10 Hz prediction (86-frame window)", None),
    "shake_window_accuracy_mlp": ("MLP, per 10 Hz prediction", None),
    "shake_latency_ms_cnn": ("CNN alone, one prediction (onnxruntime, p50)", None),
    "shake_latency_ms_mlp": ("MLP alone, one prediction (onnxruntime, p50)", None),
    "shake_latency_audio_ms_cnn": ("one 1.02 s window of 44.1 kHz audio -> CNN prediction, "
                                   "p50", None),
    "shake_latency_audio_ms_mlp": ("one 1.02 s window of 44.1 kHz audio -> MLP prediction, "
                                   "p50", None),
    "shake_params_cnn": ("CNN parameters", None),
    "shake_params_mlp": ("MLP parameters", None),
    "shake_train_s_cnn": ("CNN training time, seconds (numpy, one core)", None),
    "shake_train_s_mlp": ("MLP training time, seconds", None),
    "shake_cnn_worth_it": ("1 if the CNN's accuracy gain over the MLP is significant (paired "
                           "by test recording, > 2 standard errors)", None),
    "shake_hard_accuracy_cnn": ("harder shakes (0.5-2 N grip, rumble, 8 kHz), 30 held-out "
                                "shakes, CNN, majority vote", None),
    "shake_hard_accuracy_mlp": ("same, MLP", None),
    "shake_hard_window_accuracy_cnn": ("harder shakes, CNN, per 10 Hz prediction", None),
    "shake_hard_window_accuracy_mlp": ("harder shakes, MLP, per 10 Hz prediction", None),
    "shake_hard_train_s_cnn": ("harder shakes, CNN training time, seconds", None),
    "shake_hard_train_s_mlp": ("harder shakes, MLP training time, seconds", None),
    "shake_hard_cnn_minus_mlp_points": ("harder shakes, window accuracy CNN minus MLP, points, "
                                        "mean over test recordings", None),
    "shake_hard_cnn_minus_mlp_se_points": ("its standard error, points", None),
    "shake_hard_cnn_worth_it": ("1 if the CNN's gain is significant on the harder shakes",
                                None),
    "stft_ms_per_second_of_audio": ("our STFT power + bands, 1 s of 44.1 kHz audio, 2048/512 "
                                    "Hann frames, float32, ms", None),
    "stft_scipy_shorttimefft_ms_per_second_of_audio": (
        "scipy.signal.ShortTimeFFT |stft|^2 on the same frames, same run, ms", None),
    "stft_speedup_vs_scipy": ("ShortTimeFFT time / ours", (">=", 3.0)),
    "stft_16k_ms_per_second_of_audio": ("our STFT power + bands, 1 s at the 16 kHz working "
                                        "rate, 512/186 Hann frames, float32, ms", None),
    "stft_16k_scipy_shorttimefft_ms_per_second_of_audio": (
        "scipy.signal.ShortTimeFFT |stft|^2 on the same 16 kHz frames, same run, ms", None),
    "stft_16k_speedup_vs_scipy": ("ShortTimeFFT time / ours, 16 kHz frames", (">=", 5.0)),
    "features_ms_per_second_of_audio": ("whole feature path for 1 s of 44.1 kHz audio: "
                                        "resample to 16 kHz, STFT, 32 bands, ms", None),
}


def tables(r: dict[str, float]) -> dict[str, str]:
    """Shake classifiers: the CNN against the MLP, accuracy and cost side by side."""
    def g(k: str) -> str:
        v = r.get(k)
        return "-" if v is None else (f"{v:,.0f}" if abs(v) >= 100 else f"{v:.4g}")

    rows = ["| | MLP | CNN |", "|---|---|---|"]
    for label, key in [("accuracy per shake (paper protocol)", "shake_accuracy_{}"),
                       ("accuracy per shake (harder set)", "shake_hard_accuracy_{}"),
                       ("parameters", "shake_params_{}"),
                       ("latency, model alone (ms)", "shake_latency_ms_{}"),
                       ("latency from 1 s of raw audio (ms)", "shake_latency_audio_ms_{}"),
                       ("training time (s)", "shake_train_s_{}")]:
        rows.append(f"| {label} | {g(key.format('mlp'))} | {g(key.format('cnn'))} |")
    return {"Shake classifiers: is the CNN worth its cost?": "\n".join(rows)}
