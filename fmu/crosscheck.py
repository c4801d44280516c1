"""The FMI cross-check layout for Trebuchet.fmu, and the in-process reference it holds.

``fmus/2.0/cs/<platform>/trebuchet/<version>/Trebuchet/`` with ``Trebuchet.fmu``, the
reference result ``Trebuchet_ref.csv`` (the in-process simulator, :func:`reference`), the
options ``Trebuchet_ref.opt`` (StartTime, StopTime, StepSize, RelTol), the input
``Trebuchet_in.csv`` (the release command rising at :data:`COMMAND_TIME`) and a ReadMe.md.
Other tools simulate the FMU with those options and input and compare with the reference
(the rules of https://github.com/modelica/fmi-cross-check; files under 1 MB).
"""

from __future__ import annotations

import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.core.output import atomic_dir
from trebuchet.core.version import __version__
from trebuchet.fmu.interface import OUTPUT_NAMES, PARAMETERS, scene_from_parameters
from trebuchet.fmu.model_description import MODEL_NAME
from trebuchet.model.simulate import DEFAULT_AFTER_RELEASE, simulate

__all__ = ["reference", "write_crosscheck", "after_release_for", "START_TIME", "STOP_TIME",
           "STEP_SIZE", "COMMAND_TIME", "REL_TOL"]

START_TIME = 0.0
STOP_TIME = 1.5  # s
STEP_SIZE = 1e-3  # s: 1501 rows, 0.6 MB (the cross-check allows 1 MB)
COMMAND_TIME = 0.9  # s: the release command rises here, before the scene's release at 0.997 s
REL_TOL = 1e-8


def after_release_for(t_stop: float | None) -> float | None:
    """Seconds of phase III to simulate for outputs up to ``t_stop`` (s) whatever the release
    time, at least the simulator's default; None (the default) for an open end."""
    if t_stop is None or not np.isfinite(t_stop):
        return None
    return max(DEFAULT_AFTER_RELEASE, float(t_stop))


def reference(times: Sequence[float] | np.ndarray, values: Mapping[str, float | str] | None = None,
              command_time: float | None = None, t_stop: float | None = None,
              rtol: float | str = "default") -> pd.DataFrame:
    """The FMU's outputs computed in-process: ``simulate`` of the parameters' scene at
    ``times`` (s), released at ``command_time`` (s) if the command rises there between lift-off
    and the scene's own release; phase III as long as the FMU integrates it for ``t_stop`` (s);
    at ``simulate``'s tolerance ``rtol``.

    Returns a DataFrame with ``time`` and :data:`~trebuchet.fmu.interface.OUTPUT_NAMES` (the sling
    angles 0 after release, as the FMU reports them).
    """
    if values is None:
        values = {p.name: p.start for p in PARAMETERS}
    scene = scene_from_parameters(values)
    after = after_release_for(t_stop)
    # the numba kernels: the FMU's C is checked against the model's Python, not against itself
    if command_time is not None:
        events = simulate(scene, t_eval=[0.0], after_release=after,
                          method="numba-DOP853").attrs["events"]
        if events.get("lift_off", 0.0) < command_time < events.get("release", -np.inf):
            scene = scene.with_release(time=command_time,
                                       velocity_angle=scene.release.velocity_angle)
    run = simulate(scene, t_eval=np.asarray(times, dtype=float), after_release=after,
                   method="numba-DOP853", rtol=rtol)
    for name in OUTPUT_NAMES:  # a frictionless scene's output has no friction columns: 0
        if name not in run.columns:
            run[name] = 0.0
    out = run.loc[:, list(OUTPUT_NAMES)].copy()
    free = out["phase"].to_numpy() == 3
    out.loc[free, ["phi", "phi_d", "phi_dd"]] = 0.0
    out.insert(0, "time", run["t"].to_numpy())
    return out.reset_index(drop=True)


def write_crosscheck(fmu: str | Path, out_dir: str | Path) -> Path:
    """Write the cross-check layout for ``fmu`` under ``out_dir`` (whole or not at all);
    returns the model's folder."""
    import fmpy  # for its platform name; imported here (the package imports it lazily)

    fmu = Path(fmu)
    if not fmu.is_file():
        raise TrebuchetInputError(f"{fmu}: FMU not found")
    n = int(round((STOP_TIME - START_TIME) / STEP_SIZE))
    times = START_TIME + STEP_SIZE * np.arange(n + 1)
    ref = reference(times, command_time=COMMAND_TIME, t_stop=STOP_TIME)
    rel = Path("fmus", "2.0", "cs", fmpy.platform, "trebuchet", __version__, MODEL_NAME)
    out_dir = Path(out_dir)
    with atomic_dir(out_dir, inputs=[fmu]) as tmp:
        folder = tmp / rel
        folder.mkdir(parents=True)
        shutil.copyfile(fmu, folder / f"{MODEL_NAME}.fmu")
        ref.to_csv(folder / f"{MODEL_NAME}_ref.csv", index=False, float_format="%.12g")
        pd.DataFrame({"time": [START_TIME, COMMAND_TIME, STOP_TIME],
                      "release_command": [0, 1, 1]}).to_csv(
            folder / f"{MODEL_NAME}_in.csv", index=False)
        (folder / f"{MODEL_NAME}_ref.opt").write_text(
            f"StartTime, {START_TIME!r}\nStopTime, {STOP_TIME!r}\nStepSize, {STEP_SIZE!r}\n"
            f"RelTol, {REL_TOL!r}\n")
        (folder / "ReadMe.md").write_text(_readme())
    return out_dir / rel


def _readme() -> str:
    return f"""# {MODEL_NAME}.fmu (trebuchet {__version__})

Swinging-counterweight trebuchet after Horsdal, FMI 2.0 co-simulation and model exchange,
native C (`trebuchet fmu build`).
Parameters at their start values (the large engine of Table 1 of the paper, g = 9.82 m/s²).
The input `release_command` rises at {COMMAND_TIME} s and releases the projectile there.

The reference `{MODEL_NAME}_ref.csv` is the in-process simulation of the trebuchet package
(DOP853, rtol 1e-10) at the communication points; the FMU reproduces it to 1e-8 relative.

Host requirements: none but the FMU (binaries for linux64, and win64 where the build had
the cross compiler; the C sources are in `sources/`). See fmu/README.md.
"""
