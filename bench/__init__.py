"""Benchmarks: ``python -m bench [NAME ...]`` (or ``make bench``) runs each module's
``run(out_dir) -> DataFrame`` and writes ``bench/results/NAME.md`` and ``NAME.csv``."""
