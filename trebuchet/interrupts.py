"""``trebuchet.interrupts`` is :mod:`trebuchet.core.interrupts` (moved there; this path is kept so
that code written before the move still imports it: the same module object, not a copy)."""

import sys

from trebuchet.core import interrupts as _interrupts

sys.modules[__name__] = _interrupts
