"""A user's own calibration of the camera: read from a file, applied to tracked pixels.

Two kinds, decided from the file's content (never its extension):

* **known points** in the engine's plane: four or more points whose image position ``u``,
  ``v`` (px; ``u`` along the row, ``v`` the row counted down from the top, as image tools,
  DeepLabCut and SLEAP give them) and plane position ``x``, ``y`` (m; ``y`` up, ``x`` the
  way the picture's ``u`` runs, any origin) are known: a CSV with those four columns (units
  in the header, e.g. ``x (cm)``), or a TOML ``[[point]]`` list. They fix the map from
  the image to the plane, a homography (:func:`.camera.homography_from_points`), and with
  it the tilt, roll and scale; with five or more points the reprojection residual (px)
  says how well (:data:`RESIDUAL_WARN_PX`). A lens (below) in the same TOML or JSON file
  is taken out of the clicked pixels first.
* **a camera file**: OpenCV's camera matrix and distortion coefficients, as written by
  ``cv::FileStorage`` (YAML ``%YAML:1.0`` with ``!!opencv-matrix``, or XML
  ``<opencv_storage>``: OpenCV's calibration samples, keys ``camera_matrix`` and
  ``distortion_coefficients``), by ROS's ``camera_calibration`` (camera_info YAML: the
  same keys as ``rows``/``cols``/``data`` maps, ``distortion_model: plumb_bob`` or
  ``rational_polynomial``), by Kalibr (camchain YAML: ``intrinsics: [fu, fv, pu, pv]``,
  ``distortion_model: radtan``, ``distortion_coeffs: [k1, k2, p1, p2]``), or a JSON file
  with OpenCV's keys. It fixes the lens: the tracked pixels are undistorted
  (:func:`undistort_opencv`, OpenCV's ``undistortPoints`` model: k1, k2, p1, p2, k3, k4,
  k5, k6). It does **not** fix where the engine's plane stands before the camera (tilt,
  roll, scale). With the scene known, :func:`plane_from_engine` finds that from the
  engine's own geometry (:class:`PlanePose`); without it the angles keep the tilt's error.

Pixels here are the readers' (``y`` up: the row negated); the calibration files' are
OpenCV's (rows down) and are turned on reading.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.core.user_files import read_user_file
from trebuchet.ingest.readers.table import DECIMAL

from .camera import apply_homography, homography_from_points
from .camera_files import camera_yaml, opencv_xml
from .plane_pose import PlanePose, plane_from_engine, rectified

__all__ = ["Lens", "UserCalibration", "read_calibration", "undistort_opencv",
           "RESIDUAL_WARN_PX", "PlanePose", "plane_from_engine", "rectified"]

#: A reprojection residual (px, rms per coordinate, corrected for the homography's eight
#: degrees of freedom) beyond which the known points warn: a mistyped point, or a lens
#: that bends (give its camera file too).
RESIDUAL_WARN_PX = 2.0
#: OpenCV's distortion coefficients in their order; more (thin prism, tilted sensor) are
#: not modelled and refused.
OPENCV_COEFFICIENTS = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")
#: Bytes of a calibration file (a camera file or a list of points is a few kB).
MAX_CALIBRATION_BYTES = 1 << 20
#: Largest magnitude of any number of a calibration file (px, m, lens coefficients).
MAX_MAGNITUDE = 1e9
#: Length units of the plane points' header, in m.
PLANE_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}


@dataclass(frozen=True)
class Lens:
    """OpenCV's camera model: ``matrix`` K (3×3, px, rows down), ``distortion`` (k1, k2, p1,
    p2[, k3[, k4, k5, k6]]), dimensionless, on coordinates normalised by the focal length;
    ``image_size`` (width, height) px when the file states it."""

    matrix: np.ndarray
    distortion: np.ndarray
    image_size: tuple[int, int] | None = None

    @property
    def focal(self) -> float:
        """fx (px): undistorted pixels are put on square pixels of this size."""
        return float(self.matrix[0, 0])

    def undistort(self, xy_up: np.ndarray) -> np.ndarray:
        """Readers' pixels (…, 2, y up) with the lens taken out: the pinhole camera's pixels
        (y up, square, of size fx, principal point unchanged)."""
        uv = np.asarray(xy_up, dtype=float) * [1.0, -1.0]
        return undistort_opencv(uv, self.matrix, self.distortion) * [1.0, -1.0]


def undistort_opencv(uv: np.ndarray, matrix: np.ndarray, distortion: np.ndarray,
                     iterations: int = 20) -> np.ndarray:
    """OpenCV's ``undistortPoints(uv, K, d, P=K')`` with ``K'`` = K with fy set to fx:
    pixels (…, 2, rows down) to undistorted pixels. The normalised point ``x_d = K⁻¹ u`` is
    solved for ``x`` in ``x_d = x (1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶)
    + (2 p1 x y + p2 (r² + 2x²), p1 (r² + 2y²) + 2 p2 x y)`` by OpenCV's fixed-point
    iteration."""
    d = np.zeros(8)
    d[:len(distortion)] = distortion
    k1, k2, p1, p2, k3, k4, k5, k6 = d
    fx, fy, cx, cy, skew = matrix[0, 0], matrix[1, 1], matrix[0, 2], matrix[1, 2], matrix[0, 1]
    uv = np.asarray(uv, dtype=float)
    y0 = (uv[..., 1] - cy) / fy
    x0 = (uv[..., 0] - cx - skew * y0) / fx
    x, y = x0.copy(), y0.copy()
    for _ in range(iterations):
        r2 = x * x + y * y
        icdist = (1 + ((k6 * r2 + k5) * r2 + k4) * r2) / (1 + ((k3 * r2 + k2) * r2 + k1) * r2)
        dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        x, y = (x0 - dx) * icdist, (y0 - dy) * icdist
    return np.stack([x * fx + cx, y * fx + cy], axis=-1)


@dataclass(frozen=True)
class UserCalibration:
    """A user's calibration file, read.

    ``source`` the file; ``kind`` "points" (known plane points) or "camera" (a camera
    file); ``lens`` the :class:`Lens` when the file has one; ``homography`` (3×3) from the
    plane (m, y up) to the lens-free pixels (y up) when the file has points, else None;
    ``plane``, ``image`` the known points (m; px, y up), ``residual_px`` the rms
    reprojection residual per coordinate (px, over 2n − 8 degrees of freedom; None for
    fewer than five points); ``layout`` the file's layout in words.
    """

    source: str
    kind: str
    layout: str
    lens: Lens | None = None
    homography: np.ndarray | None = field(default=None, repr=False)
    plane: np.ndarray | None = field(default=None, repr=False)
    image: np.ndarray | None = field(default=None, repr=False)
    residual_px: float | None = None

    @property
    def fixes_plane(self) -> bool:
        """Whether the file fixes the map to the engine's plane (points), not the lens only."""
        return self.homography is not None

    def to_plane(self, xy_up: np.ndarray) -> np.ndarray:
        """Tracked pixels (…, 2, y up) to the engine's plane (m, y up) for known points,
        or to the lens-free pixels (y up) for a camera file alone."""
        xy = np.asarray(xy_up, dtype=float)
        if self.lens is not None:
            xy = self.lens.undistort(xy)
        if self.homography is not None:
            xy = apply_homography(np.linalg.inv(self.homography), xy)
        return xy

    def describe(self) -> str:
        """One sentence: what the file fixed (for the log's decisions)."""
        name = Path(self.source).name
        if self.kind == "points":
            n = 0 if self.plane is None else len(self.plane)
            fit = (f", reprojection residual {self.residual_px:.2f} px rms" if self.residual_px
                   is not None else " (four points: no residual to check them by)")
            lens = " after taking out its lens" if self.lens is not None else ""
            return (f"points taken from the image to the engine's plane (m) by the homography "
                    f"of {n} known points in {name} ({self.layout}){lens}{fit}")
        K = self.lens.matrix
        return (f"lens distortion taken out of the tracked pixels by {name} ({self.layout}: "
                f"fx {K[0, 0]:.1f} px, fy {K[1, 1]:.1f} px, k1 {self.lens.distortion[0]:.4g}); "
                "a camera file does not fix the plane's tilt or roll (reconstruct finds them "
                "from the engine's geometry; read_log alone leaves their error)")


