"""``fingertip train material|shake FOLDER`` and ``fingertip classify material|shake MODEL``.

:func:`add_parsers` adds ``train`` and ``classify`` to the top-level subparsers of
``fingertip``. Handlers return 0 done; an error is raised for the command line's one
mapping (2 a user error: bad folder, file, model or device; 1 a failure part-way). Heavy
modules (scipy, onnx, onnxruntime) are imported only when a command runs.
``python -m fingertip.cli.classify train material FOLDER`` runs it on its own.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from .argtypes import dispatch, number
from ..badfile import reports_bad_files
from ..errors import BadArgumentError

if TYPE_CHECKING:
    from ..models.vibration.features import FeatureConfig
log = logging.getLogger("fingertip")


def _hidden(text: str) -> tuple[int, ...]:
    try:
        out = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"hidden sizes are integers like 32 or 64,32, not "
                                         f"{text!r}") from None
    if not out or any(v < 1 or v > 4096 for v in out):
        raise argparse.ArgumentTypeError("hidden sizes must be 1..4096")
    return out


def _models(text: str) -> tuple[str, ...]:
    from ..models.vibration.candidates import CANDIDATES

    out = tuple(v.strip() for v in text.split(",") if v.strip())
    bad = [v for v in out if v not in CANDIDATES]
    if not out or bad:
        raise argparse.ArgumentTypeError(f"models are some of {','.join(CANDIDATES)}, not "
                                         f"{text!r}")
    return out


def _features(args: argparse.Namespace, notch: bool = True) -> FeatureConfig:
    """The feature configuration the train options ask for (the library's defaults else);
    ``notch``: whether it carries ``--mains-notch`` (the material trainer takes it apart)."""
    from ..models.vibration.features import FeatureConfig

    kw = {} if args.mains_notch is None or not notch else {"mains_notch": args.mains_notch}
    return FeatureConfig(canonical_rate=args.canonical_rate, **kw)


@reports_bad_files
def _cmd_train_material(args: argparse.Namespace) -> int:
    """Train a material classifier on FOLDER (one sub-folder per class of WAV, FLAC or CSV
    recordings, any rate from 1 to 384 kHz, any length from 0.1 s): windows and bands
    adapted to the recordings, answers that grow with the slide (0.25 s, 0.5 s, ... the
    whole recording), candidate models (a log-spectrum logistic-regression baseline,
    logistic regression on log bands, an MLP, an ensemble of these, an RBF SVM, boosted
    trees, a CNN) chosen by cross-validation by recording,
    calibrated probabilities and an "unknown" answer; exported to ONNX."""
    from ..models.vibration.augment import AugmentConfig
    from ..models.vibration.candidates import DEFAULT_CANDIDATES
    from ..models.vibration.classifier.report_text import material_summary_lines
    from ..models.vibration.material import train_material

    def train():
        return train_material(args.folder, args.out, window_s=args.window, step_s=args.step,
                              features=_features(args, notch=False),
                              mains_notch=args.mains_notch,
                              hidden=args.hidden, test_fraction=args.test_fraction,
                              seed=args.seed, rate_hint=args.rate_hint, max_hz=args.max_hz,
                              epochs=args.epochs, folds=args.folds,
                              models=args.models or DEFAULT_CANDIDATES,
                              augment=AugmentConfig(copies=args.augment),
                              cnn_budget=args.cnn_budget, jobs=args.jobs,
                              every_fold=args.every_fold)

    _check_out(args.out)
    return _run_training(train, material_summary_lines, args.json)


def _check_out(out: str) -> None:
    """The trainers' output folder: created, or an existing folder (their files in it are
    replaced); never a file, a FIFO or a device."""
    from ..outputs import check_output

    check_output(out, force=True, what="model folder", folder=True)


def _run_training(train: Callable[[], Any], words: Callable[[Any], list[str]],
                  as_json: bool) -> int:
    """Run one training, then print its report as JSON or in the lines ``words`` makes of
    it, and the files written (an error is raised: a user's, exit 2, is one line)."""
    from ..models.vibration.classify import json_safe

    r = train()
    if as_json:
        print(json.dumps(json_safe(r.report)))
        return 0
    for line in words(r):
        print(line)
    print("wrote " + ", ".join(str(p) for p in r.files))
    return 0


@reports_bad_files
def _cmd_train_shake(args: argparse.Namespace) -> int:
    """Train shake classifiers on FOLDER (one sub-folder per box content): 86-frame windows
    (1 s) every 0.1 s, a small ResNet CNN and an MLP, both exported to ONNX, evaluated per
    window and per shake (majority vote) on held-out recordings, with their costs."""
    from ..models.vibration.classifier.report_text import shake_summary_lines
    from ..models.vibration.shake import train_shake

    models = ("cnn", "mlp") if args.model == "both" else (args.model,)

    def train():
        return train_shake(args.folder, args.out, models=models, step_s=args.step,
                           features=_features(args),
                           test_fraction=args.test_fraction, seed=args.seed,
                           rate_hint=args.rate_hint, max_hz=args.max_hz,
                           cnn_epochs=args.cnn_epochs, cnn_max_seconds=args.cnn_max_seconds)

    _check_out(args.out)
    return _run_training(train, shake_summary_lines, args.json)


@reports_bad_files
def _cmd_classify(args: argparse.Namespace) -> int:
    """Classify a recording (WAV, FLAC, CSV) or a live stream (a sound card, the sound card
    paired with a fingertip's serial port, or the virtual fingertip) with a model made by
    `fingertip train`: one prediction per window with its time, then the majority vote."""
    from ..models.vibration.classify import VibrationClassifier
    from ..models.vibration.live_classify import run_classification, sound_card_source

    sources = [s for s in (args.file, args.audio, args.port, args.simulate) if s is not None]
    if len(sources) != 1:
        raise BadArgumentError("give exactly one of FILE, --audio DEVICE, --port PORT or "
                               "--simulate NAME")
    forces = ft = None
    if args.force_model:
        if args.port is None:
            raise BadArgumentError("--force-model needs --port: the fingertip whose forces go "
                                   "with the predictions (its paired sound card is classified)")
        forces, ft = _open_forces(args.port, args.force_model)
    try:
        clf = VibrationClassifier(args.model, kind=args.kind)
        if args.file is not None:
            source = args.file
        elif args.simulate is not None:
            from ..sim.device.scene_audio import scene_audio_source

            source = scene_audio_source(args.simulate, args.kind, args.duration,
                                        not args.fast, args.seed)
        else:
            source = sound_card_source(args.audio, args.port, args.samplerate, args.channel)
        result = run_classification(clf, source, rate=args.rate, duration=args.duration,
                                    channel=args.channel, decide_at=args.decide_at,
                                    on_prediction=lambda p: _show(p, args.json, forces))
    finally:
        if ft is not None:
            ft.close()
    preds = result.predictions
    if args.decide_at is not None:
        return _print_decision(result, args.decide_at, args.json)
    vote = result.vote
    shares = result.shares()
    if args.json:
        print(json.dumps({"vote": vote, "predictions": len(preds),
                          "shares": {k: round(v, 4) for k, v in shares.items()}}))
    elif vote is None:
        print("no prediction (the audio ended before one window)")
    else:
        clipped = sum(p.clipped for p in preds)
        share = (f"{100 * shares[vote]:.0f} % of {len(preds)} predictions" if vote in shares
                 else f"farther from every class than the model's threshold; "
                      f"{len(preds)} predictions")
        print(f"vote: {vote} ({share})"
              + (f"; {clipped} window(s) clipped" if clipped else ""))
    return 0


def _print_decision(result, threshold: float, as_json: bool) -> int:
    if not result.predictions:
        print(json.dumps({"decision": None}) if as_json else
              "no prediction (the audio ended before one window)")
        return 0
    d = result.decide(threshold)
    if as_json:
        print(json.dumps({"decision": d.to_dict(), "threshold": threshold}))
    elif d.decided:
        print(f"decision: {d.label} ({100 * d.probability:.1f} % >= {100 * threshold:g} %) "
              f"after {d.t:.3f} s")
    else:
        print(f"no decision at {100 * threshold:g} %: best {d.label} "
              f"({100 * d.probability:.1f} %) after {d.t:.3f} s")
    return 0


def _open_forces(port: str, path: str):
    """The fingertip on ``port`` streaming into a force window of the model at ``path``
    (the device's errors, or a refused model, raised)."""
    from ..models.vibration.live_classify import ForceModelRefused, open_force_window

    try:
        return open_force_window(port, path)
    except ForceModelRefused as e:
        e.add_context("--force-model refused")
        raise


def _show(p, as_json: bool, forces=None) -> None:
    f = None
    if forces is not None and p.host_time is not None:
        f = forces.mean(p.host_time - (p.t_end - p.t_start), p.host_time)
    if as_json:
        d = p.to_dict()
        if forces is not None:
            d["force_n"] = None if f is None else [round(f[0], 4), round(f[1], 4)]
        print(json.dumps(d), flush=True)
        return
    level = f"{p.level_db:6.1f} dB" if math.isfinite(p.level_db) else "silence"
    run = ""
    if p.running:
        top = max(p.running, key=p.running.get)
        run = f"  so far: {top} {100 * p.running[top]:5.1f} %"
    print(f"{p.t_start:8.2f}-{p.t_end:7.2f} s  {p.label:<18} {100 * p.probability:5.1f} %  "
          f"{level}" + ("  CLIPPED" if p.clipped else "")
          + (f"  Fx {f[0]:+.2f} Fy {f[1]:+.2f} N" if f else "") + run, flush=True)


def add_parsers(sub) -> None:
    """Add ``train`` and ``classify`` (each with ``material`` and ``shake``) to ``sub``, the
    top-level subparsers of ``fingertip``."""
    t = sub.add_parser("train", help="train a vibration classifier (material or shake) on "
                                     "a folder of labelled recordings",
                       description="Train on a folder with one sub-folder per class of "
                                   "recordings (docs/classifiers.md).")
    tsub = t.add_subparsers(dest="train_command", metavar="KIND", required=True)

    def common(p: argparse.ArgumentParser, default_out: str) -> None:
        p.add_argument("folder", metavar="FOLDER", help="one sub-folder per class of WAV, "
                                                        "FLAC or CSV recordings")
        p.add_argument("-o", "--out", default=default_out,
                       help=f"output folder for the model(s), report.json and the "
                            f"confusion-matrix PNG (default: {default_out})")
        p.add_argument("--rate-hint", type=number(float, 999, 384_000, lo_open=True), metavar="HZ",
                       help="sample rate of CSV files that do not state theirs (a header "
                            "line '# rate=8000' does)")
        p.add_argument("--max-hz", type=number(float, 200, lo_open=True), metavar="HZ",
                       help="top of the frequency bands (default: 0.45 x the lowest rate "
                            "in FOLDER, at most 7200): lower it to run the model on "
                            "recordings at lower rates")
        p.add_argument("--test-fraction", type=number(float, 0, 0.9, lo_open=True), default=0.25,
                       metavar="F", help="share of each class's recordings held out for "
                                         "the test (default 0.25)")
        p.add_argument("--canonical-rate", type=number(int, 999, 192_000, lo_open=True),
                       default=16000,
                       metavar="HZ", help="recordings above this rate are resampled to it "
                                          "(default 16000: bands up to 7.2 kHz, portable to "
                                          "any sensor at 16 kHz or more)")
        p.add_argument("--mains-notch", action=argparse.BooleanOptionalAction,
                       help="notch out (or not) steady 50/60 Hz mains lines found in "
                            "each recording before the features, in training and at run "
                            "time (default: material: tried by cross-validation when "
                            "recordings carry lines, kept when it costs no accuracy; "
                            "shake: off; docs/classifiers.md, 'Mains hum')")
        p.add_argument("--seed", type=int, default=0, help="seed of the split and the "
                                                          "training (default 0)")
        p.add_argument("--json", action="store_true", help="print the report as JSON")

    m = tsub.add_parser("material", help="material classifier (sliding contact)",
                        description=_cmd_train_material.__doc__)
    common(m, "material-model")
    m.add_argument("--window", type=number(float, 0.05, 10, lo_open=True), metavar="S",
                   help="longest window, seconds (default: the median recording, at most "
                        "2 s)")
    m.add_argument("--step", type=number(float, 0.005, 10, lo_open=True), metavar="S",
                   help="one answer every S seconds (default 0.1, less for short "
                        "recordings)")
    m.add_argument("--hidden", type=_hidden, default=(64,), metavar="N[,N...]",
                   help="hidden layer sizes of the MLP candidate (default 64)")
    m.add_argument("--models", type=_models, default=None, metavar="NAME[,NAME...]",
                   help="candidate models compared by cross-validation (default "
                        "baseline,linear,mlp,ensemble,svm,cnn; the CNN only within "
                        "--cnn-budget; boost, slow to cross-validate, only when named)")
    m.add_argument("--cnn-budget", type=number(float, 0, 1e12, lo_open=True),
                   default=None, metavar="N",
                   help="cross-validate the CNN candidate only when its projected work "
                        "(training windows x 30 epochs x fits) is at most N window-epochs "
                        "(default 250000, about a minute; counted from the data, not timed)")
    m.add_argument("--augment", type=number(int, 0, 20), default=1, metavar="N",
                   help="augmented copies of each training recording (other speeds, mains "
                        "hum, motor noise), adopted when the cross-validation finds them "
                        "free (default 1; 0: none)")
    m.add_argument("--epochs", type=number(int, 0, 100_000, lo_open=True), default=300,
                   help="most training epochs (default 300; early stopping)")
    m.add_argument("--jobs", type=number(int, 0, 1024, lo_open=True), default=None,
                   metavar="N", help="worker processes for the cross-validation's folds "
                                     "(default: every core; the result is the same)")
    m.add_argument("--folds", type=number(int, 0, 100, lo_open=True), default=1, metavar="K",
                   help="K-fold cross-validation by recording instead of one split "
                        "(default 1: one split, --test-fraction held out)")
    m.add_argument("--every-fold", action="store_true",
                   help="cross-validate every candidate on every fold (default: a costlier "
                        "candidate stops once it can no longer change the choice)")
    m.set_defaults(func=_cmd_train_material)

    s = tsub.add_parser("shake", help="box-content classifiers (CNN and MLP) from shaking",
                        description=_cmd_train_shake.__doc__)
    common(s, "shake-model")
    s.add_argument("--model", choices=("both", "cnn", "mlp"), default="both",
                   help="which model(s) to train (default both, compared)")
    s.add_argument("--step", type=number(float, 0.005, 10, lo_open=True), default=0.1, metavar="S",
                   help="prediction step, seconds (default 0.1: 10 Hz)")
    s.add_argument("--cnn-epochs", type=number(int, 0, 10_000, lo_open=True), default=40,
                   metavar="N",
                   help="most CNN epochs (default 40; early stopping on held-out "
                        "recordings)")
    s.add_argument("--cnn-max-seconds", type=number(float, 0, lo_open=True), metavar="S",
                   help="stop the CNN's training after S seconds")
    s.set_defaults(func=_cmd_train_shake)

    c = sub.add_parser("classify", help="classify a recording or a live stream with a "
                                        "trained material or shake model",
                       description=_cmd_classify.__doc__)
    csub = c.add_subparsers(dest="classify_command", metavar="KIND", required=True)
    for kind in ("material", "shake"):
        p = csub.add_parser(kind, help=f"with a {kind} model",
                            description=_cmd_classify.__doc__)
        p.add_argument("model", metavar="MODEL", help="the .onnx file written by "
                                                      f"`fingertip train {kind}`")
        p.add_argument("file", metavar="FILE", nargs="?",
                       help="a WAV, FLAC or CSV recording")
        p.add_argument("--audio", metavar="DEVICE",
                       help="live from this sound card (index or part of its name)")
        p.add_argument("--port", metavar="PORT",
                       help="live from the USB sound card on the same hub as the "
                            "fingertip on this serial port")
        p.add_argument("--simulate", metavar="NAME",
                       help="live from the virtual fingertip: a material (sliding) or a "
                            "box content (screws, rubber_bands, empty)")
        p.add_argument("--duration", type=number(float, 0, lo_open=True), metavar="S",
                       help="stop a live stream after S seconds of audio")
        p.add_argument("--rate", type=number(float, 999, 384_000, lo_open=True), metavar="HZ",
                       help="sample rate of a CSV file that does not state its own")
        p.add_argument("--samplerate", type=number(float, 999, 384_000, lo_open=True),
                       default=44100,
                       metavar="HZ", help="rate to open the sound card at (default 44100)")
        p.add_argument("--channel", type=int, default=0, help="input channel (default 0)")
        p.add_argument("--fast", action="store_true",
                       help="--simulate: as fast as possible instead of in real time")
        p.add_argument("--seed", type=int, default=0, help="--simulate: which realisation")
        p.add_argument("--json", action="store_true", help="one JSON object per line")
        p.add_argument("--decide-at", type=number(float, 0, 1, lo_open=True), metavar="P",
                       help="stop at the first answer whose running probability reaches P "
                            "(0-1) and print the decision and the time it took")
        p.add_argument("--force-model", metavar="FORCE.onnx",
                       help="with --port: the fingertip's mean force over each window, from "
                            "this calibration (refused when it does not fit the fingertip)")
        p.set_defaults(func=_cmd_classify, kind=kind)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="fingertip-classifiers")
    add_parsers(p.add_subparsers(dest="command", metavar="COMMAND", required=True))
    return dispatch(p, argv)


if __name__ == "__main__":
    sys.exit(main())
