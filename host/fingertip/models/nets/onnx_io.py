"""ONNX in and out, in one place: writing a graph to a file (needs the ``onnx`` package, the
``train`` extra) and opening a file in onnxruntime with the project's session options."""
from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from ...badfile import BadFileError, require_file
from ...outputs import atomic_output


def onnx_builder() -> tuple[Any, Any, Any, Any]:
    """``(onnx, TensorProto, helper, numpy_helper)``, or a clear ImportError: the runtime
    needs only onnxruntime, exporting needs the onnx package."""
    try:
        import onnx
        from onnx import TensorProto, helper, numpy_helper
    except ImportError as e:
        raise ImportError("exporting needs the 'onnx' package: pip install 'fingertip[train]'"
                          ) from e
    return onnx, TensorProto, helper, numpy_helper


def batch_graph(nodes: list, name: str, inp: tuple[str, int], out: tuple[str, int],
                inits: list) -> Any:
    """A graph from ``nodes`` taking float32 rows ``(batch, inp[1])`` named ``inp[0]`` to
    rows ``(batch, out[1])`` named ``out[0]`` (any batch size)."""
    _, TensorProto, helper, _ = onnx_builder()
    return helper.make_graph(
        nodes, name,
        [helper.make_tensor_value_info(inp[0], TensorProto.FLOAT, ["batch", inp[1]])],
        [helper.make_tensor_value_info(out[0], TensorProto.FLOAT, ["batch", out[1]])], inits)


def save_graph(graph: Any, path: str | Path, metadata: dict[str, Any], opset: int = 17) -> Path:
    """Wrap ``graph`` in a model (opset ``opset``, IR version at most 9 so that older runtimes
    read it too), store ``metadata`` as string properties (non-strings as JSON), check it,
    and write it to ``path`` (parent folders created)."""
    onnx, _, helper, _ = onnx_builder()
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)],
                              producer_name="fingertip")
    model.ir_version = min(model.ir_version, 9)
    helper.set_model_props(model, {k: v if isinstance(v, str) else json.dumps(v)
                                   for k, v in metadata.items()})
    onnx.checker.check_model(model)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:  # a reader never sees half a model
        onnx.save(model, str(tmp))
    return path


def open_session(path: str | Path, threads: int = 1, *, what: str = "model file") -> Any:
    """An onnxruntime CPU session on ``path``: FileNotFoundError when it is missing
    ("no {what} at ..."), :class:`~fingertip.badfile.BadFileError` (a ValueError) when it is
    empty, a folder, or not an ONNX graph onnxruntime can load."""
    import onnxruntime as ort

    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads must be an integer >= 1, not {threads!r}")
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no {what} at {path}")
    require_file(path, what)
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads  # a control loop wants one predictable core
    opts.inter_op_num_threads = 1
    # No spin-waiting: a frame arrives every few ms, and spinning threads between runs
    # would burn a core's worth of cycles for nothing.
    opts.add_session_config_entry("session.intra_op.allow_spinning", "0")
    opts.add_session_config_entry("session.inter_op.allow_spinning", "0")
    opts.log_severity_level = 3
    try:
        return ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
    except Exception as e:  # onnxruntime raises its own exception types
        raise BadFileError(f"{path} is not a usable ONNX model ({_ort_reason(e)})", path
                           ) from e


def _ort_reason(e: Exception) -> str:
    """onnxruntime's message without its prefix and the path repeated: "[ONNXRuntimeError] :
    7 : INVALID_PROTOBUF : Load model from X failed:Protobuf parsing failed." ->
    "INVALID_PROTOBUF: Protobuf parsing failed."."""
    text = str(e)
    m = re.search(r"\[ONNXRuntimeError\]\s*:\s*\d+\s*:\s*(\w+)\s*:\s*(.*)", text, re.S)
    if not m:
        return text
    detail = re.sub(r"^Load model from .*? failed:\s*", "", m.group(2), flags=re.S)
    return f"{m.group(1)}: {detail}"