# ------------------------------------------------------------------ reading

def read_calibration(path: str | Path) -> UserCalibration:
    """Read a calibration file (see the module doc); ``TrebuchetInputError`` naming the
    file, the key or row, and what is wrong, for anything else."""
    p = Path(path)
    try:
        raw = read_user_file(p, "calibration file", MAX_CALIBRATION_BYTES)
    except TrebuchetInputError as exc:
        problem = "cannot be read (no such file)" if exc.message == "no such file" else (
            exc.message)
        raise TrebuchetInputError(f"calibration file {p}: {problem}") from None
    try:
        text = raw.decode("utf-8-sig")
        if "\x00" in text:
            raise UnicodeDecodeError("utf-8", raw, 0, 1, "NUL")
    except UnicodeDecodeError:
        raise TrebuchetInputError(f"calibration file {p.name}: not a text file (a camera "
                                  "file is YAML, XML or JSON; known points CSV or TOML)"
                                  ) from None
    try:
        cal = _parse(text, str(p))
    except TrebuchetInputError as exc:
        raise exc.in_file(p.name) from None
    except RecursionError:
        raise TrebuchetInputError(f"{p.name}: nested more deeply than any calibration file "
                                  "is (lists or tables within each other)") from None
    return cal


def _parse(text: str, source: str) -> UserCalibration:
    """Decide the layout from the content and read it."""
    head = text.lstrip()
    if head.startswith("<"):
        return _from_mapping(opencv_xml(text), source, "OpenCV FileStorage XML")
    if head.startswith("{"):
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise TrebuchetInputError.at(f"line {exc.lineno}", f"not valid JSON ({exc.msg})"
                                         ) from None
        except ValueError as exc:  # an integer of more than 4300 digits
            raise TrebuchetInputError(f"not valid JSON ({exc})") from None
        return _from_mapping(data, source, "JSON")
    if head.startswith("%YAML") or "!!opencv-matrix" in text:
        return _from_mapping(camera_yaml(text), source, "OpenCV FileStorage YAML")
    if re.search(r"^\s*\[\[\s*point\s*\]\]", text, re.MULTILINE) or re.search(
            r"^\s*camera_matrix\s*=", text, re.MULTILINE):
        try:
            data = tomllib.loads(text)
        except ValueError as exc:  # TOMLDecodeError, or an integer of more than 4300 digits
            raise TrebuchetInputError(f"not valid TOML ({exc})") from None
        return _from_mapping(data, source, "TOML")
    if re.search(r"^\s*(camera_matrix|cam\d+|intrinsics)\s*:", text, re.MULTILINE):
        data = camera_yaml(text)
        layout = "Kalibr camchain YAML" if _kalibr_camera(data) else "ROS camera_info YAML"
        return _from_mapping(data, source, layout)
    first = next((ln for ln in text.splitlines() if ln.strip()), "")
    if first and re.search(r"\bu\b", first) and re.search(r"\bx\b", first):
        return _points_csv(text, source)
    raise TrebuchetInputError(
        "not a calibration this reads: expected known points (a CSV with columns u, v (px) "
        "and x, y (m), or a TOML [[point]] list) or a camera file (OpenCV FileStorage YAML or "
        "XML, ROS camera_info or Kalibr YAML, JSON with camera_matrix and "
        "distortion_coefficients)")


