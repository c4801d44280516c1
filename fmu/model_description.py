"""``modelDescription.xml`` of the native FMU, from the interface table.

One FMU for both interface types: FMI 2.0 (``ModelExchange`` and ``CoSimulation`` elements
with one model identifier) or FMI 3.0. Units, display units (deg for the angles), ranges,
Enumerations for the choices, the model structure with the states θ, ψ, φ and their rates
(their derivatives are the outputs ``*_d`` and ``*_dd``) and the capabilities of the C code
(FMU state get, set and serialise; in model exchange, directional derivatives of the outputs
with respect to the states, from the generated Jacobians).
"""

from __future__ import annotations

from xml.etree import ElementTree as ET

from trebuchet.core.version import __version__
from trebuchet.fmu.interface import DISPLAY_UNITS, UNITS, VARIABLES, Variable

__all__ = ["model_description", "STATES", "MODEL_NAME", "N_EVENT_INDICATORS"]

MODEL_NAME = "Trebuchet"
#: The continuous states of the model exchange, in order, with their derivatives.
STATES = (("theta", "theta_d"), ("psi", "psi_d"), ("phi", "phi_d"),
          ("theta_d", "theta_dd"), ("psi_d", "psi_dd"), ("phi_d", "phi_dd"),
          ("E_loss_pivot", "P_loss_pivot"), ("E_loss_hinge", "P_loss_hinge"))
N_EVENT_INDICATORS = 3
_INDICATORS = ("phase I: lift-off margin F_N/(m g); phase II: projectile height (m)",
               "phase I: sling upright margin; phase II: climb margin (m/s, release angle)",
               "unused (1)")
_DESCRIPTION = ("Swinging-counterweight trebuchet after Horsdal: angles, internal forces, torque, "
                "rates of work and energies of a shot, with a release command input "
                f"(trebuchet {__version__}, native C)")


def _num(value: float) -> str:
    return repr(float(value))


def _units(root: ET.Element, fmi: int) -> None:
    units = ET.SubElement(root, "UnitDefinitions")
    for name, (exponents, factor) in UNITS.items():
        unit = ET.SubElement(units, "Unit", name=name)
        base = ET.SubElement(unit, "BaseUnit", {k: str(n) for k, n in exponents.items()})
        if factor != 1.0:
            base.set("factor", repr(factor))
        if name in DISPLAY_UNITS:
            shown, scale = DISPLAY_UNITS[name]
            ET.SubElement(unit, "DisplayUnit", name=shown, factor=repr(scale))


def _enumerations(root: ET.Element, fmi: int) -> None:
    types = ET.SubElement(root, "TypeDefinitions")
    for v in VARIABLES:
        if v.type != "Enumeration":
            continue
        if fmi == 2:
            simple = ET.SubElement(types, "SimpleType", name=v.type_name)
            enum = ET.SubElement(simple, "Enumeration")
        else:
            enum = ET.SubElement(types, "EnumerationType", name=v.type_name)
        for k, choice in enumerate(v.choices, start=1):
            ET.SubElement(enum, "Item", name=choice, value=str(k))


def _attributes(v: Variable) -> dict[str, str]:
    a: dict[str, str] = {}
    if v.type == "Enumeration":
        a["declaredType"] = v.type_name
    if v.unit is not None:
        a["unit"] = v.unit
    if v.display_unit is not None:
        a["displayUnit"] = v.display_unit
    if v.min is not None:
        a["min"] = _num(v.min)
    if v.max is not None:
        a["max"] = _num(v.max)
    if v.causality != "output":
        if v.type == "Enumeration":
            a["start"] = str(v.choices.index(v.start) + 1)
        elif v.type == "Boolean":
            a["start"] = "true" if v.start else "false"
        else:
            a["start"] = _num(v.start)
    return a


def _variability(v: Variable) -> str:
    if v.causality == "parameter":
        return "fixed"
    return "continuous" if v.type == "Real" else "discrete"


def _variables_fmi2(root: ET.Element, index: dict[str, int]) -> None:
    variables = ET.SubElement(root, "ModelVariables")
    derivative_of = {d: s for s, d in STATES}
    for vr, v in enumerate(VARIABLES):
        sv = ET.SubElement(variables, "ScalarVariable", name=v.name, valueReference=str(vr),
                           description=v.description, causality=v.causality,
                           variability=_variability(v))
        if v.causality == "parameter":
            sv.set("initial", "exact")
        kind = "Integer" if v.type == "Integer" else v.type
        elem = ET.SubElement(sv, kind, _attributes(v))
        if v.name in derivative_of:
            elem.set("derivative", str(index[derivative_of[v.name]]))


