"""The native FMU under abuse: hostile call sequences in a C host, AddressSanitizer and UBSan.

The fuzz corpus of :mod:`trebuchet.fmu.abuse_corpus` (seed 1: 400 corrupted serialised
states, every word of a state's structured part behind a right checksum, states of another
instance or none, NULL in every pointer argument of every function and a NULL instance,
NaN / infinite / huge / tiny / negative times, steps, states and parameters, bad types and
tokens, calls after errors, steps beyond the horizon, 400 random call orders; FMI 2.0 and
3.0, co-simulation and model exchange) runs in ``fmu/host/fmu_abuse.c``, the FMU's
libraries and the host compiled with ``-fsanitize=address,undefined
-fno-sanitize-recover=all``, every case in its own child process. A case still running after
60 s is a hang. ``run(out_dir)`` writes ``fmu_abuse_cases.csv`` (one row per case) and returns
the table by family of cases (targets: 0 crashes, 0 hangs, 0 sanitizer reports);
``python -m bench fmu_abuse`` runs it.
"""

from __future__ import annotations

import platform
import tempfile
from pathlib import Path

import pandas as pd

from trebuchet.fmu import abuse_corpus
from trebuchet.fmu.abuse import SANITIZE_FLAGS, AbuseRun, build_abuse, run_abuse

SEED = 1
RANDOM_CASES = 400
HANG_S = 60.0
COUNTS = {"calls": "calls", "crashes": "crash", "hangs": "hang",
          "sanitizer_reports": "sanitizer", "nan_with_ok": "nan_ok",
          "ok_after_error": "after_error", "errors_not_logged": "silent_error"}


def table(result: AbuseRun) -> pd.DataFrame:
    """Counts by family of cases, and in total."""
    rows = []
    families = sorted({c.family for c in result.cases})
    for family in [*families, "total"]:
        cases = [c for c in result.cases if family in ("total", c.family)]
        row = {"family": family, "cases": len(cases)}
        row.update({k: result.count(v, cases) for k, v in COUNTS.items()})
        row["slowest_case_s"] = max(c.ms for c in cases) / 1e3
        rows.append(row)
    return pd.DataFrame(rows)


def run(out_dir: Path) -> pd.DataFrame:
    with tempfile.TemporaryDirectory(prefix="fmu_abuse_") as tmp:
        folder = Path(tmp)
        build = build_abuse(folder / "build", sanitize=True)
        cases = abuse_corpus.corpus(SEED, RANDOM_CASES)
        corpus = abuse_corpus.write_corpus(folder / "corpus.txt", cases)
        result = run_abuse(build, corpus, timeout=HANG_S)
    pd.DataFrame([{"case": c.name, "result": c.result, "calls": c.calls, "nan_ok": c.nan_ok,
                   "after_error": c.after_error, "silent_error": c.silent_error, "ms": c.ms,
                   "last": c.last, "detail": c.detail} for c in result.cases]
                 ).to_csv(out_dir / "fmu_abuse_cases.csv", index=False)
    out = table(result)
    out.attrs["notes"] = [
        f"corpus: seed {SEED}, {len(cases)} cases ({RANDOM_CASES} corrupted states, "
        f"{RANDOM_CASES} random call orders and the fixed families); a case is a hang after "
        f"{HANG_S:g} s",
        f"build: gcc {' '.join(SANITIZE_FLAGS)}; machine {platform.machine()}, "
        f"{result.seconds:.0f} s for the whole corpus",
        "targets: 0 crashes, 0 hangs, 0 sanitizer reports; nan_with_ok, ok_after_error and "
        "errors_not_logged: 0 too",
    ]
    return out


if __name__ == "__main__":
    print(run(Path.cwd()).to_string(index=False))
