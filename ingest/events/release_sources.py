"""Which release to take where the sling's track ends: its end, the stone's flight, or the
engine's equations, weighed by their sd.

A sling track that ends says little by itself: a tracker may follow the flying stone for
several frames before it loses it (on the video bench 1–11 frames at 120–240 fps, so
the track's end came 1.4–11 frames after the release, with a stated sd of 0.29 frame),
or lose it in the sling long before the release (motion blur). Two sources see the
release itself:

- the stone's positions (:mod:`.stone_flight`): on its sling's circle before, in free
  flight after; it needs a frame or more of flight;
- the engine's equations (:mod:`.release_model`): θ̈ and ψ̈ follow phase II before and
  phase III after; it needs θ and ψ and the right scene.

Both sds get a floor of ``floor_frames`` frames: on the video bench (28 logs, both
engines, tilts to 15°, 120 and 240 fps) the equations' release missed by up to 0.75 frame
(RMS 0.38 over the 20 logs where they found one; one more 22 frames early, which the
stone's flight overruled) where their profile's sd said 0.03–0.09 frame (the tracked
angles' errors are not white noise), and the stone's by up to 0.71 frame (RMS 0.32, see
:mod:`.stone_flight`). Where both are found and agree within ``agreement_sd`` of the sd
of their difference, the estimate is their inverse-variance mean; where they disagree the
stone's flight, seen directly, is taken and a warning names both. Without a flight
seen, the equations decide between a lost track (their release well after the track's
end: :data:`LOST_TRACK_SD`), a track that ended at the release (they agree) and a track
that went on past it (their release well before its end).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.events.release_model import ModelRelease
from trebuchet.ingest.events.stone_flight import StoneRelease

__all__ = ["ReleaseChoice", "TrackEndRelease", "release_at_track_end", "LOST_TRACK_SD",
           "KINDS"]

#: A sling track that ends is a lost track, not the release, where the engine's equations
#: put the release this many of their sd after the first frame the track misses (at 1 sd,
#: 3 of 4 simulated logs at 60–120 fps and 1–2° whose track ends at the release were
#: taken for lost ones: the sd is the model's, the track end's own is a frame).
LOST_TRACK_SD = 3.0

#: What a :class:`ReleaseChoice` says about the track's end: "track end" (it is the
#: release), "lost" (the track was lost before the release), "before end" (the release
#: lies before the track's end: the stone was tracked in flight).
KINDS = ("track end", "lost", "before end")


@dataclass(frozen=True)
class TrackEndRelease:
    """Settings of :func:`release_at_track_end`: ``floor_frames``, the floor of each
    source's sd (frames); ``agreement_sd``: two sources agree within this many sd of
    their difference; ``max_misfit``: the equations' release counts only where the scene
    fits the angles this well (:attr:`.release_model.ModelRelease.misfit`)."""

    floor_frames: float = 0.5
    agreement_sd: float = 2.0
    max_misfit: float = 3.0


@dataclass(frozen=True)
class ReleaseChoice:
    """The release taken: ``time`` (s, log time) and ``sd`` (s), ``kind`` (:data:`KINDS`),
    ``source`` (a phrase for ``attrs["event_sources"]``), ``note`` (a sentence for
    ``attrs["notes"]``, or None) and ``warning`` (a sentence to warn, or None: the sources
    disagree beyond their sd, or nothing confirms the track's end)."""

    time: float
    sd: float
    kind: str
    source: str
    note: str | None = None
    warning: str | None = None


def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.1f} ms"


