"""The compiled load columns equal the force formulas evaluated with numpy over time."""

from __future__ import annotations

import numpy as np
import pytest

from trebuchet.model import forces as fo
from trebuchet.model import kinematics as kin
from trebuchet.model import loads as ld
from trebuchet.model.simulate import integrate


def _vectorised(cols: dict[str, np.ndarray], scene, projected: bool) -> dict[str, np.ndarray]:
    """The contract's forces, torque, powers and energies from the ``(2, n)`` functions of
    :mod:`trebuchet.model.forces` on whole arrays (no compiled code)."""
    e, g, H = scene.engine, scene.g, scene.start.H
    phase = cols["phase"]
    trough, sling, held = phase == 1, phase == 2, phase <= 2
    th = kin.Angle(cols["theta"], cols["theta_d"], cols["theta_dd"])
    ps = kin.Angle(cols["psi"], cols["psi_d"], cols["psi_dd"])
    ph = kin.Angle(*(np.where(held, cols[c], 0.0) for c in ("phi", "phi_d", "phi_dd")))
    F_CM = fo.centre_of_mass_force(th, e, g)
    F_H = fo.hinge_force_along_arm(th, ps, e, g) if projected else fo.hinge_force(th, ps, e, g)
    in_sling = fo.sling_force_along_sling if projected else fo.sling_force_in_sling
    F_S = np.where(sling, in_sling(th, ph, e, g), 0.0)
    with np.errstate(all="ignore"):  # the trough's formula off the trough
        F_S = np.where(trough, fo.sling_force_in_trough(th, ph, e), F_S)
    F_R = fo.pivot_reaction(F_H, F_CM, F_S)
    torque = sum(fo.torque_contributions(th, ps, F_H, F_S, e, g))
    v_m = kin.projectile_velocity(th, ph, th.rate, ph.rate, e)
    r_m = kin.projectile_position(th, ph, e, H)
    E_m, E_M, E_b = fo.energies(th, ps, v_m, r_m[1], e, g, H)
    rest = fo.rest_energies(scene)
    v_M = kin.counterweight_velocity(th, ps, th.rate, ps.rate, e)
    return {"F_S_x": F_S[0], "F_S_y": F_S[1], "F_H_x": F_H[0], "F_H_y": F_H[1],
            "F_CM_x": F_CM[0], "F_CM_y": F_CM[1], "F_R_x": F_R[0], "F_R_y": F_R[1],
            "torque": torque, "P_M": kin.dot(F_H, v_M),
            "P_m": np.where(held, kin.dot(F_S, v_m), 0.0),
            "E_M": E_M - rest[1], "E_beam": E_b - rest[2],
            "E_m": np.where(held, E_m - rest[0], np.nan),
            "F_N": np.where(trough, fo.trough_normal_force(F_S[1], e, g), 0.0)}


@pytest.mark.parametrize("form", ["direct", "projected"])
@pytest.mark.parametrize("engine", ["horsdal", "backyard"])
def test_compiled_rows_equal_the_vectorised_formulas(engine, form, request):
    scene = request.getfixturevalue(engine)
    traj = integrate(scene)
    cols = traj.angle_columns(np.linspace(0.0, traj.t_end, 700))
    out = ld.load_columns(cols, scene, form=form, release_state=traj.release_state)
    want = _vectorised(cols, scene, form == "projected")
    held = cols["phase"] <= 2
    assert held.any() and (~held).any() and (cols["phase"] == 1).any()
    for name, v in want.items():
        got = out[name] if name != "E_m" else np.where(held, out[name], np.nan)
        scale = np.nanmax(np.abs(v)) or 1.0
        np.testing.assert_allclose(got, v, rtol=0, atol=1e-12 * scale, err_msg=name)


def test_row_loads_runs_as_plain_python(horsdal):
    """The row function is ordinary Python too: one row by hand equals the compiled row."""
    traj = integrate(horsdal)
    cols = traj.angle_columns(np.array([0.2, 0.6]))
    out = ld.load_columns(cols, horsdal, release_state=traj.release_state)
    e = horsdal.engine
    for i in range(2):
        row = fo.row_loads(int(cols["phase"][i]), *(float(cols[c][i]) for group in
                                                     fo.ANGLE_COLUMNS for c in group),
                           e, horsdal.g, horsdal.start.H, False, fo.rest_energies(horsdal))
        assert len(row) == len(fo.ROW_COLUMNS)
        for name, v in zip(fo.ROW_COLUMNS, row, strict=True):
            if name in fo.FRICTION_COLUMNS:  # a frictionless engine's output has none
                assert name not in out and v == 0.0, name
                continue
            assert v == pytest.approx(out[name][i], rel=1e-13, abs=1e-9), name


def test_a_bad_phase_is_refused_before_the_kernel(horsdal):
    traj = integrate(horsdal)
    cols = traj.angle_columns(np.linspace(0.0, 0.5, 5))
    cols["phase"] = np.array([1, 1, 4, 2, 2])
    with pytest.raises(Exception, match="row 2 has 4"):
        ld.load_columns(cols, horsdal)
