"""The vibration classifiers' parts, one job each: :mod:`.datasets` (labelled folders, splits
by recording), :mod:`.windows` (windows and the features a model takes), :mod:`.training`
(what a fit needs around it), :mod:`.evaluation` (accuracy, confusion, comparisons) and
:mod:`.voting`; :mod:`fingertip.models.vibration.classify` runs a trained model and keeps
their names.
"""