def _from_mapping(data: Mapping, source: str, layout: str) -> UserCalibration:
    """A parsed YAML, XML, JSON or TOML file: its lens and/or its points."""
    if not isinstance(data, Mapping):
        raise TrebuchetInputError(f"{layout}: expected a mapping of keys at the top")
    kalibr = _kalibr_camera(data)
    lens = _kalibr_lens(kalibr) if kalibr is not None else _opencv_lens(data, layout)
    camera = data.get("camera")
    if lens is None and isinstance(camera, Mapping):
        lens = _opencv_lens(camera, layout, "camera.")
    points = data.get("point", data.get("points"))
    if points is None:
        if lens is None:
            raise TrebuchetInputError(
                f"{layout}: no key camera_matrix (a camera file) and no point list (known "
                f"points); keys found: {', '.join(map(str, data)) or 'none'}")
        return UserCalibration(source, "camera", layout, lens=lens)
    plane, image = _point_list(points)
    return _with_points(source, layout, plane, image, lens)


def _with_points(source: str, layout: str, plane: np.ndarray, image_rows_down: np.ndarray,
                 lens: Lens | None) -> UserCalibration:
    """The homography of the known points (image turned y up, lens taken out) and its
    residual."""
    image = image_rows_down * [1.0, -1.0]
    flat = lens.undistort(image) if lens is not None else image
    Hm = homography_from_points(plane, flat)
    if not np.isfinite(Hm).all() or np.linalg.cond(Hm) > 1e12:
        raise TrebuchetInputError("the image points do not fix a homography (three or more "
                                  "on one line in the picture, or the same point twice?)")
    n = plane.shape[0]
    residual = None
    if n >= 5:
        err = apply_homography(Hm, plane) - flat
        residual = float(math.sqrt(np.sum(err * err) / (2 * n - 8)))
    return UserCalibration(source, "points", layout, lens=lens, homography=Hm, plane=plane,
                           image=image, residual_px=residual)


