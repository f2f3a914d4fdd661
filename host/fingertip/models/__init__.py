"""Models: force calibration and vibration classifiers, trained here, run with onnxruntime."""
from .mlp import MLP, OnnxModel, to_onnx, train_mlp

__all__ = ["MLP", "OnnxModel", "to_onnx", "train_mlp"]
