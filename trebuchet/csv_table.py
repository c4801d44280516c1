"""``trebuchet.csv_table`` is :mod:`trebuchet.core.csv_table` (moved there; this path is kept so
that code written before the move still imports it: the same module object, not a copy)."""

import sys

from trebuchet.core import csv_table as _csv_table

sys.modules[__name__] = _csv_table
