"""Properties of the model over random physical engines, drawn across scales.

Engines from table-top (beam 0.5 m, a 1 g projectile) to 20 m beams; counterweights from ten
times the beam's own moment upwards; start angles from −85° to −15°; release by velocity angle
(20°–70°) or by time. On every shot the model must conserve energy, the torque on the beam must
equal I θ̈, the hinge force must lie along the counterweight arm and the sling force along the
sling while the projectile is held. A scene the model refuses must say why
(TrebuchetInputError naming the scene); refusals are counted and must stay rare, otherwise the
strategy is drawing engines that make no sense.

CI runs a fixed (derandomized) set of examples. To explore, set
``TREBUCHET_PROPERTY_EXAMPLES=500 TREBUCHET_PROPERTY_RANDOM=1``.
"""

from __future__ import annotations

import math
import os
from collections import Counter

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import kinematics as kin
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import integrate, simulate

EXAMPLES = int(os.environ.get("TREBUCHET_PROPERTY_EXAMPLES", "40"))
PROPERTY_SETTINGS = settings(
    max_examples=EXAMPLES, deadline=None, database=None,
    derandomize=not os.environ.get("TREBUCHET_PROPERTY_RANDOM"),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
MAX_REFUSED = 0.2  # fraction of drawn scenes the model may refuse
G = 9.81


def log_uniform(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Floats spread evenly in log scale over [lo, hi]."""
    return st.floats(math.log(lo), math.log(hi)).map(math.exp)


@st.composite
def physical_scenes(draw: st.DrawFn) -> tuple[dict, float | None]:
    """A scene dict of an engine someone could build (lengths m, masses kg, angles deg), and
    ``time_fraction``: None to release at the velocity angle, else release at a time that
    fraction of the way from lift-off to the moment the velocity angle is reached (a time
    drawn blind falls before lift-off or after the projectile hits the ground too often: the
    lift-off time ranges over 0.3–6 s for the same beam)."""
    L1 = draw(log_uniform(0.5, 20.0))
    L2 = L1 * draw(st.floats(0.12, 0.5))                  # short arm over long arm
    L_CM = L1 * draw(st.floats(0.0, 0.45))               # beam's centre of mass, spigot side
    L4 = L1 * draw(st.floats(0.5, 1.3))                  # sling
    m_b = L1 * draw(log_uniform(2.0, 100.0))             # kg: 2–100 kg per metre of beam
    beam_moment = m_b * max(L_CM, 0.1 * L2) / L2         # kg: counterweight balancing the beam
    M = 10.0 * beam_moment * draw(log_uniform(1.0, 30.0))
    m = max(1e-3, M * draw(log_uniform(1e-4, 0.05)))
    theta_deg = draw(st.floats(-85.0, -15.0))
    psi_deg = -90.0 + draw(st.floats(-10.0, 10.0))       # counterweight near hanging
    # counterweight arm: the counterweight hangs clear of the ground at the start
    L3 = (L1 + L2) * math.sin(math.radians(-theta_deg)) * draw(st.floats(0.1, 0.9))
    release = {"velocity_angle_deg": draw(st.floats(20.0, 70.0))}
    time_fraction = draw(st.none() | st.floats(0.05, 1.0))
    scene = {
        "engine": {"L1": L1, "L2": L2, "L_CM": L_CM, "L3": L3, "L4": L4, "m_b": m_b, "M": M,
                   "m": m},
        "start": {"theta_deg": theta_deg, "psi_deg": psi_deg, "phi_deg": -180.0},
        "release": release,
        "environment": {"g": G},
    }
    return scene, time_fraction


def _scale(frame, *cols: str) -> float:
    return max(float(np.max(np.abs(frame[c]))) for c in cols)


def check_shot(data: dict, time_fraction: float | None = None) -> str | None:
    """Simulate one drawn scene and assert the model's invariants on it. Returns None, or the
    refusal's message when the model refuses the scene."""
    try:
        scene = Scene.from_dict(data, source="drawn")
        if time_fraction is not None:
            ev = integrate(scene, after_release=0.0).events
            t = ev["lift_off"] + time_fraction * (ev["release"] - ev["lift_off"])
            scene = scene.with_release(time=t)
        run = simulate(scene)
    except TrebuchetInputError as exc:
        reason = str(exc)
        assert reason.startswith("drawn: ") and len(reason) > 20, reason
        return reason
    held = run[run.phase <= 2]
    numbers = run.drop(columns=["phase", "phi", "phi_d", "phi_dd"]).select_dtypes("number")
    assert np.isfinite(numbers.to_numpy()).all(), "non-finite output"
    assert np.isfinite(held[["phi", "phi_d", "phi_dd"]].to_numpy()).all(), "non-finite sling"
    diag = run.attrs["diagnostics"]
    assert diag["energy_drift_rel"] < 1e-8, diag
    total = (run.E_m + run.E_M + run.E_beam).to_numpy()
    assert np.max(np.abs(total)) < 1e-8 * diag["delta_U"]
    assert np.max(np.abs(run.torque - scene.engine.I * run.theta_dd)) < 1e-9 * _scale(
        run, "torque")
    across_H = kin.dot(np.array([run.F_H_x, run.F_H_y]), kin.unit_perp(run.psi.to_numpy()))
    assert np.max(np.abs(across_H)) < 1e-9 * _scale(run, "F_H_abs")
    across_S = kin.dot(np.array([held.F_S_x, held.F_S_y]), kin.unit_perp(held.phi.to_numpy()))
    assert np.max(np.abs(across_S)) < 1e-9 * _scale(held, "F_S_abs")
    ev = run.attrs["events"]
    assert 0.0 < ev["lift_off"] < ev["release"] < ev["end"]
    return None


def test_random_engines_conserve_energy_and_balance_forces():
    outcomes: Counter[str] = Counter()

    @PROPERTY_SETTINGS
    @given(physical_scenes())
    def shot(drawn: tuple[dict, float | None]) -> None:
        reason = check_shot(*drawn)
        outcomes["refused" if reason else "ok"] += 1
        assume(reason is None)

    shot()
    drawn = sum(outcomes.values())
    assert outcomes["ok"] >= 10, outcomes
    assert outcomes["refused"] <= MAX_REFUSED * drawn, outcomes


# Found by hypothesis (an earlier version of the strategy, with L3 = 0.1–0.5 L1): with the
# automatic first-step guess after release, DOP853 (lean and scipy's alike) lost 3.9e-7 of ΔU
# in the 20 ms after release at rtol 1e-10 (Radau: 3e-11). Two more engines in 1000 random
# ones drifted by 1.2e-8 and 1.5e-8, also after release. Carrying the last step size across a
# phase change (simulate._solve's first_step) removes it.
PHASE3_DRIFT_SCENE = {
    "engine": {"L1": math.exp(1.625), "L2": 1.6762750337567065, "L_CM": 0.0,
               "L3": 1.9837574363984694, "L4": 4.35434757289464, "m_b": 13.804574186067095,
               "M": 125.95661219607334, "m": 0.04225373612899234},
    "start": {"theta_deg": -72.0, "psi_deg": -90.0, "phi_deg": -180.0},
    "release": {"velocity_angle_deg": 57.25},
    "environment": {"g": 9.81},
}
PHASE3_DRIFT_SCENES = [
    PHASE3_DRIFT_SCENE,
    {"engine": {"L1": 1.267856, "L2": 0.494362, "L_CM": 0.150159, "L3": 1.425985,
                "L4": 1.487989, "m_b": 27.027851, "M": 215.32224, "m": 0.054203},
     "start": {"theta_deg": -76.29414629179185, "psi_deg": -96.93813888752547,
               "phi_deg": -180.0},
     "release": {"velocity_angle_deg": 48.3479773417631}, "environment": {"g": 9.81}},
    {"engine": {"L1": 1.0, "L2": 0.41796875, "L_CM": 0.0, "L3": 0.4800540887517611,
                "L4": 0.6015625, "m_b": 2.718281828459045, "M": 5.448348308054143,
                "m": 0.004968250564174035},
     "start": {"theta_deg": -85.0, "psi_deg": -94.0, "phi_deg": -180.0},
     "release": {"velocity_angle_deg": 60.0}, "environment": {"g": 9.81}},
]


@pytest.mark.parametrize("data", PHASE3_DRIFT_SCENES)
def test_energy_conserved_after_release_on_drift_engines(data):
    run = simulate(Scene.from_dict(data, source="phase3-drift"))
    assert run.attrs["diagnostics"]["energy_drift_rel"] < 1e-8
    total = (run.E_m + run.E_M + run.E_beam).to_numpy()
    assert np.max(np.abs(total)) < 1e-8 * run.attrs["diagnostics"]["delta_U"]
