"""The bad-input table (issue 28): one row per case, over files, recordings, live ports, the
network, signals and the Python API.

A row is a :class:`Case`: the command line (``{name}``: a path of the workspace, ``{tmp}``:
a fresh folder of the case) or an API call, the exit status it must end with, and words its
single error line must hold. Rows are generated where one rule covers a family (every
command that reads a recording, fed every kind of bad file).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fingertip.errors import BadArgumentError, BadFileError, Error, NetworkError, OutputRefused


@dataclass(frozen=True)
class Case:
    id: str
    argv: str = ""
    code: int | tuple[int, ...] | None = 2
    says: str = ""
    timeout: float = 60.0
    api: Callable[[Any], Any] | None = None
    raises: type[BaseException] | tuple[type[BaseException], ...] | None = Error
    check: Callable[[Any], str | None] | None = None
    """Run after the case: a reason it failed, or None."""
    proc: bool = False
    signal: str = ""
    after: float = 0.0
    wait_for: str = ""
    sigint_ignored: bool = False
    wait_on: str = "stderr"
    """Where ``wait_for`` appears: "stderr" or "stdout"."""


# What a bad file of each kind must be called in the error line.
BAD_INPUTS = {"missing": "missing.file", "empty": "empty", "folder": "a-folder",
              "fifo": "FIFO", "random": "random.bin", "text": "notes.txt"}

CASES: list[Case] = []
CLASSIFY = "classify material {model} {NAME}"
RECORD_AUDIO = "record --port {port} -o {tmp}/r.mcap --duration 0.5 --audio-file {NAME}"


def _at(template: str, name: str) -> str:
    """``template`` with ``{NAME}`` naming the workspace path ``name``."""
    return template.replace("NAME", name)


def add(*cases: Case) -> None:
    CASES.extend(cases)


# --- recordings -------------------------------------------------------------------------------
RECORDING_COMMANDS = {
    "replay": "replay {NAME} --as-fast-as-possible",
    "export": "export {NAME} -o {tmp}/out",
    "repair": "repair {NAME} -o {tmp}/r.mcap",
}
BAD_RECORDINGS = {**BAD_INPUTS, "head_rec": "head.mcap", "good_wav": "good.wav",
                  "magic_rnd": "magic-random.mcap"}
for cmd, pattern in RECORDING_COMMANDS.items():
    for name, says in BAD_RECORDINGS.items():
        # repair keeps what it can: nothing, from a file that is only MCAP's magic
        code = 0 if cmd == "repair" and name in ("magic_rnd", "head_rec") else 2
        add(Case(f"{cmd}-{name}", pattern.replace("NAME", name), code, says if code else ""))
    add(Case(f"{cmd}-cut", pattern.replace("NAME", "cut_rec"), 0))
add(Case("export-magic-random-no-folder", "export {magic_rnd} -o {tmp}/o", 2,
         "no fingertip message",
         check=lambda ws: "an empty folder was left" if (ws["tmp"] / "o").exists() else None))

# --- audio files ------------------------------------------------------------------------------
BAD_AUDIO = {**BAD_INPUTS, "rec": "good.mcap", "latin": "latin1.csv"}
for name, says in BAD_AUDIO.items():
    add(Case(f"classify-file-{name}", _at(CLASSIFY, name), 2, says))
    add(Case(f"record-audio-file-{name}",
             _at(RECORD_AUDIO, name),
             2, says))
add(Case("classify-file-cut_wav", _at(CLASSIFY, "cut_wav"), 2, "cut.wav"),
    Case("record-takes-cut_wav", _at(RECORD_AUDIO, "cut_wav"), 0, "recorded"))
for name, says in (("silent_wav", "silent"), ("const_wav", "constant"),
                   ("clip_wav", "clipped")):
    add(Case(f"classify-warns-{name}", _at(CLASSIFY, name), 0, says))
    add(Case(f"record-warns-{name}",
             _at(RECORD_AUDIO, name),
             0, says))
for name, says in (("nan_wav", "NaN"), ("inf_wav", "infinite")):
    add(Case(f"classify-refuses-{name}", _at(CLASSIFY, name), 2, says))
    add(Case(f"record-warns-{name}",
             _at(RECORD_AUDIO, name),
             0, says))

# --- model files ------------------------------------------------------------------------------
BAD_MODELS = {**BAD_INPUTS, "fake_onnx": "fake.onnx", "good_wav": "good.wav"}
for name, says in BAD_MODELS.items():
    add(Case(f"classify-model-{name}", _at("classify material {NAME} {good_wav}", name), 2, says))
add(Case("classify-shake-with-material-model", "classify shake {model} {good_wav}", 2,
         "not a shake model"))
for cmd in ("record --port {port} -o {tmp}/r.mcap --duration 0.5",
            "stream --port {port} --count 2"):
    word = cmd.split()[0]
    add(Case(f"{word}-force-model-fake", cmd + " --force-model {fake_onnx}", 2, "fake.onnx"),
        Case(f"{word}-force-model-classifier", cmd + " --force-model {model}", 2,
             "material.onnx"),
        Case(f"{word}-force-model-missing", cmd + " --force-model {tmp}/none.onnx", 2,
             "none.onnx"),
        Case(f"{word}-force-model-callable", cmd + " --force-model no_such_mod:f", 2,
             "no_such_mod"))

# --- datasets ---------------------------------------------------------------------------------
BAD_CAL = {**BAD_INPUTS, "empty_folder": "empty-folder", "cal_cut": "cal_cut",
           "cal_header": "cal_header", "good_wav": "good.wav", "latin": "latin1.csv"}
for name, says in BAD_CAL.items():
    add(Case(f"calibrate-check-{name}", _at("calibrate check {NAME}", name), 2, says))
for name in ("missing", "empty", "fifo", "random", "cal_header", "empty_folder"):
    add(Case(f"calibrate-fit-{name}", _at("calibrate fit {NAME} -o {tmp}/c -q", name), 2,
             BAD_CAL[name]))
BAD_FOLDERS = {"missing": "missing.file", "text": "notes.txt", "fifo": "FIFO",
               "empty_folder": "empty-folder", "vib_one": "need at least 2",
               "vib_zeros": "silent", "vib_clipped": "clipped", "vib_dc": "constant"}
for name, says in BAD_FOLDERS.items():
    add(Case(f"train-material-{name}", _at("train material {NAME} -o {tmp}/m", name), 2, says))
for name in ("vib_zeros", "vib_one", "missing"):
    add(Case(f"train-shake-{name}", _at("train shake {NAME} -o {tmp}/m", name), 2,
             BAD_FOLDERS[name]))
for name, says in (("toml_bad", "bad.toml"), ("empty", "empty"), ("random", "random.bin"),
                   ("missing", "missing.file"), ("fifo", "FIFO")):
    add(Case(f"sim-dataset-params-{name}",
             _at("sim dataset calibration {tmp}/d -q --params {NAME}", name), 2, says))
for name, says in (("fifo", "FIFO"), ("missing", "missing.file"), ("folder", "a-folder")):
    add(Case(f"decode-{name}", _at("decode {NAME}", name), 2, says))
for name, says in (("missing", "missing.file"), ("empty", "empty"), ("random", "random.bin"),
                   ("fifo", "FIFO")):
    add(Case(f"flash-hex-{name}", _at("flash --dry-run --hex {NAME}", name), 2, says))


# --- outputs ----------------------------------------------------------------------------------
def _kept(name: str) -> Callable[[Any], str | None]:
    return lambda ws: None if ws[name].exists() else f"{name} was removed"


OUTPUTS = {"fifo": ("{fifo}", "FIFO"), "dev-full": ("/dev/full", "device"),
           "dev-null": ("/dev/null", "device"), "folder": ("{folder}", "directory"),
           "nodir": ("{nodir}/x.mcap", "does not exist")}
for name, (path, says) in OUTPUTS.items():
    add(Case(f"record-output-{name}", f"record --port {{port}} -o {path} --duration 0.5", 2,
             says),
        Case(f"repair-output-{name}", f"repair {{cut_rec}} -o {path} --force", 2, says),
        Case(f"record-from-output-{name}", f"record --from lsl -o {path} --force", 2, says))
add(Case("record-output-exists", "record --port {port} -o {rec} --duration 0.5", 2,
         "already exists"),
    Case("repair-output-exists", "repair {cut_rec} -o {rec}", 2, "already exists"),
    Case("repair-output-is-input", "repair {cut_rec} -o {cut_rec} --force", 2,
         "must not replace"),
    Case("record-output-is-audio-input",
         "record --port {port} -o {good_wav} --force --audio-file {good_wav} --duration 0.5",
         2, "also an input"),
    Case("repair-part-named-input", "repair {part_rec} -o {root}/run.mcap", 0,
         check=lambda ws: _remove(ws["root"] / "run.mcap")),
    Case("export-output-not-empty", "export {rec} -o {folder}", 2, "not empty"),
    Case("export-output-is-file", "export {rec} -o {text}", 2, "not a folder"),
    Case("export-output-fifo", "export {rec} -o {fifo}", 2, "FIFO"),
    Case("export-output-dev-null", "export {rec} -o /dev/null", 2, "device"),
    Case("export-twice", "export {rec} -o {model_dir}", 2, "not empty"),
    Case("check-report-fifo", "check --virtual --no-prompt --report {fifo}", 2, "FIFO"),
    Case("check-report-folder", "check --virtual --no-prompt --report {folder}", 2,
         "directory"),
    Case("check-report-dev-full", "check --virtual --no-prompt --report /dev/full", 2,
         "device"),
    Case("check-plot-fifo", "check --virtual --no-prompt --report {tmp}/r.json --plot {fifo}",
         2, "FIFO"),
    Case("stream-plot-png-fifo", "stream --port {port} --count 2 --plot-png {fifo}", 2,
         "FIFO"),
    Case("train-output-file", "train material {vib} -o {text}", 2, "not a folder"),
    Case("train-output-fifo", "train material {vib} -o {fifo}", 2, "FIFO"),
    Case("calibrate-fit-output-file", "calibrate fit {cal} -o {text} -q", 2, "not a folder"),
    Case("calibrate-fit-output-fifo", "calibrate fit {cal} -o {fifo} -q", 2, "FIFO"),
    Case("sim-dataset-output-file", "sim dataset vibration {text} -q", 2, "notes.txt"),
    Case("sim-dataset-output-not-empty", "sim dataset vibration {folder} -q", 2, "a-folder"),
    Case("publish-record-fifo", "publish --virtual 1 --record {fifo} --duration 1", 2,
         "FIFO"),
    Case("publish-record-exists", "publish --virtual 1 --record {rec} --duration 1", 2,
         "already exists"))


def _remove(p: Path) -> str | None:
    if not p.exists():
        return f"{p} was not written"
    p.unlink()
    return None


# --- live ports: arguments --------------------------------------------------------------------
ARGS = {
    "tare-samples-0": ("tare --port {port} --samples 0", "at least 1"),
    "tare-samples-huge": ("tare --port {port} --samples 100000", "at most 256"),
    "tare-samples-negative": ("tare --port {port} --samples -1", "at least 1"),
    "tare-samples-word": ("tare --port {port} --samples many", "invalid integer"),
    "tare-channels-letter": ("tare --port {port} --channels a", "channels"),
    "tare-channels-9": ("tare --port {port} --channels 9", "does not exist"),
    "tare-channels-repeat": ("tare --port {port} --channels 0,0", "distinct"),
    "tare-channels-16": ("tare --port {port} --channels 16", "0-15"),
    "stream-decimation-0": ("stream --port {port} --count 2 --decimation 0", "at least 1"),
    "stream-decimation-1000": ("stream --port {port} --count 2 --decimation 1000",
                               "at most 255"),
    "stream-tare-negative": ("stream --port {port} --count 2 --tare -1", "at least 1"),
    "stream-tare-0": ("stream --port {port} --count 2 --tare 0", "at least 1"),
    "stream-rate-7": ("stream --port {port} --count 2 --rate 7", "invalid choice"),
    "stream-gain-5": ("stream --port {port} --count 2 --gain 5", "invalid choice"),
    "stream-count-word": ("stream --port {port} --count x", "invalid int"),
    "info-no-port": ("info --port {noport}", "no-such-port"),
    "info-port-is-text": ("info --port {text}", "notes.txt"),
    "info-port-is-fifo": ("info --port {fifo}", "fifo"),
    "stream-no-port": ("stream --port {noport} --count 2", "no-such-port"),
    "record-no-port": ("record --port {noport} -o {tmp}/r.mcap", "no-such-port"),
    "record-name-accent": ("record --port {port} -o {tmp}/r.mcap --name índex", "ASCII"),
    "record-name-empty": ("record --port {port} -o {tmp}/r.mcap --name ''", "ROS 2 topic"),
    "record-name-dash": ("record --port {port} -o {tmp}/r.mcap --name a-b", "ROS 2 topic"),
    "record-duration-0": ("record --port {port} -o {tmp}/r.mcap --duration 0", "above 0"),
    "record-duration-nan": ("record --port {port} -o {tmp}/r.mcap --duration nan",
                            "duration"),
    "publish-name-accent": ("publish --virtual 1 --name índex --duration 1", "ASCII"),
    "publish-name-empty": ("publish --virtual 1 --name '' --duration 1", "ROS 2 topic"),
    "publish-names-count": ("publish --virtual 2 --name a --duration 1", "2 fingertips"),
    "publish-virtual-0": ("publish --virtual 0 --duration 1", "at least 1"),
    "classify-two-sources": ("classify material {model} {good_wav} --port {port}",
                             "exactly one"),
    "classify-no-port": ("classify material {model} --port {noport} --duration 1",
                         "no-such-port"),
    "check-fault-without-virtual": ("check --port {port} --fault dead_gauge", "--virtual"),
    "check-bad-fault": ("check --virtual --fault nonsense --report {tmp}/r.json",
                        "nonsense"),
    "sim-device-bad-fault": ("sim device --fault nonsense", "nonsense"),
    "experiment-trials-0": ("experiment pinch --trials 0", "at least 1"),
    "replay-speed-negative": ("replay {rec} --speed -1", "above 0"),
    "train-hidden-bad": ("train material {vib} -o {tmp}/m --hidden 0", "1..4096"),
    "train-models-bad": ("train material {vib} -o {tmp}/m --models nope", "nope"),
    "calibrate-models-bad": ("calibrate fit {cal} -o {tmp}/c --models nope", "nope"),
}
for cid, (argv, says) in ARGS.items():
    add(Case(cid, argv, 2, says))
add(Case("tare-good", "tare --port {port} --channels 0,1", 0),
    Case("info-good", "info --port {port}", 0),
    Case("stream-good", "stream --port {port} --count 3 --decimation 2", 0))

# --- network ----------------------------------------------------------------------------------
for cid, addr, says in (("port-huge", "127.0.0.1:99999", "1-65535"),
                        ("unknown-host", "nosuchhost.invalid", "unknown host"),
                        ("port-word", "127.0.0.1:abc", "1-65535"),
                        ("no-host", ":5", "no host"),
                        ("open-bracket", "'[::1'", "closing")):
    add(Case(f"rdt-{cid}", f"calibrate record --virtual --rdt {addr} --duration 5", 2, says))
add(Case("rdt-wrong-size", "calibrate record --port {port} --rdt {rdt_size} --duration 5", 2,
         "wrong size"),
    Case("rdt-status-bit", "calibrate record --port {port} --rdt {rdt_status} --duration 5",
         2, "status bit"),
    Case("rdt-nothing", "calibrate record --port {port} --rdt 127.0.0.1:9 --duration 5", 2,
         "no RDT packets"),
    Case("rdt-ipv6-nothing", "calibrate record --port {port} --rdt [::1]:9 --duration 5", 2,
         "no RDT packets"),
    Case("calibrate-record-no-reference", "calibrate record --port {port} --duration 5", 2,
         "give a reference"),
    Case("calibrate-record-csv-missing",
         "calibrate record --fingertip-csv {missing} --reference-csv {missing}", 2,
         "missing.file"))


# --- signals ----------------------------------------------------------------------------------
def _complete(name: str, required: bool = True) -> Callable[[Any], str | None]:
    """The recording ``name`` of the case is complete (``required=False``: if it exists)."""
    def check(ws) -> str | None:
        from fingertip.record import Recording

        p = ws["tmp"] / name
        if not p.exists():
            return f"{name} not written" if required else None
        rec = Recording(p)
        return None if rec.complete else f"{name} is not complete"
    return check


REC = "record --port {port} -o {tmp}/s.mcap"
for sig in ("SIGINT", "SIGTERM", "SIGHUP"):
    add(Case(f"record-{sig}", REC, 0, "recorded", proc=True, signal=sig, after=0.5,
             wait_for="recording", check=_complete("s.mcap")))
add(Case("record-SIGINT-ignored-by-parent", REC, 0, "recorded", proc=True, signal="SIGINT",
         after=0.5, wait_for="recording", sigint_ignored=True, check=_complete("s.mcap")),
    # "at start": as soon as the command's own code runs (Python's start-up before it is
    # Python's), while it imports its modules, opens the device, creates the file
    Case("record-SIGINT-at-start", REC, (0, 130), "", proc=True, signal="SIGINT",
         wait_for="handlers", check=_complete("s.mcap", required=False)),
    Case("record-SIGTERM-at-open", REC, (0, 130), "", proc=True, signal="SIGTERM",
         after=0.3, wait_for="handlers", check=_complete("s.mcap", required=False)),
    Case("record-SIGHUP-at-open", REC, (0, 130), "", proc=True, signal="SIGHUP",
         after=0.6, wait_for="handlers", check=_complete("s.mcap", required=False)),
    Case("publish-SIGINT-at-start", "publish --virtual 1 --duration 20", (0, 130), "",
         proc=True, signal="SIGINT", wait_for="handlers"),
    Case("publish-SIGTERM-at-open", "publish --virtual 1 --duration 20", (0, 130), "",
         proc=True, signal="SIGTERM", after=0.4, wait_for="handlers"),
    Case("stream-SIGTERM", "stream --port {port}", 0, "frames", proc=True, signal="SIGTERM",
         after=0.5, wait_for=" ", wait_on="stdout"),
    Case("train-SIGINT", "train material {vib} -o {tmp}/m --models baseline --augment 0", 130,
         "interrupted by SIGINT", proc=True, signal="SIGINT", after=0.2,
         wait_for="cross-validation"),
    Case("calibrate-fit-SIGHUP", "calibrate fit {cal} -o {tmp}/c -q", 130,
         "interrupted by SIGHUP", proc=True, signal="SIGHUP", after=1.5),
    Case("check-SIGINT", "check --virtual --no-prompt --report {tmp}/r.json", 130,
         "interrupted by SIGINT", proc=True, signal="SIGINT", after=2.0))


# --- the Python API ---------------------------------------------------------------------------
def _ft(ws, fn):
    from fingertip import Fingertip

    with Fingertip(str(ws["port"])) as ft:
        return fn(ft)


def _api(cid: str, call: Callable[[Any], Any], says: str,
         raises: type[BaseException] | tuple = Error) -> None:
    add(Case(f"api-{cid}", api=call, says=says, raises=raises, code=None))


_api("tare-string-channels", lambda ws: _ft(ws, lambda ft: ft.tare("0,1")), "tare channels",
     (BadArgumentError, TypeError))
_api("tare-samples-huge", lambda ws: _ft(ws, lambda ft: ft.tare(samples=100000)), "0..256")
_api("tare-channel-9", lambda ws: _ft(ws, lambda ft: ft.tare([9])), "does not exist")
_api("tare-channel-float", lambda ws: _ft(ws, lambda ft: ft.tare([0.5])), "integers")
_api("set-rate-7", lambda ws: _ft(ws, lambda ft: ft.set_rate(7)), "rate must be one of")
_api("set-decimation-0", lambda ws: _ft(ws, lambda ft: ft.set_rate(80, 0)), "decimation")
_api("set-gain-5", lambda ws: _ft(ws, lambda ft: ft.set_gain(5)), "gain must be one of")
_api("tare-offsets-count", lambda ws: _ft(ws, lambda ft: ft.set_tare_offsets([1, 2])),
     "need 4 offsets")


def _fingertip(**kw):
    from fingertip import Fingertip

    return Fingertip(**kw)


def _read_unopened(ws):
    from fingertip import Fingertip

    return Fingertip(str(ws["port"])).read()


_api("port-and-serial", lambda ws: _fingertip(port="a", serial_number="b"), "exactly one")
_api("read-never-opened", _read_unopened, "never opened")


def _open_missing(ws):
    from fingertip import Fingertip

    return Fingertip(str(ws["noport"])).open()


_api("open-missing-port", _open_missing, "no-such-port")


def _check_name(name):
    from fingertip.record.schemas import check_name

    return check_name(name)


_api("name-accent", lambda ws: _check_name("índex"), "ASCII", BadArgumentError)
_api("name-empty", lambda ws: _check_name(""), "ROS 2 topic", BadArgumentError)


def _publish_names(name, n):
    from fingertip.network.publish_sources import publish_names

    return publish_names(name, n)


_api("publish-names-empty", lambda ws: _publish_names("", 1), "ROS 2 topic")


def _repair(src, out=None, **kw):
    from fingertip.record.repair import repair

    return repair(src, out, **kw)


_api("repair-fifo", lambda ws: _repair(ws["fifo"]), "FIFO", BadFileError)
_api("repair-to-dev-null", lambda ws: _repair(ws["cut_rec"], "/dev/null", overwrite=True),
     "device", OutputRefused)
_api("repair-exists", lambda ws: _repair(ws["cut_rec"], ws["rec"]), "already exists",
     (OutputRefused, FileExistsError))


def _export(src, out, **kw):
    from fingertip.record.export import export

    return export(src, out, **kw)


_api("export-not-empty", lambda ws: _export(ws["rec"], ws["folder"], overwrite=False),
     "not empty", OutputRefused)
_api("export-magic-random", lambda ws: _export(ws["magic_rnd"], ws["tmp"] / "e"),
     "no fingertip message", BadFileError)


def _recording(p):
    from fingertip.record import Recording

    return Recording(p)


_api("recording-fifo", lambda ws: _recording(ws["fifo"]), "FIFO")
_api("recording-random", lambda ws: _recording(ws["random"]), "not an MCAP file")


def _load_folder(p):
    from fingertip.models.vibration.classifier.datasets import load_folder

    return load_folder(p)


_api("dataset-silent", lambda ws: _load_folder(ws["vib_zeros"]), "silent", BadFileError)
_api("dataset-clipped", lambda ws: _load_folder(ws["vib_clipped"]), "clipped", BadFileError)


def _classifier(p):
    from fingertip.models.vibration.classify import VibrationClassifier

    return VibrationClassifier(p)


def _force_model(p):
    from fingertip.models.force.runtime import ForceModel

    return ForceModel(p)


_api("classifier-fake", lambda ws: _classifier(ws["fake_onnx"]), "fake.onnx", BadFileError)
_api("force-model-classifier", lambda ws: _force_model(ws["model"]), "material.onnx",
     BadFileError)


def _rdt(host, port=49152):
    from fingertip.reference.rdt import RdtClient

    return RdtClient(host, port, first_packet_timeout=1.0).start()


_api("rdt-unknown-host", lambda ws: _rdt("nosuchhost.invalid"), "cannot be reached",
     NetworkError)
_api("rdt-port-huge", lambda ws: _rdt("127.0.0.1", 99999), "1-65535", NetworkError)


def _check_output(p, **kw):
    from fingertip.outputs import check_output

    return check_output(p, **kw)


_api("output-fifo", lambda ws: _check_output(ws["fifo"], force=True), "FIFO", OutputRefused)
_api("output-exists", lambda ws: _check_output(ws["rec"]), "already exists", OutputRefused)

IDS = [c.id for c in CASES]
assert len(IDS) == len(set(IDS)), "duplicate case ids"
