"""Side-view frames of a simulated shot: marker blobs, the moving engine, occluding frame
members, motion blur from the shutter, lens blur and sensor noise.

Only what a tracker sees is drawn, on a 8-bit grey image: a textured sky and ground, the
beam, counterweight arm, counterweight and sling (dark, moving), a ringed white marker on
each tracked point (the stone is its own marker), and the near frame's members (legs and a
brace) in front of everything, nearer the camera than the engine's plane. Moving parts are
drawn at ``n_sub`` instants inside the exposure and averaged (motion blur); the frame is
then blurred by a Gaussian (the lens, sd in px) and gets Gaussian noise (the sensor, sd in
grey levels) before rounding to 8 bits. Drawing uses OpenCV's anti-aliased primitives at
1/16 px, into the region each frame's moving parts cover. Points and the frame members
go through the full camera model (pose, distortion); the markers, beam and counterweight
are drawn as disks and lines at the scale (px per m) of the pivot, not reshaped by
perspective or distortion (a few per cent across the image).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np

import trebuchet as tb

from .camera import Camera, project, rotation, undistort_pixels

__all__ = ["Look", "Member", "look_for", "frame_members", "stone_post", "background",
           "render_frames", "sub_samples"]

SHIFT = 4  # OpenCV's fractional bits: coordinates in 1/16 px
ONE = 1 << SHIFT


@dataclass(frozen=True)
class Look:
    """How the shot looks: marker radius (m; the ring around it is half as wide again), width
    (m) of the beam, arm and sling as drawn, counterweight half-size (m), grey levels, lens
    blur sd (px), sensor noise sd (grey levels)."""

    marker_radius: float
    beam_width: float
    sling_width: float
    weight_half: float
    marker_grey: float = 235.0
    ring_grey: float = 25.0
    engine_grey: float = 70.0
    member_grey: float = 95.0
    lens_blur_px: float = 0.8
    noise_sd: float = 2.0


@dataclass(frozen=True)
class Member:
    """A straight frame member in front of the engine: ends ``p0``, ``p1`` (world, m, on the
    plane z = ``z``), width (m)."""

    p0: tuple[float, float]
    p1: tuple[float, float]
    width: float
    z: float


def look_for(scene: tb.Scene) -> Look:
    """A look scaled to the engine: markers of radius 1.5 % of L1 + L4 (18 cm on the paper's
    engine, 6 cm on the backyard one)."""
    e = scene.engine
    size = e.L1 + e.L4
    return Look(marker_radius=0.015 * size, beam_width=0.012 * size, sling_width=0.004 * size,
                weight_half=0.04 * size)


def frame_members(scene: tb.Scene) -> tuple[Member, ...]:
    """The near frame's two legs, from the ground (±0.6 H) up to 3 marker radii below the
    pivot, and a brace between them at 0.5 H (the counterweight crosses it on its way down,
    and hangs below it after the shot), all 0.1 (L1 + L4) nearer the camera than the
    engine and 1.8 % of L1 + L4 wide."""
    e, H = scene.engine, scene.start.H
    size = e.L1 + e.L4
    top = H - 3 * 0.015 * size
    width, z = 0.018 * size, 0.1 * size
    foot = 0.6 * H
    brace_y = 0.5 * H
    brace_x = foot * (1.0 - brace_y / H)
    return (Member((-foot, 0.0), (-0.05 * H, top), width, z),
            Member((foot, 0.0), (0.05 * H, top), width, z),
            Member((-brace_x, brace_y), (brace_x, brace_y), width, z))


def stone_post(scene: tb.Scene, fraction: float) -> Member:
    """A post in front of the engine (as the frame's members: 1.8 % of L1 + L4 wide, 0.1 (L1 +
    L4) nearer the camera) standing from the ground to 0.2 (L1 + L4) above the stone where
    the stone is ``fraction`` of the way from the trigger to the release (the stone passes
    behind it in the sling: a tracker that never lets go sticks on it)."""
    e = scene.engine
    size = e.L1 + e.L4
    release = tb.simulate(scene, t_eval=[0.0]).attrs["events"]["release"]
    at = tb.simulate(scene, t_eval=[fraction * release])
    x, y = float(at["x_m"].iloc[0]), float(at["y_m"].iloc[0])
    return Member((x, 0.0), (x, y + 0.2 * size), 0.018 * size, 0.1 * size)


def background(cam: Camera, seed: int) -> np.ndarray:
    """Static background (float32 grey levels): sky where a pixel's ray rises, darker ground
    where it falls (the horizon at the camera's eye level), each with a smooth random
    texture."""
    w, h = cam.size
    rng = np.random.default_rng([seed, 17])
    texture = cv2.GaussianBlur(rng.normal(0.0, 1.0, (h, w)).astype(np.float32), (0, 0), 6.0)
    texture *= 12.0 / max(float(texture.std()), 1e-6)
    uv = np.stack(np.meshgrid(np.arange(w), np.arange(h)), axis=-1).astype(float)
    xy = (undistort_pixels(cam, uv) - np.array(cam.principal)) / cam.focal_px
    rays = np.concatenate([xy, np.ones((h, w, 1))], axis=-1) @ rotation(cam)
    sky = np.where(rays[..., 1] < 0.0, 120.0, 185.0).astype(np.float32)
    return sky + texture


def sub_samples(cam: Camera, points: np.ndarray, shutter: float, fps: float,
                max_step_px: float = 0.5, most: int = 48) -> int:
    """Sub-frame instants per exposure so that no point moves more than ``max_step_px``
    between two of them: from the fastest point's speed in px per frame (``points``: world
    positions of every frame, (n, k, 2)), at least 1, at most ``most``."""
    uv = project(cam, points)
    step = np.nanmax(np.linalg.norm(np.diff(uv, axis=0), axis=-1)) if len(uv) > 1 else 0.0
    blur = float(step) * shutter * fps
    return int(np.clip(np.ceil(blur / max_step_px), 1, most))


def _fixed(uv: np.ndarray) -> np.ndarray:
    """Pixel coordinates as OpenCV's fixed-point integers."""
    return np.round(uv * ONE).astype(np.int32)


