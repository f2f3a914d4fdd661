"""``fingertip sim device | mujoco | faults | dataset``: the virtual fingertip on a pty (alone
or in a MuJoCo scene), its build faults, and datasets from it.

:func:`add_group` adds ``fingertip sim`` with all three; :func:`add_parsers` adds ``dataset``
to the subparsers of ``fingertip sim``. Handlers return
an exit code: 0 done, 1 the writing failed part-way (disk full...), 2 a user error (bad
argument, output folder not empty or not writable), each reported as one clear log line.
``python -m fingertip.cli.sim dataset ...`` runs it on its own.
"""
from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from .argtypes import dispatch, number
from ..badfile import reports_bad_files
from ..errors import BadArgumentError
from ..sim.device.faults import FAULTS

log = logging.getLogger("fingertip")


def _cmd_sim_device(args: argparse.Namespace) -> int:
    """Serve a virtual fingertip (the firmware's device logic, host build) on a pty."""
    from ..sim import VirtualFirmware
    from ..sim.physics import Idle, VirtualStrainSensor

    if args.fault:
        from ..sim.device.bringup import VirtualUnit
        from ..sim.device.faults import parse_faults

        if args.channels != 4:
            raise BadArgumentError("--fault needs the 4-channel fingertip")
        fw = VirtualUnit(args.seed, parse_faults(args.fault)).firmware  # BadArgumentError
    else:
        scene = Idle(duration=1e9)
        source = VirtualStrainSensor(args.seed).as_source(scene)
        fw = VirtualFirmware(args.channels, source=source if args.channels == 4 else None)
    return _serve(fw, args.link, "virtual fingertip")


def _serve(fw, link: str | None, what: str) -> int:
    """Serve ``fw`` on a pty until Ctrl-C or SIGTERM."""
    import signal
    import threading

    from ..sim.device.pty_device import PtyDevice

    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    with PtyDevice(fw, link=link) as dev:
        print(f"{what} on {dev.link or dev.port}  (Ctrl-C to stop)", flush=True)
        try:
            while not stop.wait(0.2):
                pass
        except KeyboardInterrupt:
            pass
    return 0


def _cmd_sim_mujoco(args: argparse.Namespace) -> int:
    """Serve one fingertip of a MuJoCo scene on a pty through the virtual device (the
    firmware's C++ core): `fingertip stream`, `record`, `check` and `publish` read it as a
    fingertip. Needs the mujoco extra."""
    try:
        from ..sim.mujoco.live import SCENES, LiveSimulation
    except ImportError as e:
        log.error("%s", e)
        return 2
    from ..sim import VirtualFirmware

    if args.scene not in SCENES:
        raise BadArgumentError(f"unknown scene {args.scene!r}: one of {', '.join(SCENES)}")
    if args.render or args.view:
        from ..sim.mujoco.render import render_run, view

        if args.view:
            try:
                view(args.scene, args.seconds, seed=args.seed)
            except RuntimeError as e:
                log.error("%s", e)
                return 2
            return 0
        r = render_run(args.scene, args.render, seconds=args.seconds or 6.0, fps=args.fps,
                       seed=args.seed)
        print(f"wrote {r.frames} frames, {r.readings} readings and {r.audio_s:.1f} s of piezo "
              f"to {r.out} (summary.png, counts.csv, frames/)")
        return 0
    live = LiveSimulation(args.scene, seed=args.seed)
    fw = VirtualFirmware(4, source=live.counts_source())
    return _serve(fw, args.link, f"MuJoCo scene {args.scene!r} ({SCENES[args.scene].what}): "
                                 "fingertip")


def _cmd_sim_faults(args: argparse.Namespace) -> int:
    """List the build faults `fingertip sim device --fault` and `fingertip check --virtual
    --fault` take."""
    for name, what in FAULTS.items():
        print(f"{name:<16} {what}")
    return 0


def _report(res, what: str) -> None:
    for w in res.warnings:
        log.warning("%s", w)
    print(f"wrote {what} to {res.out} in {res.wall_s:.1f} s (see {res.out / 'dataset.json'})")