def _number(value: object, key: str) -> float:
    """A finite number of at most :data:`MAX_MAGNITUDE`, else an error naming ``key``; text
    is a number only in ASCII decimals (as CSV tools read it)."""
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise TrebuchetInputError(f"key {key}: {_shown(value)} is not a number")
    if isinstance(value, str) and not DECIMAL.fullmatch(value.strip()):
        raise TrebuchetInputError(f"key {key}: {_shown(value)} is not a number")
    try:
        x = float(value)
    except (ValueError, OverflowError):
        raise TrebuchetInputError(f"key {key}: {_shown(value)} is not a finite number"
                                  ) from None
    if not math.isfinite(x):
        raise TrebuchetInputError(f"key {key}: {_shown(value)} is not a finite number")
    if abs(x) > MAX_MAGNITUDE:
        raise TrebuchetInputError(f"key {key}: {x:.4g} is beyond {MAX_MAGNITUDE:.0e}, which no "
                                  "pixel, length or lens coefficient reaches")
    return x


def _shown(value: object) -> str:
    """A value for a message: its repr, cut to 40 characters."""
    if isinstance(value, list | tuple | Mapping):
        return f"a {type(value).__name__} of {len(value)}"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _numbers(value: object, key: str) -> np.ndarray:
    """A list of numbers (nested lists flattened, or a ``rows``/``cols``/``data`` map)."""
    if isinstance(value, Mapping):
        if "data" not in value:
            raise TrebuchetInputError(f"key {key}: a matrix map needs 'data' (and rows, "
                                      f"cols); found {', '.join(map(str, value))}")
        out = _numbers(value["data"], f"{key}.data")
        rows, cols = value.get("rows"), value.get("cols")
        if rows is not None and cols is not None and int(_number(rows, f"{key}.rows")) * int(
                _number(cols, f"{key}.cols")) != out.size:
            raise TrebuchetInputError(f"key {key}: rows × cols = {rows} × {cols} but "
                                      f"{out.size} numbers in data")
        return out
    if isinstance(value, list | tuple):
        flat: list[float] = []
        for v in value:
            if isinstance(v, list | tuple):  # a matrix's rows; deeper is no camera file's
                if any(isinstance(w, list | tuple | Mapping) for w in v):
                    raise TrebuchetInputError(f"key {key}: lists nested more than two deep")
                flat.extend(_number(w, key) for w in v)
            else:
                flat.append(_number(v, key))
        return np.array(flat, dtype=float)
    return np.array([_number(value, key)])