def _members_layer(cam: Camera, members: tuple[Member, ...]) -> np.ndarray:
    """Coverage (0–1, float32) of the frame members, drawn as quadrilaterals in 3-D."""
    w, h = cam.size
    mask = np.zeros((h, w), np.uint8)
    for m in members:
        p0, p1 = np.array(m.p0), np.array(m.p1)
        d = (p1 - p0) / np.linalg.norm(p1 - p0)
        n = np.array([-d[1], d[0]]) * m.width / 2.0
        corners = np.array([p0 + n, p1 + n, p1 - n, p0 - n])
        # distortion bends long members: project points along each edge
        edge = np.concatenate([np.linspace(a, b, 16) for a, b in
                               zip(corners, np.roll(corners, -1, axis=0), strict=True)])
        world = np.concatenate([edge, np.full((len(edge), 1), m.z)], axis=1)
        uv = project(cam, world)
        cv2.fillPoly(mask, [_fixed(uv)], 255, cv2.LINE_AA, SHIFT)
    return mask.astype(np.float32) / 255.0


def _draw_engine(engine: np.ndarray, ring: np.ndarray, white: np.ndarray, uv: np.ndarray,
                 px: dict[str, float], slung: bool, offset: np.ndarray) -> None:
    """Draw one instant of the engine (points ``uv``, (5, 2) px, in the order of
    ``truth.POINTS``) into the three masks of a region whose corner is ``offset``."""
    q = _fixed(uv - offset)
    pivot, spigot, hinge, cw, stone = (tuple(int(v) for v in p) for p in q)
    aa = cv2.LINE_AA
    cv2.line(engine, hinge, spigot, 255, max(1, round(px["beam"])), aa, SHIFT)
    cv2.line(engine, hinge, cw, 255, max(1, round(px["beam"] * 0.6)), aa, SHIFT)
    cv2.circle(engine, cw, round(px["weight"] * ONE), 255, -1, aa, SHIFT)
    if slung:
        cv2.line(engine, spigot, stone, 255, max(1, round(px["sling"])), aa, SHIFT)
    for p in (pivot, spigot, hinge, cw, stone):
        cv2.circle(ring, p, round(px["marker"] * 1.5 * ONE), 255, -1, aa, SHIFT)
        cv2.circle(white, p, round(px["marker"] * ONE), 255, -1, aa, SHIFT)