def release_at_track_end(track_end: tuple[float, float], last_frame: float, next_frame: float,
                         frame: float, stone: StoneRelease | None, model: ModelRelease | None,
                         settings: TrackEndRelease = TrackEndRelease()) -> ReleaseChoice:
    """The release where the sling's track ends at ``last_frame`` (s; ``next_frame`` the
    first frame without it) and θ, ψ go on; see the module doc.

    ``track_end``: (time, sd) s the track's end gives (between its last frame and the
    next); ``frame``: the frame interval (s); ``stone``: the stone's flight fit (None: no
    stone positions); ``model``: the engine's equations' release (None: not sought).
    """
    floor = settings.floor_frames * frame
    end_time, end_sd = track_end
    have_model = (model is not None and model.time is not None
                  and model.misfit <= settings.max_misfit)
    m_time = model.time if have_model else float("nan")
    m_sd = float(np.hypot(model.sd, floor)) if have_model else float("nan")
    seen = stone is not None and stone.time is not None
    if seen:
        s_time, s_sd = float(stone.time), float(np.hypot(stone.sd, floor))
        kind = "before end" if s_time < last_frame else "track end"
        if not have_model:
            return ReleaseChoice(s_time, s_sd, kind, stone.how,
                                 f"release at {s_time:.4f} s (sd {_ms(s_sd)}): "
                                 f"{stone.how}; the engine's equations did not place it")
        gap = s_time - m_time
        both = float(np.hypot(s_sd, m_sd))
        if abs(gap) <= settings.agreement_sd * both:
            w_s, w_m = 1.0 / s_sd**2, 1.0 / m_sd**2
            when = (w_s * s_time + w_m * m_time) / (w_s + w_m)
            sd = float(1.0 / np.sqrt(w_s + w_m))
            kind = "before end" if when < last_frame else "track end"
            return ReleaseChoice(
                when, sd, kind, "the tracked stone's flight and the engine's equations",
                f"release at {when:.4f} s (sd {_ms(sd)}): the tracked stone leaves its "
                f"sling's circle at {s_time:.4f} s (sd {_ms(s_sd)}) and the engine's "
                f"equations put it at {m_time:.4f} s (sd {_ms(m_sd)}); the sling's track "
                f"ends at {last_frame:.4f} s")
        return ReleaseChoice(
            s_time, s_sd, kind, stone.how, None,
            f"the release sources disagree: the tracked stone leaves its sling's circle at "
            f"{s_time:.4f} s (sd {_ms(s_sd)}), the engine's equations put the release at "
            f"{m_time:.4f} s (sd {_ms(m_sd)}), {abs(gap) / both:.1f} sd apart; the stone's "
            "flight is taken (is the scene the engine filmed?)")
    if not have_model:
        why = ("the stone stays on its sling's circle to its track's end" if stone is not None
               else "no stone positions to fit")
        return ReleaseChoice(end_time, end_sd, "track end", "end of the sling track", None,
                             f"the release is taken at the end of the sling's track "
                             f"({end_time:.4f} s), confirmed by neither the engine's "
                             f"equations ({'misfit' if model is not None else 'not sought'}) "
                             f"nor the stone's flight ({why}): if the tracker lost the stone "
                             "or followed it in flight, the release is off by that much")
    if m_time - LOST_TRACK_SD * m_sd > next_frame:
        return ReleaseChoice(m_time, m_sd, "lost",
                             f"the engine's equations (the sling's track was lost at "
                             f"{last_frame:.4f} s)")
    both = float(np.hypot(end_sd, m_sd))
    if m_time >= end_time - settings.agreement_sd * both:
        return ReleaseChoice(end_time, end_sd, "track end", "end of the sling track",
                             f"the end of the sling's track at {end_time:.4f} s is the "
                             f"release: the engine's equations put it at {m_time:.4f} s "
                             f"(sd {_ms(m_sd)})")
    return ReleaseChoice(
        m_time, m_sd, "before end", "the engine's equations (the sling's track goes on "
        "past the release)", None,
        f"the sling's track ends at {last_frame:.4f} s, {(last_frame - m_time) / frame:.1f} "
        f"frames after the release the engine's equations find at {m_time:.4f} s (sd "
        f"{_ms(m_sd)}), and the stone was not seen to leave its circle: the tracker followed "
        "the stone in flight? The equations' release is taken")
