"""The FMU's slave: pythonfmu wraps this class as an FMI 2.0 co-simulation FMU.

The file is the FMU's script (``resources/trebuchet_fmu_slave.py``; the module name is unique
to the project because two FMUs whose scripts share a name cannot load in one process). It
holds no model: it imports the installed ``trebuchet`` package and answers every
communication step from :mod:`trebuchet.fmu.cosim`, the in-process simulator.

Errors: a parameter the scene refuses (negative mass, a start pose that does not fit) or a
shot the simulator refuses is logged with status Error and the call fails; the importer
survives and may instantiate again.
"""

from __future__ import annotations

from typing import Any

from pythonfmu import (
    Boolean,
    DefaultExperiment,
    Fmi2Causality,
    Fmi2Slave,
    Fmi2Variability,
    Integer,
    Real,
    String,
)
from pythonfmu.enums import Fmi2Status

from trebuchet.errors import TrebuchetInputError
from trebuchet.fmu import cosim
from trebuchet.fmu.interface import VARIABLES, Variable, scene_from_parameters
from trebuchet.version import __version__

_TYPES = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}
_CAUSALITY = {"parameter": Fmi2Causality.parameter, "input": Fmi2Causality.input,
              "output": Fmi2Causality.output}
_VARIABILITY = {"parameter": Fmi2Variability.fixed, "input": Fmi2Variability.discrete}


class Trebuchet(Fmi2Slave):
    """Swinging-counterweight trebuchet (Horsdal): angles, internal forces, torque, rates of
    work and energies of a shot, with a release command input."""

    author = "trebuchet developers"
    description = (f"Swinging-counterweight trebuchet after Horsdal: internal forces of a shot "
                   f"(trebuchet {__version__}, in-process simulator)")
    version = __version__
    license = "MIT"
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=1.5, step_size=1e-3)

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._values: dict[str, Any] = {v.name: _zero(v) if v.start is None else v.start
                                        for v in VARIABLES}
        self._t_start = 0.0
        self._t_stop: float | None = None
        self._run: cosim.Run | None = None
        self._window: cosim.Window | None = None
        self._command = False
        for v in VARIABLES:
            self._register(v)

    def _register(self, v: Variable) -> None:
        variability = (_VARIABILITY.get(v.causality)
                       or (Fmi2Variability.discrete if v.type == "Integer"
                           else Fmi2Variability.continuous))
        kind = _TYPES[v.type]
        self.register_variable(kind(
            v.name, causality=_CAUSALITY[v.causality], variability=variability,
            description=v.description,
            getter=lambda name=v.name: self._values[name],
            setter=None if v.causality == "output" else
            (lambda value, name=v.name: self._values.__setitem__(name, value))))

    def setup_experiment(self, start_time: float, stop_time: float | None,
                         tolerance: float | None) -> None:
        self._t_start = float(start_time)
        self._t_stop = None if stop_time is None else float(stop_time)

    def exit_initialization_mode(self) -> None:
        try:
            if self._t_start < 0.0:
                raise TrebuchetInputError(f"start time = {self._t_start:g} s: the FMU's time "
                                          "is the time after the trigger and starts at 0 or "
                                          "later")
            scene = scene_from_parameters(self._values)
            self._run = cosim.start_run(scene, self._t_stop)
            self._command = bool(self._values["release_command"])
            self._window = None
            self._publish(self._t_start, 0.0)
        except TrebuchetInputError as exc:
            self.log(str(exc), Fmi2Status.error)
            raise

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self._run is None:
            self.log("doStep before a successful initialisation", Fmi2Status.error)
            return False
        try:
            command = bool(self._values["release_command"])
            if command and not self._command:
                self._run, ignored = cosim.command_release(self._run, current_time)
                if ignored:
                    self.log(ignored, Fmi2Status.warning)
                else:
                    self._window = None
            self._command = command
            self._publish(current_time + step_size, step_size)
        except TrebuchetInputError as exc:
            self.log(str(exc), Fmi2Status.error)
            raise
        return True

    def _publish(self, t: float, h: float) -> None:
        """Hold every output at ``t`` (s) for the getters; ``h`` (s) the step that led there.

        Outputs come from a window precomputed for the next communication points (one call
        of the simulator's loads per window instead of one per step)."""
        run = cosim.covering(self._run, t)
        if run is not self._run:
            self._run, self._window = run, None
        row = cosim.lookup(self._run, self._window, t)
        if row is None:
            self._window = cosim.window(self._run, t, h)
            row = self._window.values[0]
        self._values.update(zip(cosim.OUTPUT_NAMES, row.tolist(), strict=True))


def _zero(v: Variable) -> Any:
    return {"Real": 0.0, "Integer": 0, "Boolean": False, "String": ""}[v.type]
