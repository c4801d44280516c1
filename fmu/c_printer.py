"""The printer of the generated C: sympy's C99 printer with every float literal printed to
round-trip, and, for the friction's formulas, small powers as products and ``sqrt``."""

from __future__ import annotations

from typing import Any

__all__ = ["c_printer"]

#: Powers that the friction's formulas print with products and ``sqrt`` instead of ``pow``
#: (a call into libm that gcc does not inline but for the square): exponent, C of ``b``.
_POWERS = {3: "({b}*{b}*{b})", 4: "({b}*{b}*{b}*{b})", 6: "({b}*{b}*{b}*{b}*{b}*{b})",
           -6: "(1.0/({b}*{b}*{b}*{b}*{b}*{b}))", -2: "(1.0/({b}*{b}))",
           -3: "(1.0/({b}*{b}*{b}))", -4: "(1.0/({b}*{b}*{b}*{b}))", 0.5: "sqrt({b})",
           -0.5: "(1.0/sqrt({b}))", 1.5: "({b}*sqrt({b}))", -1.5: "(1.0/({b}*sqrt({b})))",
           2.5: "({b}*{b}*sqrt({b}))"}


def c_printer(products: bool = False):  # noqa: ANN202 - sympy's printer class
    """sympy's C99 printer; ``products``: the :data:`_POWERS` without ``pow`` (the same
    numbers to rounding: used for the friction's formulas only, so that a frictionless
    engine keeps its numbers bit for bit)."""
    from sympy.printing.c import C99CodePrinter

    class Printer(C99CodePrinter):
        """C99 with every float literal printed to round-trip (``repr``)."""

        def _print_Float(self, expr: Any) -> str:
            return repr(float(expr))

        def _print_Pow(self, expr: Any) -> str:
            e = expr.exp
            if products and e.is_Rational and float(e) in _POWERS:
                return _POWERS[float(e)].format(b=f"({self._print(expr.base)})")
            return super()._print_Pow(expr)

    return Printer()
