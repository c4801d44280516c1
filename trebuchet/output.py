"""``trebuchet.output`` is :mod:`trebuchet.core.output` (moved there; this path is kept so
that code written before the move still imports it: the same module object, not a copy)."""

import sys

from trebuchet.core import output as _output

sys.modules[__name__] = _output