@reports_bad_files
def _cmd_calibration(args: argparse.Namespace) -> int:
    """Simulate the paper's calibration sweep (angles -50..50 deg in 10 deg steps, contact
    heights 0..5 mm, indentation steps of 1.5 mm to 30 mm, loading and unloading, 8 s pauses)
    on virtual units: one CSV per unit, in the layout of `fingertip export`, with the true
    forces."""
    from ..sim.dataset import DatasetError, write_calibration

    try:
        res = write_calibration(
            args.out, units=args.units, seed=args.seed, sweeps=args.sweeps,
            rate_sps=args.rate_sps, samples_per_step=args.samples_per_step,
            tare_samples=args.tare, max_force_n=args.max_force, params_file=args.params,
            force=args.force, progress=not args.quiet)
    except DatasetError as e:
        log.error("%s", e)
        return e.code
    rows = sum(res.meta["rows"].values())
    _report(res, f"{len(res.files)} unit(s), {rows} rows")
    return 0


@reports_bad_files
def _cmd_vibration(args: argparse.Namespace) -> int:
    """Simulate labelled contact-microphone recordings: one sub-folder per class of WAV
    files (materials: the paper's seven; shake: screws / rubber_bands / empty; cups: slides
    over a 5-cup stack with rim times and robot Z), and a manifest CSV."""
    from ..sim.dataset import DatasetError, write_vibration

    try:
        res = write_vibration(
            args.out, kind=args.kind, recordings_per_class=args.recordings_per_class,
            seconds=args.seconds, seed=args.seed, rate=args.rate, fmt=args.format,
            params_file=args.params, force=args.force, progress=not args.quiet)
    except DatasetError as e:
        log.error("%s", e)
        return e.code
    m = res.meta
    _report(res, f"{m['recordings']} recording{'s' if m['recordings'] > 1 else ''} in "
                 f"{len(m['classes'])} "
                 f"class{'es' if len(m['classes']) > 1 else ''} "
                 f"({', '.join(m['classes'])}) at {m['rate_hz']} Hz")
    return 0


def add_parsers(sub) -> None:
    """Add ``dataset`` (with ``calibration`` and ``vibration``) to ``sub``, the subparsers
    of ``fingertip sim``."""
    from ..sim.dataset import DEFAULT_RECORDINGS, FORMATS, KINDS, MAX_RATE_HZ, MIN_RATE_HZ

    d = sub.add_parser("dataset", help="write simulated calibration sweeps or labelled "
                                       "vibration recordings",
                       description="Datasets from the virtual fingertip, in the formats of "
                                   "real recordings (docs/simulation.md).")
    dsub = d.add_subparsers(dest="dataset_command", metavar="KIND", required=True)

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument("out", metavar="OUT", help="output folder (created; must be empty)")
        p.add_argument("--seed", type=number(int, 0, 2 ** 31 - 1), default=0,
                       help="seed of the whole dataset (default 0): same seed, same files")
        p.add_argument("--params", metavar="FILE.toml",
                       help="another parameter file (default: the shipped fingertip.toml)")
        p.add_argument("--force", action="store_true",
                       help="write into a non-empty folder: a dataset this command wrote "
                            "there is replaced; other files are left alone")
        p.add_argument("-q", "--quiet", action="store_true", help="no progress line")

    c = dsub.add_parser("calibration", help="the paper's calibration sweep, one CSV per unit",
                        description=_cmd_calibration.__doc__)
    common(c)
    c.add_argument("--units", type=number(int, 1, 10_000), default=1,
                   help="virtual fingertips, seeds SEED..SEED+N-1 (default 1)")
    c.add_argument("--sweeps", type=number(int, 1, 100), default=1,
                   help="sweeps per unit, one after the other (default 1; 2 gives a "
                        "held-out sweep)")
    c.add_argument("--rate-sps", type=int, choices=(10, 80), default=80,
                   help="HX711 rate, sets the noise (default 80)")
    c.add_argument("--samples-per-step", type=number(int, 1, 64), default=1,
                   help="readings logged at the end of each 8 s pause (default 1)")
    c.add_argument("--tare", type=number(int, 0, 256), default=16, metavar="N",
                   help="tare with N readings at zero load first, as `fingertip tare` does "
                        "(default 16; 0 logs raw counts with their offsets)")
    c.add_argument("--max-force", type=number(float, 0.1, 50.0), default=5.0, metavar="N",
                   help="force at full travel, newtons (default 5, the paper's range)")
    c.set_defaults(func=_cmd_calibration)

    v = dsub.add_parser("vibration", help="labelled recordings, one sub-folder per class",
                        description=_cmd_vibration.__doc__)
    common(v)
    v.add_argument("--kind", choices=KINDS, default="materials",
                   help="materials (default), shake or cups")
    v.add_argument("--recordings-per-class", type=number(int, 1, 100_000), metavar="N",
                   help="default: " + ", ".join(f"{k} {n}" for k, n in
                                                DEFAULT_RECORDINGS.items()))
    v.add_argument("--seconds", type=number(float, 0.05, 600.0), metavar="S",
                   help="length of each recording (default: materials the paper's 16 mm "
                        "slide at the drawn speed, 0.4-1.6 s; shake 5.6 s; not for cups)")
    v.add_argument("--rate", type=number(int, MIN_RATE_HZ, MAX_RATE_HZ), default=44100,
                   metavar="HZ", help="sample rate of the files (default 44100, the "
                                      "simulation's; others are resampled from it)")
    v.add_argument("--format", choices=FORMATS, default="wav",
                   help="wav (default) or flac, 16-bit PCM")
    v.set_defaults(func=_cmd_vibration)


