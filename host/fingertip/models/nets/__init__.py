"""The networks and helpers both force and vibration use: logistic regression (:mod:`.linear`),
MLPs (:mod:`.mlp`), small CNNs (:mod:`.cnn`), ONNX graphs and sessions (:mod:`.onnx_io`), the
trainers' figures (:mod:`.figures`) and the keys of fits cached on disk (:mod:`.fit_cache`).
Nothing here imports :mod:`..force` or :mod:`..vibration`."""
