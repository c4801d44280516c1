"""The block YAML and the XML of camera files, read without a YAML or XML library's
general machinery: OpenCV's FileStorage (YAML ``%YAML:1.0`` with ``!!opencv-matrix``, XML
``<opencv_storage>``), ROS's camera_info and Kalibr's camchain YAML. Each gives a plain dict
that :mod:`.user_calibration` reads its lens and points from.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from trebuchet.core.errors import TrebuchetInputError

__all__ = ["opencv_xml", "camera_yaml"]


def opencv_xml(text: str) -> dict:
    """OpenCV's FileStorage XML: ``<opencv_storage>`` with ``<key type_id="opencv-matrix">``
    (rows, cols, dt, data) and scalar keys."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise TrebuchetInputError(f"not valid XML ({exc})") from None
    out: dict = {}
    for child in root:
        if child.get("type_id") == "opencv-matrix" or child.find("data") is not None:
            cells = {c.tag: (c.text or "").strip() for c in child}
            out[child.tag] = {"rows": cells.get("rows"), "cols": cells.get("cols"),
                              "data": cells.get("data", "").split()}
        else:
            out[child.tag] = (child.text or "").strip().strip('"')
    return out


def camera_yaml(text: str) -> dict:
    """The block YAML of camera files (OpenCV FileStorage, ROS camera_info, Kalibr): nested
    maps by indentation, ``key: value`` scalars, flow lists ``[…]`` (over several lines),
    tags (``!!opencv-matrix``) and ``%``/``---`` lines ignored. Not a general YAML parser."""
    lines = []
    for raw in text.splitlines():
        line = raw.split(" #")[0].rstrip() if not raw.lstrip().startswith("#") else ""
        if not line.strip() or line.startswith(("%", "---", "...")):
            continue
        lines.append(line)
    joined: list[str] = []  # flow lists spread over several lines, joined
    for line in lines:
        if joined and joined[-1].count("[") > joined[-1].count("]"):
            joined[-1] += " " + line.strip()
        else:
            joined.append(line)
    root: dict = {}
    stack: list[tuple[int, dict]] = [(-1, root)]
    for line in joined:
        indent = len(line) - len(line.lstrip())
        key, sep, value = line.strip().partition(":")
        if not sep or key.startswith("-"):
            continue  # a list item or stray line: not in camera files
        while stack[-1][0] >= indent:
            stack.pop()
        value = re.sub(r"^!!\S+", "", value.strip()).strip()
        if value == "":
            child: dict = {}
            stack[-1][1][key.strip()] = child
            stack.append((indent, child))
        elif value.startswith("["):
            stack[-1][1][key.strip()] = [v.strip().strip("'\"") for v in
                                         value.strip("[] ").split(",") if v.strip()]
        else:
            stack[-1][1][key.strip()] = value.strip("'\"")
    return root
