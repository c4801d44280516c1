"""A command line that starts at once, and stops at once.

What is imported is checked in fresh interpreters (not timed: a timing on a shared machine
proves little; `make bench`'s cli_speed measures the ratio): ``import trebuchet`` imports
neither numpy nor scipy, the simulator no scipy.integrate, and ``trebuchet --help`` and the
usage errors nothing heavy at all. Ctrl-C, sent at moments of a real ``trebuchet forces``,
prints one line and ends with status 130.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from trebuchet.cli import main
from trebuchet.core import interrupts

from .conftest import HORSDAL, ROOT

HEAVY = ("numpy", "pandas", "scipy", "numba", "matplotlib", "filterpy", "sympy", "fmpy")
COMMAND = Path(sys.executable).with_name("trebuchet")


def loaded_after(code: str) -> set[str]:
    """The top-level packages of HEAVY imported by ``code`` in a fresh interpreter (plus
    ``scipy.integrate`` and ``scipy.optimize`` when those are)."""
    probe = (f"import sys\n{code}\n"
             "import json\n"
             f"heavy = {{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r})\n"
             "heavy |= {m for m in ('scipy.integrate', 'scipy.optimize') if m in sys.modules}\n"
             "print(json.dumps(sorted(heavy)), file=sys.__stderr__)\n")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=120, cwd=ROOT)
    return set(json.loads(done.stderr.strip().splitlines()[-1]))


def test_import_trebuchet_loads_neither_numpy_nor_scipy():
    assert loaded_after("import trebuchet") == set()


def test_the_public_names_load_on_first_use():
    import trebuchet as tb

    assert {"Scene", "simulate", "forces", "read_log", "reconstruct"} <= set(dir(tb))
    assert tb.Scene.from_toml(HORSDAL).engine.M == 19100.0
    from trebuchet import Engine, simulate

    assert callable(simulate) and Engine is tb.Engine
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        tb.nothing  # noqa: B018


def test_the_simulator_imports_no_scipy_integrate():
    """The DOP853 tableau is scipy's own file, read without scipy.integrate's package."""
    assert not loaded_after("import trebuchet.model.simulate") & {"scipy.integrate",
                                                                   "scipy.optimize"}


def test_the_tableau_is_scipys():
    from scipy.integrate._ivp import dop853_coefficients as scipy_table

    from trebuchet.model.dop853_tableau import _tableau

    sys.modules.pop("scipy.integrate._ivp.dop853_coefficients")
    try:
        ours = _tableau()
    finally:
        sys.modules["scipy.integrate._ivp.dop853_coefficients"] = scipy_table
    assert ours is not scipy_table and ours.N_STAGES == 12 and ours.INTERPOLATOR_POWER == 7
    for name in ("A", "B", "C", "E3", "E5", "D"):
        np.testing.assert_array_equal(getattr(ours, name), getattr(scipy_table, name))


@pytest.mark.parametrize("argv", [
    ["--help"], [], ["nonsense"], ["forces"], ["forces", "--help"], ["compare", "--help"],
    ["simulate", "s.toml", "-o", "x.csv", "--dt", "5"], ["sweep", "--accuracy", "sloppy"],
    ["report"], ["paper", "--bogus"], ["fmu", "build", "--fmi", "5"], ["design", "--help"],
    ["design", "s.toml", "-o", "b.toml", "--vary", "engine.L4=3:8"],
    ["sweep", "s.toml", "--grid", "engine.M=1", "-o", "x.csv", "--memory-budget", "lots"],
    ["forces", "x.csv", "--scene", "s.toml", "-o", "y.csv", "--form", "bent"],
    ["identify", "--help"], ["identify", "x.csv"],
    ["forces", "x.csv", "--scene", "s.toml", "-o", "y.csv", "--method", "guess"],
], ids=lambda argv: " ".join(argv) or "(none)")
def test_help_and_usage_errors_import_nothing_heavy(argv):
    code = (f"sys.argv = ['trebuchet', *{argv!r}]\n"
            "from trebuchet.cli import main\n"
            "try:\n    main()\nexcept SystemExit as exc:\n    assert exc.code in (0, 2), exc.code")
    assert loaded_after(code) == set()


# --------------------------------------------------------------------------- Ctrl-C


def _interrupted_forces(tmp_path: Path, delay: float) -> subprocess.CompletedProcess:
    """``trebuchet forces`` on the shipped sample, sent SIGINT ``delay`` s after its start
    (to its process group, as a terminal's Ctrl-C; SIGINT at its default in the child, even
    where the test runs with it ignored)."""
    out = tmp_path / "loads.csv"
    proc = subprocess.Popen(
        [str(COMMAND), "forces", str(ROOT / "data_samples" / "horsdal_240fps.csv"), "--scene",
         str(HORSDAL), "-o", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, cwd=tmp_path, start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    return subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)


@pytest.mark.skipif(not COMMAND.exists(), reason="no trebuchet command beside this Python")
@pytest.mark.parametrize("delay", [0.3, 0.6, 1.0])
def test_ctrl_c_prints_one_line_and_exits_130(tmp_path, delay):
    """At 0.3 s the command is importing numpy and pandas; later, numba, filterpy and the
    reconstruction (the whole run takes about 2 s)."""
    done = _interrupted_forces(tmp_path, delay)
    assert (done.returncode, done.stderr, done.stdout) == (130, "trebuchet: interrupted\n", "")
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no output, no temporary file


def test_an_interrupt_raised_inside_a_command_is_one_line_too(monkeypatch, capsys):
    import trebuchet.model.cli as model_cli

    def stop(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(model_cli, "_paper", stop)
    before = signal.getsignal(signal.SIGINT)
    assert main(["paper"]) == 130
    assert capsys.readouterr().err == "trebuchet: interrupted\n"
    assert signal.getsignal(signal.SIGINT) is before  # a caller's Ctrl-C is its own again


#: A module whose initialisation is interrupted and, as a compiled module's does (scipy's
#: HiGHS wrapper, seen at 0.3 s), turns the interrupt into an ImportError.
_CONVERTING_MODULE = """
import os, signal, time
try:
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(5)
except BaseException as exc:
    raise ImportError("initialization failed") from exc
"""


def test_ctrl_c_inside_an_import_that_converts_it_is_one_line(tmp_path):
    """The command's handler ends the process where the interrupt lands inside an import:
    unwound, it came out as ``ImportError: initialization failed`` and a traceback, exit 1."""
    (tmp_path / "converting.py").write_text(_CONVERTING_MODULE)
    code = ("import sys; from trebuchet.core.interrupts import catch_interrupts; "
            "catch_interrupts(); import converting; print('went on')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=60, env={**os.environ, "PYTHONPATH": str(tmp_path)},
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert (done.returncode, done.stderr, done.stdout) == (130, "trebuchet: interrupted\n", "")


def test_only_the_command_takes_ctrl_c():
    """``import trebuchet`` in a program leaves its Ctrl-C alone."""
    assert not interrupts.started_as_command()
    done = subprocess.run([sys.executable, "-c", "import signal, trebuchet, trebuchet.cli; "
                           "print(signal.getsignal(signal.SIGINT) is "
                           "signal.default_int_handler)"], capture_output=True, text=True,
                          timeout=60)
    assert done.stdout.strip() == "True"
