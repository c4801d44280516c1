"""``trebuchet.errors`` is :mod:`trebuchet.core.errors` (moved there; this path is kept so
that code written before the move still imports it: the same module object, not a copy)."""

import sys

from trebuchet.core import errors as _errors

sys.modules[__name__] = _errors
