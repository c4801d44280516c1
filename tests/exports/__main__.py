"""``python -m tests.exports DIR``: write every export fixture into DIR and list them."""

from __future__ import annotations

import sys

from . import write_all

if __name__ == "__main__":
    folder = sys.argv[1] if len(sys.argv) > 1 else "exports_out"
    for name, truth in write_all(folder).items():
        print(f"{name:38s} {truth.tool:10s} {len(truth.t):4d} rows  {truth.layout}")
