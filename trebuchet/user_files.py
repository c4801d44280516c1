"""``trebuchet.user_files`` is :mod:`trebuchet.core.user_files` (moved there; this path is kept so
that code written before the move still imports it: the same module object, not a copy)."""

import sys

from trebuchet.core import user_files as _user_files

sys.modules[__name__] = _user_files