def render_frames(cam: Camera, look: Look, exposed: np.ndarray, slung: np.ndarray,
                  members: tuple[Member, ...], seed: int) -> Iterator[np.ndarray]:
    """Frames (uint8, height × width) of a shot whose points lie at ``exposed`` (world, m,
    (n_frames, n_sub, 5, 2)) during each exposure; ``slung`` (n_frames, n_sub) tells where the
    sling still holds the stone (the sling is drawn)."""
    w, h = cam.size
    noise_seed = int(np.random.default_rng([seed, 29]).integers(1, 2**30))
    noise = np.empty((h, w), np.float32)
    base = background(cam, seed)
    members_alpha = _members_layer(cam, members)
    members_keep = (1.0 - members_alpha).astype(np.float32)
    members_paint = (look.member_grey * members_alpha).astype(np.float32)
    uv_all = project(cam, exposed)
    scale = _px_per_m(cam, exposed)
    px = {"marker": look.marker_radius * scale, "beam": look.beam_width * scale,
          "sling": look.sling_width * scale, "weight": look.weight_half * scale}
    margin = 2.0 * (px["marker"] * 1.5 + px["weight"] + px["beam"]) + 4.0
    n_sub = exposed.shape[1]
    for k in range(exposed.shape[0]):
        uv = uv_all[k]
        lo = np.floor(np.nanmin(uv.reshape(-1, 2), axis=0) - margin).astype(int)
        hi = np.ceil(np.nanmax(uv.reshape(-1, 2), axis=0) + margin).astype(int)
        lo = np.clip(lo, 0, [w, h])
        hi = np.clip(hi, 0, [w, h])
        frame = base.copy()
        if (hi > lo).all():
            shape = (hi[1] - lo[1], hi[0] - lo[0])
            masks = [np.zeros(shape, np.uint8) for _ in range(3)]
            sums = [np.zeros(shape, np.float32) for _ in range(3)]
            for j in range(n_sub):
                for m in masks:
                    m[:] = 0
                _draw_engine(*masks, uv[j], px, bool(slung[k, j]), lo.astype(float))
                for m, s in zip(masks, sums, strict=True):
                    cv2.accumulate(m, s)
            region = frame[lo[1]:hi[1], lo[0]:hi[0]]
            for s, grey in zip(sums, (look.engine_grey, look.ring_grey, look.marker_grey),
                               strict=True):
                alpha = s / (255.0 * n_sub)
                region *= 1.0 - alpha
                region += grey * alpha
        frame *= members_keep
        frame += members_paint
        if look.lens_blur_px > 0:
            frame = cv2.GaussianBlur(frame, (0, 0), look.lens_blur_px)
        cv2.setRNGSeed(noise_seed + k)  # OpenCV's thread-local generator: fast, seeded per frame
        cv2.randn(noise, 0.0, look.noise_sd)
        frame += noise
        yield np.clip(np.rint(frame), 0, 255).astype(np.uint8)


def _px_per_m(cam: Camera, exposed: np.ndarray) -> float:
    """Pixels per metre at the engine's plane near the pivot (the first frame's pivot)."""
    p = exposed[0, 0, 0]
    uv = project(cam, np.array([p, p + [1.0, 0.0]]))
    return float(np.linalg.norm(uv[1] - uv[0]))
