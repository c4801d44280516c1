"""Example: a plain Python loop coupling the FMU with a second model, a release controller.

    python fmu/examples/speed_controller.py Trebuchet.fmu out.csv [TARGET_SPEED]

The controller reads the projectile's velocity from the FMU at every communication point and
raises the release command once the projectile (in the sling) reaches TARGET_SPEED m/s; the
FMU releases at the next communication point. 1 ms steps for 1.5 s; writes
``time, phase, speed, release_command`` to ``out.csv``.
"""

from __future__ import annotations

import math
import shutil
import sys
from dataclasses import dataclass

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave


@dataclass(frozen=True)
class SpeedController:
    """Second model: command = (phase 2 and speed >= target) or an earlier command."""

    target: float  # m/s

    def command(self, phase: int, speed: float, previous: bool) -> bool:
        return previous or (phase == 2 and speed >= self.target)


def main(fmu: str, out: str, target: float = 50.0, step: float = 1e-3,
         stop: float = 1.5) -> list[tuple[float, int, float, bool]]:
    """Co-simulate ``fmu`` with :class:`SpeedController`; returns the rows written."""
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(fmu)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="trebuchet")
    controller = SpeedController(target)
    rows = []
    try:
        slave.instantiate()
        slave.setupExperiment(startTime=0.0, stopTime=stop)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        command, n = False, int(round(stop / step))
        for k in range(n + 1):
            t = k * step
            phase = slave.getInteger([vr["phase"]])[0]
            vx, vy = slave.getReal([vr["vx_m"], vr["vy_m"]])
            command = controller.command(phase, math.hypot(vx, vy), command)
            rows.append((t, phase, math.hypot(vx, vy), command))
            if k == n:
                break
            slave.setBoolean([vr["release_command"]], [command])
            slave.doStep(currentCommunicationPoint=t, communicationStepSize=step)
        slave.terminate()
    finally:
        slave.freeInstance()
        shutil.rmtree(unzipped, ignore_errors=True)
    with open(out, "w") as f:
        f.write("time,phase,speed,release_command\n")
        f.writelines(f"{t!r},{p},{s!r},{int(c)}\n" for t, p, s, c in rows)
    first = next((t for t, _, _, c in rows if c), None)
    print(f"target {target} m/s: command raised at {first} s")
    return rows


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *(float(a) for a in sys.argv[3:4]))
