"""The force calibration's parts, one job each; :mod:`fingertip.models.force.calibrate` runs them in
order (:func:`~fingertip.models.force.calibrate.fit_calibration`) and keeps their public names.

:mod:`.limits` and :mod:`.errors` (what data is held to and why it is refused), :mod:`.data`
(loading), :mod:`.checks` (can it determine a map?), :mod:`.split` (held-out cells),
:mod:`.maps` (fitting affine, polynomial and MLP maps; their ONNX graphs), :mod:`.evaluate`
(error, latency, float32), :mod:`.select` (the choice), :mod:`.report` (JSON, Markdown, figure).
"""
