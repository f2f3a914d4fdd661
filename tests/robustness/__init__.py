"""Bad inputs and faults, one row per case (issue 28): :mod:`.cases` is the table,
:mod:`.workspace` the files and ports it runs against, :mod:`.harness` runs and judges a row.
``tests/bench/bench_robustness.py`` counts the same table for ``make bench``."""
