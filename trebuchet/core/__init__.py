"""The shared ground of the package: what every room stands on and nothing above it.

``errors`` (the input error and the warnings, messages that name the interface called),
``interrupts`` (Ctrl-C in one line), ``version``, ``user_files`` (a user's file opened only
when it is a regular file of a sane size), ``output`` (outputs written whole, never over a
user's) and ``csv_table`` (the CSV writer). The model, the ingest path, the FMU, the reports
and the command line import from here; this room imports none of them. The old paths
(``trebuchet.core.errors``, ...) are the same modules (aliases kept for code written before it).
"""
