"""trebuchet.fmu: the trebuchet as a native FMI 2.0 / 3.0 FMU (see fmu/README.md).

``interface`` (the FMU's variables), ``codegen`` (C of the model's formulas, generated from its
Python with sympy), ``engine_formulas`` (the in-process engine's: every column of ``simulate``'s
rows), ``csources`` (every C source of the FMU), ``model_description``, ``build``
(``build_fmu``: compile and zip), ``crosscheck`` (``write_crosscheck``, ``reference``), ``cli``
(``trebuchet fmu build|crosscheck``). Importing this package imports none of them, nor sympy
or fmpy.
"""