def _opencv_lens(data: Mapping, layout: str, prefix: str = "") -> Lens | None:
    """OpenCV's (and ROS's) ``camera_matrix`` and ``distortion_coefficients``; None without
    a camera matrix."""
    key = next((k for k in ("camera_matrix", "cameraMatrix", "K") if k in data), None)
    if key is None:
        return None
    K = _numbers(data[key], prefix + key)
    if K.size != 9:
        raise TrebuchetInputError(f"key {prefix}{key}: {K.size} numbers; a camera matrix "
                                  "has 9 (3 × 3, px)")
    K = K.reshape(3, 3)
    model = data.get("distortion_model")
    if model is not None and str(model) not in ("plumb_bob", "rational_polynomial"):
        raise TrebuchetInputError(f"key {prefix}distortion_model: {model!r} is not read "
                                  "(plumb_bob and rational_polynomial are; fisheye/"
                                  "equidistant lenses are not modelled)")
    dkey = next((k for k in ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D")
                 if k in data), None)
    d = np.zeros(5) if dkey is None else _numbers(data[dkey], prefix + dkey)
    return Lens(_checked_matrix(K, prefix + key), _checked_distortion(d, prefix + (dkey or "")),
                _image_size(data))


def _kalibr_camera(data: Mapping) -> Mapping | None:
    """The first camera (``cam0``, …) of a Kalibr camchain, else None."""
    for k in sorted(str(k) for k in data):
        if re.fullmatch(r"cam\d+", k) and isinstance(data[k], Mapping) \
                and "intrinsics" in data[k]:
            return data[k]
    return data if "intrinsics" in data and "distortion_coeffs" in data else None


def _kalibr_lens(cam: Mapping) -> Lens:
    """Kalibr's pinhole-radtan camera: ``intrinsics`` [fu, fv, pu, pv], ``distortion_coeffs``
    [k1, k2, r1, r2] (OpenCV's k1, k2, p1, p2)."""
    model = str(cam.get("camera_model", "pinhole"))
    dist_model = str(cam.get("distortion_model", "radtan"))
    if model != "pinhole" or dist_model not in ("radtan", "none"):
        raise TrebuchetInputError(f"key camera_model/distortion_model: {model}-{dist_model} "
                                  "is not read (only Kalibr's pinhole-radtan)")
    fu_fv_pu_pv = _numbers(cam["intrinsics"], "intrinsics")
    if fu_fv_pu_pv.size != 4:
        raise TrebuchetInputError(f"key intrinsics: {fu_fv_pu_pv.size} numbers; Kalibr "
                                  "writes four: fu, fv, pu, pv (px)")
    fu, fv, pu, pv = fu_fv_pu_pv
    K = np.array([[fu, 0.0, pu], [0.0, fv, pv], [0.0, 0.0, 1.0]])
    d = _numbers(cam.get("distortion_coeffs", [0.0] * 4), "distortion_coeffs")
    size = cam.get("resolution")
    wh = tuple(int(v) for v in _numbers(size, "resolution")) if size is not None else None
    return Lens(_checked_matrix(K, "intrinsics"), _checked_distortion(d, "distortion_coeffs"),
                wh if wh and len(wh) == 2 else None)


def _checked_matrix(K: np.ndarray, key: str) -> np.ndarray:
    """A camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0."""
    if not (K[0, 0] > 0 and K[1, 1] > 0) or np.any(K[1:, 0] != 0) or K[2, 1] != 0 \
            or K[2, 2] != 1:
        raise TrebuchetInputError(f"key {key}: {K.tolist()} is not a camera matrix "
                                  "[[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (px, fx, fy > 0)")
    return K


def _checked_distortion(d: np.ndarray, key: str) -> np.ndarray:
    """OpenCV's distortion coefficients: 4, 5 or 8 of them (or none); more are refused."""
    if d.size not in (0, 4, 5, 8) and not (d.size > 8 and not np.any(d[8:])):
        raise TrebuchetInputError(
            f"key {key}: {d.size} coefficients; read are (k1, k2, p1, p2[, k3[, k4, k5, "
            "k6]]): thin-prism and tilted-sensor terms are not modelled")
    return d[:8] if d.size else np.zeros(5)


