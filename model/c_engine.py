"""The simulator's engine: the FMU's C, generated from the model's formulas, run in process.

``trebuchet fmu build`` generates C from the model's Python (:mod:`trebuchet.fmu.codegen`,
sympy: no formula is typed twice) and runs it with the hand-written DOP853 glue of
``fmu/c/treb_shot.c`` (scipy's tableau, error norm, step control and dense output, the
numba kernel's and the pure-Python integrator's method). This module runs the same C in
process: a shot integrated through its phases (:class:`CShot`), every column of
``simulate``'s table at many times in one call (``treb_batch.c``: a C loop writing one
float64 block, no Python per row), and the figures of a design reduced in C without a table.

The library is built by :mod:`trebuchet.fmu.engine_build` (sympy, then gcc) at install
(``make install`` runs ``trebuchet.warm_up``) and cached in ``__pycache__`` beside this module
under a digest of every file it is built from; a library of other sources is never loaded, and
the first call after a change builds it again (in a subprocess, one process at a time, ~20 s),
as numba rebuilds its cache. Without a C compiler :func:`available` is False and ``simulate``
runs the numba kernel (:mod:`trebuchet.model.shot_kernel`) with one line on stderr.

Loaded with ctypes: the standard library's, and a shot is one call (a table one more), so
cffi's cheaper calls would buy microseconds for a new dependency.
"""

from __future__ import annotations

import ctypes
import fcntl
import hashlib
import importlib.util
import math
import os
import shutil
import subprocess
import sys
import weakref
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import dynamics, flight, forces, friction, kinematics, phase_events, scene
from trebuchet.model.flight import projectile_in_flight
from trebuchet.model.forces import FRICTION_COLUMNS, ROW_COLUMNS, projectile_energy
from trebuchet.model.friction import has_friction
from trebuchet.model.scene import Scene

__all__ = ["EngineUnavailable", "available", "require", "library", "library_path", "CShot",
           "CPhase", "Table", "scene_numbers",
           "ANGLE_NAMES", "ROW_NAMES", "PARAMETER_NAMES", "table_names", "FIGURES_C"]

#: Angles, rates, accelerations: the first columns of every row (rad, rad/s, rad/s²).
ANGLE_NAMES = ("theta", "psi", "phi", "theta_d", "psi_d", "phi_d", "theta_dd", "psi_dd",
               "phi_dd")
#: The columns the C computes for a row, in its order (checked against the library's): the
#: table's, then the height of the counterweight's centre (m).
ROW_NAMES = (*ANGLE_NAMES, *ROW_COLUMNS, "E_loss_pivot", "E_loss_hinge", "y_M")
#: The generated formulas' parameters (``q``), in order (checked against the library's).
PARAMETER_NAMES = ("L1", "L2", "L_CM", "L3", "L4", "m_b", "M", "m", "I", "offset", "g", "H",
                   "pivot_friction", "hinge_friction", "friction_rate")
#: The figures :meth:`CShot.figures` reduces, in the C's order (treb_batch.h, TREB_FIG_*).
FIGURES_C = ("F_S_peak", "F_H_peak", "F_R_peak", "F_R_perp_peak", "torque_peak",
             "sling_tension_min", "energy_drift", "cw_clearance", "E_m_release",
             "loss_at_release")
_N_FLAGS, _N_PARS, _N_INFO, _MSG = 6, 13, 20, 512
_PROJECTILE = {"trough": 1, "sling": 2, "none": 3}
_NO_REST = (float("nan"),) * 3

# ---------------------------------------------------------------------------------------------
# The library: found, built when missing or stale, loaded once


class EngineUnavailable(RuntimeError):
    """The C engine cannot be built here (no compiler, or it failed); the reason says which."""


_MODEL_SOURCES = (kinematics, friction, forces, dynamics, phase_events, flight, scene)
_FMU_SOURCES = ("codegen.py", "engine_formulas.py", "c_printer.py", "csources.py",
                "interface.py", "build.py", "engine_build.py", "c/treb_shot.h", "c/treb_shot.c",
                "c/treb_batch.h", "c/treb_batch.c", "c/treb_peaks.h", "c/treb_peaks.c")
_state: dict[str, object] = {}


def _fmu_dir() -> Path:
    """The folder of ``trebuchet.fmu`` (found, not imported: the model sits below it)."""
    spec = importlib.util.find_spec("trebuchet.fmu")
    if spec is None or not spec.submodule_search_locations:  # pragma: no cover - broken install
        raise EngineUnavailable("the package trebuchet.fmu (the C sources) is not installed")
    return Path(next(iter(spec.submodule_search_locations)))


