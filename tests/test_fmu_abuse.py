"""The native FMU under abuse (issue 21): hostile call sequences in the C abuse host
(fmu/host/fmu_abuse.c), every case in a child process. Each test runs a few families of the
fuzz corpus (trebuchet.fmu.abuse_corpus) and asserts no crash, no hang, no non-finite value
returned with OK, no call going on after an error, no error without a logged message, and
the refusals the FMU must log. A plain build here, to stay quick; ``python -m bench
fmu_abuse`` runs the whole corpus with AddressSanitizer and UBSan (docs/benchmarks.md).
Each test fails on the code before issue 21 (crashes, hangs, NaN with OK, steps after an
error)."""

from __future__ import annotations

import random
import shutil
from pathlib import Path

import numpy as np
import pytest

from trebuchet.fmu import abuse_corpus as ac
from trebuchet.fmu.abuse import AbuseBuild, AbuseRun, build_abuse, run_abuse

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


@pytest.fixture(scope="module")
def build(tmp_path_factory, fmu_path) -> AbuseBuild:
    """The FMU's FMI 2 and 3 libraries and the host (from the session's FMU's sources: no
    second code generation)."""
    return build_abuse(tmp_path_factory.mktemp("abuse"), sanitize=False, fmu=fmu_path)


def run(build: AbuseBuild, cases: list[ac.Case], folder: Path) -> AbuseRun:
    corpus = ac.write_corpus(folder / "corpus.txt", cases)
    return run_abuse(build, corpus, timeout=20.0, log=True)


def assert_clean(result: AbuseRun) -> None:
    bad = [(c.name, c.result, c.nan_ok, c.after_error, c.silent_error, c.last, c.detail)
           for c in result.failures()]
    assert not bad, bad[:5]


def logged(result: AbuseRun, name: str) -> str:
    return "\n".join(next(c for c in result.cases if c.name == name).log)


def test_corrupted_serialised_states_are_refused_never_trusted(build, tmp_path):
    """Before: heap-buffer-overflow in dop_step, out-of-bounds indexes, wild pointers, a UB
    shift on a corrupted state. Now every word of the state's structured part set to an
    extreme value behind a right checksum, random corruptions and truncations: refused with
    a message, or (a number that is merely wrong) run on without harm."""
    rng = random.Random(7)
    cases = [*ac.states(rng, 24), *ac.fields(rng, per_case=32, stride=7),
             *ac.state_misuse(rng)]
    result = run(build, cases, tmp_path)
    assert_clean(result)
    refusals = "\n".join(line for c in result.cases for line in c.log)
    for reason in ("checksum does not match", "not a serialised state of this FMU",
                   "the shot's scene is not the one its parameters give",
                   "not an FMU state of this instance"):
        assert reason in refusals


def test_every_pointer_argument_is_checked(build, tmp_path):
    """Before: fmi2GetRealStatus(c, NULL) and fmi2SerializedFMUstateSize(c, s, NULL) crashed.
    Now NULL in each pointer argument of every function (FMI 2 and 3), and a NULL instance
    in every function, is an error (logged where there is an instance)."""
    result = run(build, ac.nulls(), tmp_path)
    assert_clean(result)
    assert "fmi2GetRealStatus: value is NULL" in logged(result, "null-2cs-running")
    assert "fmiSerializedFMUstateSize: the pointer to the size is NULL" in logged(
        result, "null-2cs-running")
    assert "fmi3DoStep: lastSuccessfulTime is NULL" in logged(result, "null-3cs-running")


def test_nan_infinite_huge_and_negative_numbers(build, tmp_path):
    """Before: a step of inf, 1e9 or 1e300 or a start time of inf ran away, a NaN step or
    time, a negative communication point, NaN states or times in model exchange returned NaN
    with OK. Now each is refused (or stopped at the horizon) with a message."""
    numbers = ac.numbers()
    cases = [c for c in numbers if c.name.split("-")[0] in ("step", "start", "time", "setx")]
    result = run(build, cases, tmp_path)
    assert_clean(result)
    assert "communication point nan s" in logged(result, "step-2-nan-1e-3")
    assert "communication point -1 s" in logged(result, "step-3--1-1e-3")
    assert "start time = inf s" in logged(result, "start-2cs-inf")
    assert "fmiSetTime: t = nan s" in logged(result, "time-2-nan-1")
    assert "continuous states at t = " in logged(result, "setx-3-0-nan")