def _image_size(data: Mapping) -> tuple[int, int] | None:
    """``image_width``, ``image_height`` (px) when given."""
    w, h = data.get("image_width"), data.get("image_height")
    if w is None or h is None:
        return None
    return int(_number(w, "image_width")), int(_number(h, "image_height"))


def _point_list(points: object) -> tuple[np.ndarray, np.ndarray]:
    """Known points of a TOML/JSON list: each a map with ``u``, ``v`` (px) and ``x``, ``y``
    (m)."""
    if not isinstance(points, list) or not all(isinstance(p, Mapping) for p in points):
        raise TrebuchetInputError("key point: expected a list of points, each with u, v "
                                  "(px, v down) and x, y (m, y up)")
    plane, image = [], []
    for i, p in enumerate(points, 1):
        missing = [k for k in ("u", "v", "x", "y") if k not in p]
        if missing:
            raise TrebuchetInputError(f"key point #{i}: no {', '.join(missing)} (each point "
                                      "needs u, v in px, v down, and x, y in m, y up)")
        image.append([_number(p["u"], f"point #{i}.u"), _number(p["v"], f"point #{i}.v")])
        plane.append([_number(p["x"], f"point #{i}.x"), _number(p["y"], f"point #{i}.y")])
    return _enough(np.array(plane), np.array(image))


def _enough(plane: np.ndarray, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Four or more points, else an error."""
    if len(plane) < 4:
        raise TrebuchetInputError(f"{len(plane)} known points; a homography needs four or "
                                  "more (no three on one line)")
    return plane, image


def _points_csv(text: str, source: str) -> UserCalibration:
    """A CSV of known points: columns ``u``, ``v`` (px) and ``x``, ``y`` (m, or the unit
    in the header: cm, mm); other columns (a name) ignored; ``,`` or ``;`` or tab."""
    try:
        dialect = csv.Sniffer().sniff(text.splitlines()[0], delimiters=",;\t")
        rows = list(csv.reader(io.StringIO(text), dialect))
    except csv.Error as exc:
        raise TrebuchetInputError(f"not a table of known points ({exc})") from None
    numbered = [(i, r) for i, r in enumerate(rows, 1) if any(c.strip() for c in r)]
    header_line, header = numbered[0]
    index, scale = {}, {}
    for j, cell in enumerate(header):
        m = re.fullmatch(r"\s*([uvxy])\s*(?:[(\[]\s*([^)\]]*?)\s*[)\]])?\s*", cell, re.I)
        if not m:
            continue
        name, unit = m.group(1).lower(), (m.group(2) or "").lower()
        if name in "uv" and unit not in ("", "px", "pixel", "pixels"):
            raise TrebuchetInputError.at(f"line {header_line}, column '{cell.strip()}'",
                                         f"unit {unit!r}: image positions are in px")
        if name in "xy" and unit not in ("", *PLANE_UNITS):
            raise TrebuchetInputError.at(f"line {header_line}, column '{cell.strip()}'",
                                         f"unit {unit!r}: plane positions are in m, cm or mm")
        index[name], scale[name] = j, PLANE_UNITS.get(unit, 1.0) if name in "xy" else 1.0
    missing = [k for k in "uvxy" if k not in index]
    if missing:
        raise TrebuchetInputError.at(f"line {header_line}", "known points need the columns "
                                     f"u, v (px) and x, y (m); no {', '.join(missing)}")
    plane, image = [], []
    for line, row in numbered[1:]:
        vals = []
        for k in "uvxy":
            cell = row[index[k]].strip() if index[k] < len(row) else ""
            text_cell = cell.replace(",", ".") if dialect.delimiter != "," else cell
            try:
                v = _number(text_cell, k)
            except TrebuchetInputError as exc:
                raise TrebuchetInputError.at(f"line {line}, column {k}",
                                             exc.message.split(": ", 1)[-1]) from None
            vals.append(v * scale[k])
        image.append(vals[:2])
        plane.append(vals[2:])
    plane_a, image_a = _enough(np.array(plane).reshape(-1, 2), np.array(image).reshape(-1, 2))
    return _with_points(source, "CSV", plane_a, image_a, None)
