"""trebuchet.fmu: the trebuchet as an FMI 2.0 co-simulation FMU (see fmu/README.md).

``interface`` (the FMU's variables), ``cosim`` (communication steps answered by the
in-process simulator), ``build`` (``build_fmu``), ``crosscheck`` (``write_crosscheck``,
``reference``), ``cli`` (``trebuchet fmu build|crosscheck``). Importing this package imports
none of them, nor pythonfmu or fmpy.
"""
