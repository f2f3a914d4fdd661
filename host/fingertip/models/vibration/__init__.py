"""Vibration: spectrogram features (:mod:`.features`, :mod:`.mains`), augmentation, the
classifiers (:mod:`.classify` runs the parts in :mod:`.classifier`; :mod:`.material` and
:mod:`.shake` train them, :mod:`.candidates` and :mod:`.ensemble` are what they choose from),
anytime decisions (:mod:`.anytime`), probability calibration (:mod:`.reliability`) and the live
session (:mod:`.live_classify`)."""