def add_group(sub) -> None:
    """Add ``sim`` (device, faults, dataset) to the ``fingertip`` subparsers."""
    sm = sub.add_parser("sim", help="the virtual fingertip (no hardware needed)")
    smsub = sm.add_subparsers(dest="sim_command", metavar="SIM_COMMAND", required=True)
    sd = smsub.add_parser("device", help="serve a virtual fingertip on a pseudo-terminal",
                          description=_cmd_sim_device.__doc__)
    sd.add_argument("--channels", type=int, default=4, choices=range(1, 17), metavar="1-16")
    sd.add_argument("--link", help="also make this path a symlink to the pty")
    sd.add_argument("--seed", type=int, default=0, help="which virtual unit (its variation)")
    sd.add_argument("--fault", action="append", metavar="NAME[:CH]",
                    help="a build fault (repeatable): " + ", ".join(FAULTS))
    sd.set_defaults(func=_cmd_sim_device)
    sj = smsub.add_parser("mujoco", help="serve a fingertip of a MuJoCo scene on a "
                                         "pseudo-terminal (needs the mujoco extra)",
                          description=_cmd_sim_mujoco.__doc__)
    sj.add_argument("--scene", default="slide", metavar="NAME",
                    help="slide (a probe over the seven materials, default) or pinch (a "
                         "gripper and the tofu)")
    sj.add_argument("--link", help="also make this path a symlink to the pty")
    sj.add_argument("--seed", type=int, default=0, help="which virtual unit (its variation)")
    sj.add_argument("--render", metavar="DIR",
                    help="instead of serving: run the scene headless and write PNG frames, "
                         "counts.csv and summary.png (counts, force, spectrogram) to DIR")
    sj.add_argument("--view", action="store_true",
                    help="instead of serving: MuJoCo's passive viewer (needs a display)")
    sj.add_argument("--seconds", type=number(float, 0.1, 3600.0), metavar="S",
                    help="length of a --render run (default 6) or a --view (default: until "
                         "closed)")
    sj.add_argument("--fps", type=number(float, 1.0, 60.0), default=20.0,
                    help="frames per simulated second of --render (default 20)")
    sj.set_defaults(func=_cmd_sim_mujoco)
    sf = smsub.add_parser("faults", help="list the build faults the simulator can add",
                          description=_cmd_sim_faults.__doc__)
    sf.set_defaults(func=_cmd_sim_faults)
    add_parsers(smsub)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m fingertip.cli.sim dataset calibration|vibration OUT ...``"""
    parser = argparse.ArgumentParser(prog="fingertip sim",
                                     description="The virtual fingertip's datasets.")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    add_parsers(parser.add_subparsers(dest="sim_command", metavar="SIM_COMMAND",
                                      required=True))
    return dispatch(parser, argv)


if __name__ == "__main__":
    sys.exit(main())
