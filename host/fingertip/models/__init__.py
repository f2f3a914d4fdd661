"""Models: force calibration and vibration classifiers, trained here, run with onnxruntime."""
from .force import ForceModel, ForceStatus
from .mlp import MLP, OnnxModel, to_onnx, train_mlp

__all__ = ["MLP", "ForceModel", "ForceStatus", "OnnxModel", "to_onnx", "train_mlp"]
