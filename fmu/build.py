"""Build ``Trebuchet.fmu``: pythonfmu around the slave script, then a complete model description.

pythonfmu writes a modelDescription.xml without units, ranges or InitialUnknowns; ``fmpy
validate`` rejects it. :func:`complete_model_description` rewrites it from the interface table
(:data:`trebuchet.fmu.interface.VARIABLES`): unit definitions, every variable's unit, start
value and range, and the model structure (outputs and initial unknowns).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from trebuchet.fmu.interface import UNITS, VARIABLES
from trebuchet.output import atomic_path

__all__ = ["build_fmu", "complete_model_description", "SLAVE_SCRIPT", "MODEL_NAME"]

SLAVE_SCRIPT = Path(__file__).with_name("trebuchet_fmu_slave.py")
MODEL_NAME = "Trebuchet"


def build_fmu(target: str | Path) -> Path:
    """Build the co-simulation FMU at ``target`` (written whole or not at all); returns it.

    The FMU runs in a host Python that has this package (and numpy, scipy, pandas) installed.
    """
    from pythonfmu import FmuBuilder  # imported here: building is rare, importing is not

    target = Path(target)
    with tempfile.TemporaryDirectory(prefix="trebuchet_fmu_") as tmp:
        src = Path(tmp) / "src"
        src.mkdir()
        script = Path(shutil.copy2(SLAVE_SCRIPT, src))
        module = script.stem
        path_before, had_module = list(sys.path), module in sys.modules
        try:
            raw = FmuBuilder.build_FMU(script, dest=Path(tmp) / f"{MODEL_NAME}.fmu")
        finally:  # pythonfmu leaves its script folder on sys.path and the module imported
            sys.path[:] = path_before
            if not had_module:
                sys.modules.pop(module, None)
        with atomic_path(target) as out, zipfile.ZipFile(raw) as zin, \
                zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
            for item in zin.infolist():
                data = zin.read(item)
                if item.filename == "modelDescription.xml":
                    data = complete_model_description(data)
                zout.writestr(item, data)
    return target


def complete_model_description(xml: bytes) -> bytes:
    """pythonfmu's modelDescription.xml with unit definitions, units, ranges and the model
    structure (Outputs, InitialUnknowns) added."""
    root = ET.fromstring(xml)
    table = {v.name: v for v in VARIABLES}
    scalars = root.find("ModelVariables").findall("ScalarVariable")
    outputs = []
    for index, sv in enumerate(scalars, start=1):
        v = table[sv.get("name")]
        if v.causality == "output":
            outputs.append(index)
        child = sv[0]
        if v.unit is not None:
            child.set("unit", v.unit)
        if v.min is not None:
            child.set("min", _number(v.min))
        if v.max is not None:
            child.set("max", _number(v.max))
        if v.type == "Real" and v.start is not None:
            child.set("start", _number(v.start))

    units = ET.Element("UnitDefinitions")
    for name, (exponents, factor) in UNITS.items():
        unit = ET.SubElement(units, "Unit", name=name)
        base = ET.SubElement(unit, "BaseUnit", {k: str(n) for k, n in exponents.items()})
        if factor != 1.0:
            base.set("factor", repr(factor))
    root.insert(list(root).index(root.find("CoSimulation")) + 1, units)

    old = root.find("ModelStructure")
    if old is not None:
        root.remove(old)
    structure = ET.SubElement(root, "ModelStructure")
    for section in ("Outputs", "InitialUnknowns"):
        node = ET.SubElement(structure, section)
        for index in outputs:
            ET.SubElement(node, "Unknown", index=str(index))
    for elem in root.iter():
        if elem.text is not None and not elem.text.strip():
            elem.text = None
        elem.tail = None
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def _number(value: float) -> str:
    return repr(float(value))