def _digest() -> str:
    """sha256 of every file the library is built from, and of the generators' versions."""
    from importlib.metadata import version

    h = hashlib.sha256()
    fmu = _fmu_dir()
    for path in (*(Path(m.__file__) for m in _MODEL_SOURCES), *(fmu / f for f in _FMU_SOURCES)):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    for dist in ("sympy", "scipy"):  # the generated C's form, the DOP853 tableau
        h.update(f"{dist} {version(dist)}".encode())
    return h.hexdigest()[:24]


def _cache_dir() -> Path:
    """``__pycache__`` beside this module, or the user's cache where that is read-only."""
    here = Path(__file__).resolve().parent / "__pycache__"
    try:
        here.mkdir(exist_ok=True)
        if os.access(here, os.W_OK):
            return here
    except OSError:
        pass
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = base / "trebuchet"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def library_path() -> Path:
    """Where the library of the current sources lives (built or not)."""
    return _cache_dir() / f"trebuchet_engine_{_digest()}.so"


def _build(path: Path) -> None:
    """Build the library at ``path`` unless another process did meanwhile (a lock file
    serialises the builders); a failure is remembered beside it, so that each process does
    not try again."""
    failed = path.with_suffix(".failed")
    with open(path.with_suffix(".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if path.is_file():
            return
        if failed.is_file():
            raise EngineUnavailable(failed.read_text().strip())
        if shutil.which("gcc") is None:
            raise EngineUnavailable("no C compiler (gcc) on PATH")
        print("trebuchet: compiling the simulator's C (once per installation, about 20 s)...",
              file=sys.stderr, flush=True)
        proc = subprocess.run([sys.executable, "-m", "trebuchet.fmu.engine_build", str(path)],
                              capture_output=True, text=True)
        if proc.returncode != 0 or not path.is_file():
            reason = (proc.stderr.strip().splitlines() or ["the build failed"])[-1]
            failed.write_text(f"building the C engine failed: {reason}\n")
            raise EngineUnavailable(f"building the C engine failed: {reason}")
        for old in path.parent.glob("trebuchet_engine_*"):  # libraries of older sources
            if old.stem != path.stem and old.suffix in (".so", ".failed"):
                old.unlink(missing_ok=True)


def _declare(lib: ctypes.CDLL) -> ctypes.CDLL:
    p, d, i, long_p = ctypes.c_void_p, ctypes.POINTER(ctypes.c_double), ctypes.c_int, \
        ctypes.POINTER(ctypes.c_long)
    sig = {
        "treb_engine_new": (p, []), "treb_engine_free": (None, [p]),
        "treb_engine_row_names": (ctypes.c_char_p, []),
        "treb_engine_parameter_names": (ctypes.c_char_p, []),
        "treb_engine_start": (i, [p, d, ctypes.POINTER(ctypes.c_int), d, ctypes.c_char_p]),
        "treb_engine_info": (None, [p, d]),
        "treb_engine_states": (i, [p, i, d, ctypes.c_long, d, ctypes.c_char_p]),
        "treb_engine_step_count": (ctypes.c_long, [p, i]),
        "treb_engine_steps": (None, [p, i, d, d, d, d]),
        "treb_engine_rows": (i, [p, d, ctypes.c_long, long_p, ctypes.c_long, d, long_p, long_p,
                                 ctypes.c_char_p]),
        "treb_engine_summary": (i, [p, ctypes.c_double, ctypes.c_double, d, long_p,
                                    ctypes.c_char_p]),
    }
    for name, (res, args) in sig.items():
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = res, args
    rows = lib.treb_engine_row_names().decode().split()
    params = lib.treb_engine_parameter_names().decode().split()
    if tuple(rows) != ROW_NAMES or tuple(params) != PARAMETER_NAMES:
        raise EngineUnavailable("the C engine's columns or parameters differ from the model's")
    return lib


def library() -> ctypes.CDLL:
    """The loaded library (built first if missing or stale); raises :class:`EngineUnavailable`
    with the reason when it cannot be had (and remembers it for this process)."""
    if "lib" in _state:
        return _state["lib"]  # type: ignore[return-value]
    if "error" in _state:
        raise EngineUnavailable(str(_state["error"]))
    try:
        path = library_path()
        if not path.is_file():
            _build(path)
        _state["lib"] = _declare(ctypes.CDLL(str(path)))
    except (EngineUnavailable, OSError) as exc:
        _state["error"] = exc
        raise EngineUnavailable(str(exc)) from None
    return _state["lib"]  # type: ignore[return-value]


def available(quiet: bool = False) -> bool:
    """True when the C engine runs here; else one line on stderr (once per process, unless
    ``quiet``) says why and that the numba kernel simulates instead."""
    try:
        library()
    except EngineUnavailable as exc:
        if not quiet and not _state.get("told"):
            _state["told"] = True
            print(f"trebuchet: {exc}: simulating with the numba kernel instead (the same "
                  "steps, slower)", file=sys.stderr, flush=True)
        return False
    return True


def require(method: str) -> ctypes.CDLL:
    """The library for ``method`` (the C engine named explicitly), or a refusal saying why."""
    try:
        return library()
    except EngineUnavailable as exc:
        raise TrebuchetInputError(f"method {method!r}: the C engine is unavailable ({exc}); "
                                  "use method='numba-DOP853'") from None


# ---------------------------------------------------------------------------------------------
# A shot


def scene_numbers(sc: Scene, rtol: float, after_release: float, rest: bool = True
                  ) -> tuple[tuple[float, ...], tuple[int, ...], tuple[float, ...]]:
    """The scene as the C takes it: parameters ``q`` (:data:`PARAMETER_NAMES`), switches and
    numbers (treb_batch.h's TREB_FLAG_*, TREB_PAR_*); ``rest=False`` leaves the energies at
    rest to the C (NaN: its generated formula, the same as ``forces.rest_energies``)."""
    e, s, rel, fl = sc.engine, sc.start, sc.release, sc.flight
    offset = e.counterweight_offset
    q = (e.L1, e.L2, e.L_CM, e.L3, e.L4, e.m_b, e.M, e.m, e.I,
         0.0 if offset is None else offset, sc.g, s.H, e.pivot_friction, e.hinge_friction,
         e.friction_rate)
    flags = (e.fixed_counterweight, _PROJECTILE[sc.projectile], fl.model == "drag",
             has_friction(e), rel.time is not None, rel.velocity_angle is not None)
    par = (s.theta, s.psi, s.phi, rel.time or 0.0, rel.velocity_angle or 0.0, fl.diameter,
           fl.drag_coefficient, fl.air_density, rtol, after_release,
           *(forces.rest_energies(sc) if rest else _NO_REST))
    return q, tuple(map(int, flags)), par


def _arrays(sc: Scene, rtol: float, after_release: float
            ) -> tuple[ctypes.Array, ctypes.Array, ctypes.Array]:
    """:func:`scene_numbers` as ctypes arrays."""
    q, flags, par = scene_numbers(sc, rtol, after_release)
    return ((ctypes.c_double * len(q))(*map(float, q)),
            (ctypes.c_int * _N_FLAGS)(*map(int, flags)),
            (ctypes.c_double * _N_PARS)(*map(float, par)))


def _ptr(a: np.ndarray, kind: type = ctypes.c_double) -> ctypes._Pointer:
    return a.ctypes.data_as(ctypes.POINTER(kind))


def table_names(with_friction: bool) -> tuple[str, ...]:
    """``simulate``'s columns: ``t``, ``phase``, the angles and every load column, the
    friction's only where the engine has friction (then with the lost energies)."""
    rows = [n for n in ROW_NAMES[:-1] if with_friction or (
        n not in FRICTION_COLUMNS and not n.startswith("E_loss_"))]
    return ("t", "phase", *rows)


@dataclass(frozen=True, eq=False)
class Table:
    """``simulate``'s columns at the output times: ``block`` (float64, one row per float
    column of ``names`` in order, C order), ``phase`` (int64), ``columns`` (name → a view of
    the block, and ``phase``), ``finite`` (False: some value is not finite where the table
    must be; ``simulate`` then names it)."""

    names: tuple[str, ...]
    block: np.ndarray
    phase: np.ndarray
    columns: dict[str, np.ndarray]
    finite: bool


class CShot:
    """One shot of a scene integrated by the C engine through its phases: phase III to
    ``after_release`` s after the release (a dry fire: ``after_release`` s), at ``rtol``
    (``atol = rtol/100``). :meth:`start` returns None where the C refuses the shot (the
    caller words the refusal), with the C's reason in :attr:`refusal`."""

    refusal: str = ""

    def __init__(self, sc: Scene, rtol: float, after_release: float) -> None:
        lib = library()
        self.scene, self.rtol, self.after_release = sc, float(rtol), float(after_release)
        self._lib = lib
        self._ptr = lib.treb_engine_new()
        if not self._ptr:
            raise MemoryError("the C engine could not allocate a shot")
        weakref.finalize(self, lib.treb_engine_free, self._ptr)
        msg = ctypes.create_string_buffer(_MSG)
        status = lib.treb_engine_start(self._ptr, *_arrays(sc, rtol, after_release), msg)
        if status == -2:
            raise MemoryError("the C engine ran out of memory")
        self.ok = status == 0
        self.refusal = msg.value.decode(errors="replace")
        info = np.empty(_N_INFO)
        lib.treb_engine_info(self._ptr, _ptr(info))
        n = int(info[0]) if self.ok else 0
        self.kinds = tuple(int(k) for k in info[1:1 + n])
        self.t0, self.t1 = tuple(map(float, info[4:4 + n])), tuple(map(float, info[7:7 + n]))
        self.nfev = tuple(int(v) for v in info[10:10 + n])
        self.t_lift, self.t_release = float(info[13]), float(info[14])
        self.release = info[15:20].copy()

    @classmethod
    def start(cls, sc: Scene, rtol: float, after_release: float) -> CShot | None:
        """The shot, or None where the C refuses it."""
        shot = cls(sc, rtol, after_release)
        return shot if shot.ok else None

    @property
    def t_end(self) -> float:
        """The end of phase III (s)."""
        return self.t1[-1]

    @property
    def events(self) -> dict[str, float]:
        """``lift_off``, ``release`` (where the shot has them) and ``end``, s."""
        ev = {k: v for k, v in (("lift_off", self.t_lift), ("release", self.t_release))
              if not math.isnan(v)}
        return {**ev, "end": self.t_end}

    @property
    def release_state(self) -> dict[str, float] | None:
        """The projectile's ``t, x, y, vx, vy`` at release (s, m, m/s); None for a dry fire."""
        if math.isnan(self.t_release):
            return None
        return dict(zip(("t", "x", "y", "vx", "vy"), map(float, self.release), strict=True))

    def state_size(self, k: int) -> int:
        """The size of the state of the phase of index ``k`` (with the lost energies)."""
        return (6 if self.kinds[k] == 2 else 4) + (2 if has_friction(self.scene.engine) else 0)

    def states(self, k: int, t: np.ndarray) -> np.ndarray:
        """The integrated state of the phase of index ``k`` at times ``t`` (s), shape (n, m)."""
        t = np.ascontiguousarray(t, dtype=float)
        out = np.empty((self.state_size(k), t.size))
        msg = ctypes.create_string_buffer(_MSG)
        if self._lib.treb_engine_states(self._ptr, k, _ptr(t), t.size, _ptr(out), msg):
            raise RuntimeError(msg.value.decode(errors="replace"))
        return out

    def rows(self, t: np.ndarray, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray,
                                                                    int, int]:
        """The float columns of ``names`` (``t`` and any of :data:`ROW_NAMES`) at times ``t``
        (s) as a block (one row per column), the phase of each time, and the first non-finite
        value where the table must be finite (its row in the block and column; -1: none)."""
        t = np.ascontiguousarray(t, dtype=float)
        floats = [n for n in names if n != "phase"]
        where = {n: i for i, n in enumerate(floats)}
        dest = np.array([where.get(n, -1) for n in ROW_NAMES], dtype=np.int_)
        block = np.empty((len(floats), t.size))
        phase = np.empty(t.size, dtype=np.int_)
        bad = np.full(2, -1, dtype=np.int_)
        msg = ctypes.create_string_buffer(_MSG)
        status = self._lib.treb_engine_rows(self._ptr, _ptr(t), t.size, _ptr(dest, ctypes.c_long),
                                            where.get("t", -1), _ptr(block),
                                            _ptr(phase, ctypes.c_long), _ptr(bad, ctypes.c_long),
                                            msg)
        if status:
            raise RuntimeError(msg.value.decode(errors="replace"))
        return block, phase.astype(np.int64, copy=False), int(bad[0]), int(bad[1])

    def table(self, t: np.ndarray) -> Table:
        """``simulate``'s columns (:func:`table_names`) at times ``t`` (s): every row in C; the
        projectile's flight with drag after release by :func:`flight.projectile_in_flight`."""
        sc = self.scene
        names = table_names(has_friction(sc.engine))
        block, phase, bad, _ = self.rows(t, names)
        floats = [n for n in names if n != "phase"]
        cols = dict(zip(floats, block, strict=True))
        cols = {"t": cols["t"], "phase": phase, **cols}
        finite = bad < 0
        free = phase == 3
        if sc.flight.model == "drag" and sc.engine.m > 0.0 and free.any():
            r, v = projectile_in_flight(self.release_state, cols["t"][free], sc.g, sc.flight,
                                        sc.engine.m)
            for name, value in zip(("x_m", "y_m", "vx_m", "vy_m"), (*r, *v), strict=True):
                cols[name][free] = value
            cols["E_m"][free] = projectile_energy(v, r[1], sc.engine, sc.g) - \
                forces.rest_energies(sc)[0]
            finite = finite and all(np.isfinite(cols[n][free]).all()
                                    for n in ("x_m", "y_m", "vx_m", "vy_m", "E_m"))
        return Table(names, block, phase, cols, finite)

    def figures(self, dt: float, t_clear: float) -> tuple[dict[str, float],
                                                          dict[str, float], bool]:
        """The extrema of :data:`FIGURES_C` over the rows ``simulate`` tabulates at step ``dt``
        (s), the counterweight's clearance on to ``t_clear`` (s), the time of each, and whether
        every value those rows must have is finite. Runs phase III on to ``t_clear``: call it
        last."""
        out = np.empty(2 * len(FIGURES_C))
        bad = np.full(2, -1, dtype=np.int_)
        msg = ctypes.create_string_buffer(_MSG)
        if self._lib.treb_engine_summary(self._ptr, float(dt), float(t_clear), _ptr(out),
                                         _ptr(bad, ctypes.c_long), msg):
            raise RuntimeError(msg.value.decode(errors="replace"))
        n = len(FIGURES_C)
        return (dict(zip(FIGURES_C, map(float, out[:n]), strict=True)),
                dict(zip(FIGURES_C, map(float, out[n:]), strict=True)), bool(bad[0] < 0))


class CPhase:
    """The phase of index ``k`` of a :class:`CShot` as a phase's solution of ``simulate``'s
    ``Trajectory``: callable at times (s) for the integrated state, :meth:`columns`, and its
    steps as ``kernel_phase.KernelSolution`` holds them (``kind``, ``t_steps``, ``h``,
    ``y_steps``, ``coef``, ``y_end``: the design's peak search reduces them)."""

    def __init__(self, shot: CShot, k: int) -> None:
        self.shot, self.k = shot, k
        self.kind = shot.kinds[k]
        self._steps: tuple[np.ndarray, ...] | None = None

    def _copy_steps(self) -> tuple[np.ndarray, ...]:
        if self._steps is None:
            lib, ptr = self.shot._lib, self.shot._ptr
            count = lib.treb_engine_step_count(ptr, self.k)
            n = self.shot.state_size(self.k)
            T, H = np.empty(count), np.empty(count)
            Y, F = np.empty((count, n)), np.empty((count, 7, n))
            lib.treb_engine_steps(ptr, self.k, _ptr(T), _ptr(H), _ptr(Y), _ptr(F))
            self._steps = (T, H, Y, F)
        return self._steps

    @property
    def t_steps(self) -> np.ndarray:
        """Start times of the steps, s."""
        return self._copy_steps()[0]

    @property
    def h(self) -> np.ndarray:
        """Step sizes, s."""
        return self._copy_steps()[1]

    @property
    def y_steps(self) -> np.ndarray:
        """States at the steps' starts, (steps, n)."""
        return self._copy_steps()[2]

    @property
    def coef(self) -> np.ndarray:
        """The dense output's coefficients of each step, (steps, 7, n)."""
        return self._copy_steps()[3]

    @property
    def y_end(self) -> np.ndarray:
        """The state at the phase's end."""
        return self.shot.states(self.k, np.array([self.shot.t1[self.k]]))[:, 0]

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        out = self.shot.states(self.k, np.atleast_1d(np.asarray(t, dtype=float)))
        return out[:, 0] if np.ndim(t) == 0 else out

    def columns(self, t: np.ndarray, out: np.ndarray) -> None:
        """Angles, rates, accelerations (rows of :data:`ANGLE_NAMES`; rad, rad/s, rad/s²) at
        times ``t`` (s) inside the phase into ``out`` (9 × len(t)); with 11 rows the states of
        the energies lost at pivot and hinge follow (in units of ``dynamics.energy_scale``)."""
        out[:9] = self.shot.rows(t, ANGLE_NAMES)[0]
        if out.shape[0] > 9:
            out[9:] = self.shot.states(self.k, t)[-2:]
