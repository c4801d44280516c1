"""``trebuchet.version`` is :mod:`trebuchet.core.version` (moved there; this path is kept so
that code written before the move still imports it: the same module object, not a copy)."""

import sys

from trebuchet.core import version as _version

sys.modules[__name__] = _version