def test_a_step_beyond_the_horizon_stops_there_at_once(build, tmp_path):
    """Before: phase III integrated without limit (1e4 s took 1.3 s; 1e9 s hung). Now a step
    ends at the FMU's horizon (60 s after the trigger) with fmi2Discard / fmi3Discard and
    terminateSimulation, and no further step is accepted."""
    result = run(build, ac.runaway(), tmp_path)
    assert_clean(result)
    for case in result.cases:
        assert case.ms < 5000.0, (case.name, case.ms)  # a 60 s shot: milliseconds (1e9: hung)
    text = logged(result, "runaway-2-1e9-0")
    assert "2 fmiDoStep: t + h = 1e+09 s lies beyond the FMU's horizon of 60 s" in text
    assert "fmi2DoStep may not be called in this state (stopped at the horizon)" in text


def test_parameters_are_checked_as_the_scene_checks_them(build, tmp_path):
    """Before: L1 = 1e308 or L4 = 5e-324 gave NaN outputs with OK. Now every parameter is
    finite (refused where it is set), in the range of modelDescription.xml and not below the
    smallest length or mass the FMU takes (refused at fmi2ExitInitializationMode), and an
    Enumeration outside its choices (fmuType's cousin, projectile = 77) is refused."""
    cases = [c for c in ac.numbers() if c.name.startswith("param-")
             and any(k in c.name for k in ("engine.L1-", "engine.L4-", "start.projectile-",
                                           "flight.model-", "environment.g-"))]
    result = run(build, cases, tmp_path)
    assert_clean(result)
    assert "[engine] L1: = 1e+308 m: must lie between 0 and 100 m" in logged(
        result, "param-2me-engine.L1-1e308")
    assert "[engine] L4: = 4.94066e-324 m: below 0.001 m" in logged(
        result, "param-3cs-engine.L4-5e-324")
    assert "engine.L1 = nan: must be finite" in logged(result, "param-2cs-engine.L1-nan")
    assert "[start] projectile: = 77: must be one of the choices 1 to 3" in logged(
        result, "param-3me-start.projectile-77")


def test_bad_types_tokens_and_calls_after_an_error(build, tmp_path):
    """Before: fmuType = 77 was accepted and fmi2DoStep went on after a call had returned
    fmi2Error. Now a bad type or token gives no instance, and after an error only reads,
    the FMU state functions, terminate, reset and free are allowed."""
    result = run(build, [*ac.types(), *ac.after_errors()], tmp_path)
    assert_clean(result)
    assert "fmuType = 77: must be fmi2ModelExchange (0) or fmi2CoSimulation (1)" in logged(
        result, "type-2-77")
    text = logged(result, "after-error-2-step_cur_nan")
    assert "fmi2DoStep may not be called in this state (error)" in text


def test_a_sample_of_random_call_orders(build, tmp_path):
    """Random calls in random order with random arguments on two instances."""
    result = run(build, ac.random_orders(random.Random(3), 40), tmp_path)
    assert_clean(result)
    assert result.count("calls") > 400


def test_the_corpus_is_the_same_for_a_seed(tmp_path):
    first = ac.write_corpus(tmp_path / "a.txt", ac.corpus(5, 20)).read_text()
    again = ac.write_corpus(tmp_path / "b.txt", ac.corpus(5, 20)).read_text()
    other = ac.write_corpus(tmp_path / "c.txt", ac.corpus(6, 20)).read_text()
    assert first == again != other


def test_fmpy_ends_a_run_past_the_horizon_there(fmu_path):
    """fmpy's co-simulation past the horizon ends there (fmi2Discard, fmi2Terminated): the
    last row is at 60 s and equals a run stepped to 60 s exactly. Its model exchange ends
    at the horizon's time event (terminateSimulation), also with the flight with drag that
    the FMU integrates itself."""
    from fmpy import simulate_fmu

    log: list[tuple[int, str]] = []

    def logger(component, instance, status, category, message):  # noqa: ANN001, ANN202
        log.append((status, message.decode()))

    # A logger of our own: fmpy's logging proxy keeps one global logger, left dangling by
    # an earlier simulate_fmu(logger=...) whose callback is gone.
    long = simulate_fmu(str(fmu_path), stop_time=61.0, output_interval=0.5, logger=logger)
    exact = simulate_fmu(str(fmu_path), stop_time=60.0, output_interval=0.5, logger=logger)
    assert long["time"][-1] == pytest.approx(60.0)
    assert (2, log[0][1]) == log[0] and "horizon of 60 s" in log[0][1]  # fmi2Discard
    for name in ("theta", "F_R_y", "E_beam"):
        np.testing.assert_array_equal(long[name][-1], exact[name][-1])
    me = simulate_fmu(str(fmu_path), stop_time=65.0, output_interval=0.5, logger=logger,
                      fmi_type="ModelExchange", start_values={"flight.model": 2,
                                                              "flight.diameter": 0.3})
    assert me["time"][-1] == pytest.approx(60.0) and np.isfinite(me["x_m"]).all()
