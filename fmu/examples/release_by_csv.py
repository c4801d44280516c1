"""Example: fmpy's ``simulate_fmu`` with a CSV input that drives the release command.

    python fmu/examples/release_by_csv.py Trebuchet.fmu out.csv [COMMAND_TIME]

Writes the input CSV (``time, release_command``: 0, then 1 from COMMAND_TIME s), simulates
1.5 s at 1 ms communication steps, and writes every output to ``out.csv``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu
from fmpy.util import read_csv, write_csv


def main(fmu: str, out: str, command_time: float = 0.85) -> np.ndarray:
    """Simulate ``fmu`` with the release command rising at ``command_time`` (s)."""
    inputs = Path(out).with_name(Path(out).stem + "_in.csv")
    inputs.write_text(f"time,release_command\n0,0\n{command_time!r},1\n1.5,1\n")
    result = simulate_fmu(fmu, stop_time=1.5, output_interval=1e-3, input=read_csv(inputs))
    if result["time"][-1] < 1.5 - 1e-9:  # fmpy truncates silently when a step is discarded
        raise RuntimeError(f"simulation stopped at {result['time'][-1]} s")
    write_csv(out, result)
    released = result["time"][np.argmax(result["phase"] == 3)]
    print(f"release command at {command_time} s; phase 3 from {released:.4f} s")
    return result


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *(float(a) for a in sys.argv[3:4]))
