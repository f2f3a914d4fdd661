"""Studies: experiments that use the ``fingertip`` library to answer a question and feed the
benchmarks (tests/bench) and the docs' figures. They live outside the package: the library
never imports them.

- :mod:`.paper_method`: the paper's calibration and vibration methods on virtual units;
- :mod:`.reflex_eval`: contact reflexes (piezo onset, force, fused) on simulated sessions;
- :mod:`.pinch_speed`: the pinch recipe at approach speed, per contact detector;
- :mod:`.latency_budget`: where the firmware's time goes, the real ELF in simavr;
- :mod:`.sim_speed`: simulated seconds per wall second of the physics, per scene.
"""
