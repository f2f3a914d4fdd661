"""Models, in three rooms that load alone: :mod:`.force` (the force calibration, its recording
session, the runtime force model), :mod:`.vibration` (features, mains, augmentation, the
classifiers and their decisions) and :mod:`.nets` (the networks and ONNX helpers both use).
Trained here, run with onnxruntime."""
