"""A sample of the fuzz corpus of hostile and careless user files (bench/fuzz_inputs.py, the
whole corpus in ``make bench``): every finding of issue 21 and a few cases drawn by the
seed, each in a worker process with a 60 s limit. None may end in a traceback, a hang, a
silent change, raw terminal control bytes or code run from the file."""

from __future__ import annotations

import pytest

pytest.importorskip("h5py")


def test_a_sample_of_the_fuzz_corpus_is_refused_or_named_never_wrong(tmp_path):
    from bench._fuzz_cases import all_cases
    from bench.fuzz_inputs import BAD, SEED, run_cases, sample

    cases = sample(all_cases(tmp_path, SEED))
    results = run_cases(cases, tmp_path)
    bad = results[results["outcome"].isin(BAD)]
    assert bad.empty, bad[["case", "outcome", "detail"]].to_string()
    assert set(results["outcome"]) <= {"refused", "warned", "identical", "accepted"}
    by = dict(zip(results["case"], results["outcome"], strict=True))
    assert by["log/horsdal_240fps.csv/angle_outlier_90deg"] == "warned"
    assert by["scene/horsdal_large.toml/L4=1mm"] == "refused"
    assert by["log/fifo"] == "refused"
