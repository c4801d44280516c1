"""The generated C equals the model's Python: every formula of ``trebuchet.fmu.codegen``,
compiled, against the same Python functions on floats, on random engines and states."""

from __future__ import annotations

import ctypes
import math
import shutil
import subprocess
import zlib

import numpy as np
import pytest

from trebuchet.fmu import codegen as cg
from trebuchet.fmu import engine_formulas as ef

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

SAMPLES = 1500
# Each formula's bound (Formula.tolerance) is relative to each output's peak over the samples
# (or to 1 where the peak is below 1): 1e-12 for the formulas, the central difference's error
# for the Jacobians.
PAPER = {"L1": 6.48, "L2": 0.86, "L_CM": 2.81, "L3": 2.45, "L4": 5.55, "m_b": 622.0,
         "M": 19100.0, "m": 100.0, "I": 7704.0, "offset": -0.7, "g": 9.82, "H": 4.96,
         "pivot_friction": 0.015, "hinge_friction": 0.009, "friction_rate": 1e-3}
RANGES = {  # inputs: uniform between these (rad, rad/s, s, m, m/s, J, ...)
    "th": (-1.2, 1.2), "ps": (-3.5, 1.0), "ph": (-4.5, -1.7), "th_d": (-8.0, 8.0),
    "ps_d": (-15.0, 15.0), "ph_d": (-20.0, 20.0), "rest_m": (-1e3, 1e3),
    "rest_M": (-1e6, 1e6), "rest_beam": (-1e5, 1e5), "t": (0.0, 2.0), "par": (0.1, 1.4),
    "r_t": (0.0, 1.0), "r_x": (-10.0, 10.0), "r_y": (0.0, 20.0), "r_vx": (-80.0, 0.0),
    "r_vy": (0.0, 60.0), "k": (0.0, 0.01), "x": (-100.0, 100.0), "y": (0.0, 50.0),
    "vx": (-80.0, 0.0), "vy": (-50.0, 50.0), "diameter": (0.05, 1.0),
    "drag_coefficient": (0.2, 1.0), "air_density": (1.0, 1.3), "y_m": (0.0, 3.0),
    "e_P": (0.0, 0.1), "e_H": (0.0, 0.1), "Q_th": (-3e4, 3e4), "Q_ps": (-2e4, 2e4),
    "n_R": (1e5, 1e6), "n_H": (1e5, 5e5), "p0": (-0.02, 0.02), "p1": (-0.01, 0.01),
    **{f"p{i}": (-1e6, 1e6) for i in range(2, 6)}, **{f"p{i}": (-0.05, 0.05) for i in range(6, 14)},
    "p14": (-4.5, -1.7), "p15": (-20.0, 20.0), **{f"p{i}": (-100.0, 100.0) for i in range(16, 19)},
    **{f"p{i}": (-1e-3, 1e-3) for i in range(19, 25)},  # rad/s² per N m of Q_th, Q_ps
    "o_R": (1e5, 1e6), "o_H": (1e5, 5e5), "s_R": (-1e3, 1e3), "s_H": (-1e3, 1e3),
}
_Q = cg.PARAMETER_NAMES


@pytest.fixture(scope="module")
def formulas_lib(tmp_path_factory) -> ctypes.CDLL:
    folder = tmp_path_factory.mktemp("codegen")
    (folder / "treb_formulas.c").write_text(cg.generate_c())
    (folder / "treb_formulas.h").write_text(cg.generate_header())
    (folder / "treb_rows.c").write_text(cg.generate_c(ef.ENGINE_FORMULAS, "treb_rows.h"))
    (folder / "treb_rows.h").write_text(ef.generate_rows_header())
    lib = folder / "libtreb_formulas.so"
    subprocess.run(["gcc", "-O2", "-std=c99", "-Wall", "-Werror", "-shared", "-fPIC",
                    str(folder / "treb_formulas.c"), str(folder / "treb_rows.c"), "-o", str(lib),
                    "-lm"], check=True)
    return ctypes.CDLL(str(lib))


def _sample(f: cg.Formula, rng: np.random.Generator) -> tuple[list[float], dict[str, float]]:
    """Random parameters (the paper's engine scaled by 0.7 to 1.3) and inputs of ``f``; in
    the trough the sling's constraint must have a solution."""
    while True:
        q = [PAPER[n] * rng.uniform(0.7, 1.3) for n in _Q]
        if f.dry:
            q[_Q.index("m")] = 0.0
        x = {n: rng.uniform(*RANGES[n]) for n in f.inputs}
        trough = f.name.startswith(("rates1", "outputs1", "jacobian1", "lift_off",
                                    "sling_upright", "friction_pieces1", "rows1"))
        if not trough:
            return q, x
        if abs((q[_Q.index("H")] + q[_Q.index("L1")] * math.sin(x["th"]))
               / q[_Q.index("L4")]) < 0.95:
            return q, x


@pytest.mark.parametrize("formula", cg.FORMULAS + ef.ENGINE_FORMULAS, ids=lambda f: f.name)
def test_generated_c_equals_the_python(formulas_lib, formula):
    rng = np.random.default_rng(zlib.crc32(formula.name.encode()))
    fn = getattr(formulas_lib, f"treb_{formula.name}")
    fn.restype = None
    want, got = [], []
    out = (ctypes.c_double * len(formula.outputs))()
    for _ in range(SAMPLES):
        q, x = _sample(formula, rng)
        e = cg.engine_namespace(q, bool(formula.fixed), formula.friction)
        want.append([float(v) for v in formula.build(e, q[_Q.index("g")], q[_Q.index("H")], x,
                                                     math)])
        fn((ctypes.c_double * len(q))(*q), (ctypes.c_double * max(1, len(x)))(*x.values()),
           out)
        got.append(list(out))
    want_a, got_a = np.array(want), np.array(got)
    for j, name in enumerate(formula.outputs):
        w, g = want_a[:, j], got_a[:, j]
        np.testing.assert_array_equal(np.isnan(g), np.isnan(w), err_msg=name)
        finite = ~np.isnan(w)
        if not finite.any():
            continue
        assert np.isfinite(g[finite]).all(), name
        scale = max(float(np.max(np.abs(w[finite]))), 1.0)
        err = float(np.max(np.abs(g[finite] - w[finite])))
        bound = formula.tolerance * scale
        assert err <= bound, f"{formula.name}: {name} off by {err:g} (peak {scale:g})"


def test_every_model_formula_is_generated():
    """The equations of motion of each phase and counterweight, the outputs of each phase,
    every phase event and the flight are generated (nothing is left to hand-written C)."""
    names = {f.name for f in cg.FORMULAS}
    for cw in ("hinged", "fixed"):
        for phase in (1, 2, 3):
            assert {f"rates{phase}_{cw}", f"outputs{phase}_{cw}"} <= names
        assert f"lift_off_{cw}" in names
        for phase in (1, 2, 3):  # and with friction in the bearings
            assert {f"rates{phase}_{cw}_friction", f"outputs{phase}_{cw}_friction",
                    f"friction_pieces{phase}_{cw}"} <= names
        assert f"lift_off_{cw}_friction" in names
    assert {"sling_upright", "ground", "release_time", "climb", "vacuum_flight", "drag_rates",
            "rest_energies", "projectile"} <= names
    outputs = next(f for f in cg.FORMULAS if f.name == "outputs2_hinged").outputs
    assert set(outputs) == set(cg.ANGLE_NAMES) | set(cg.LOAD_OUTPUTS)