def _structure_fmi2(root: ET.Element, index: dict[str, int]) -> None:
    structure = ET.SubElement(root, "ModelStructure")
    outputs = [index[v.name] for v in VARIABLES if v.causality == "output"]
    node = ET.SubElement(structure, "Outputs")
    for i in outputs:
        ET.SubElement(node, "Unknown", index=str(i))
    node = ET.SubElement(structure, "Derivatives")
    for _, d in STATES:
        ET.SubElement(node, "Unknown", index=str(index[d]))
    node = ET.SubElement(structure, "InitialUnknowns")
    for i in sorted(outputs):
        ET.SubElement(node, "Unknown", index=str(i))


_FMI3_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean",
               "Enumeration": "Enumeration"}


def _variables_fmi3(root: ET.Element) -> None:
    variables = ET.SubElement(root, "ModelVariables")
    vr_of = {v.name: vr for vr, v in enumerate(VARIABLES)}
    derivative_of = {d: s for s, d in STATES}
    ET.SubElement(variables, "Float64", name="time",
                  valueReference=str(len(VARIABLES) + N_EVENT_INDICATORS),
                  causality="independent", variability="continuous", unit="s",
                  description="time after the trigger")
    for vr, v in enumerate(VARIABLES):
        attributes = {"name": v.name, "valueReference": str(vr), "description": v.description,
                      "causality": v.causality, "variability": _variability(v),
                      **_attributes(v)}
        if v.name in derivative_of:
            attributes["derivative"] = str(vr_of[derivative_of[v.name]])
        ET.SubElement(variables, _FMI3_TYPES[v.type], attributes)
    for k in range(N_EVENT_INDICATORS):
        ET.SubElement(variables, "Float64", name=f"event_indicator[{k + 1}]",
                      valueReference=str(len(VARIABLES) + k), causality="local",
                      variability="continuous", description=_INDICATORS[k])


def _structure_fmi3(root: ET.Element) -> None:
    structure = ET.SubElement(root, "ModelStructure")
    vr_of = {v.name: vr for vr, v in enumerate(VARIABLES)}
    outputs = [vr_of[v.name] for v in VARIABLES if v.causality == "output"]
    for vr in outputs:
        ET.SubElement(structure, "Output", valueReference=str(vr))
    for _, d in STATES:
        ET.SubElement(structure, "ContinuousStateDerivative", valueReference=str(vr_of[d]))
    for vr in outputs:
        ET.SubElement(structure, "InitialUnknown", valueReference=str(vr))
    for k in range(N_EVENT_INDICATORS):
        ET.SubElement(structure, "EventIndicator", valueReference=str(len(VARIABLES) + k))


def model_description(guid: str, fmi: int, source_files: tuple[str, ...]) -> bytes:
    """The ``modelDescription.xml`` (UTF-8) of FMI version ``fmi`` (2 or 3)."""
    common = {"modelName": MODEL_NAME, "description": _DESCRIPTION,
              "generationTool": f"trebuchet {__version__} (trebuchet fmu build)",
              "version": __version__, "variableNamingConvention": "structured",
              "license": "MIT"}
    caps = {"canGetAndSetFMUState": "true", "canSerializeFMUState": "true"}
    if fmi == 2:
        root = ET.Element("fmiModelDescription", fmiVersion="2.0", guid=guid,
                          numberOfEventIndicators=str(N_EVENT_INDICATORS), **common)
        caps2 = {"canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true",
                 "canNotUseMemoryManagementFunctions": "true"}
        me = ET.SubElement(root, "ModelExchange", modelIdentifier=MODEL_NAME,
                           completedIntegratorStepNotNeeded="true",
                           providesDirectionalDerivative="true", **caps2)
        cs = ET.SubElement(root, "CoSimulation", modelIdentifier=MODEL_NAME,
                           canHandleVariableCommunicationStepSize="true", **caps2)
        for kind in (me, cs):
            files = ET.SubElement(kind, "SourceFiles")
            for name in source_files:
                ET.SubElement(files, "File", name=name)
    else:
        root = ET.Element("fmiModelDescription", fmiVersion="3.0", instantiationToken=guid,
                          **common)
        ET.SubElement(root, "ModelExchange", modelIdentifier=MODEL_NAME,
                      needsCompletedIntegratorStep="false", providesDirectionalDerivatives="true",
                      **caps)
        ET.SubElement(root, "CoSimulation", modelIdentifier=MODEL_NAME,
                      canHandleVariableCommunicationStepSize="true", **caps)
    _units(root, fmi)
    _enumerations(root, fmi)
    categories = ET.SubElement(root, "LogCategories")
    for name in ("logStatusError", "logStatusWarning"):
        ET.SubElement(categories, "Category", name=name)
    ET.SubElement(root, "DefaultExperiment", startTime="0.0", stopTime="1.5", stepSize="0.001",
                  tolerance="1e-10")
    if fmi == 2:
        index = {v.name: i for i, v in enumerate(VARIABLES, start=1)}
        _variables_fmi2(root, index)
        _structure_fmi2(root, index)
    else:
        _variables_fmi3(root)
        _structure_fmi3(root)
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)
