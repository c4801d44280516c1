"""Which release to take: the one place where the release's sources are weighed.

A release is a release only where a source that sees it confirms it:

- the stone's positions (:mod:`.stone_flight`): on its sling's circle before, in free
  flight after; it needs :data:`MIN_FLIGHT_FRAMES` frames of flight, and a stone whose
  track ends where
  the tracker stuck on something (``ReadLog.held``) has no flight: its last frames are the
  template sliding onto the occluder (Kinovea's default tracker, left unedited, re-cuts
  its template on a frame leg and stays there; taken for flight, that gave a release 121
  frames early with a stated sd of 1.3 frames);
- the engine's equations (:mod:`.release_model`): θ̈ and ψ̈ follow phase II before and
  phase III after; it needs θ and ψ and the right scene (``misfit``).

What the track's end or the smoother's jump search give by themselves is no confirmation:
a tracker may follow the flying stone for several frames before it loses it (on the video
bench 1–11 frames at 120–240 fps, so the track's end came 1.4–11 frames after the
release, with a stated sd of 0.29 frame), or lose it in the sling long before the release
(motion blur, a stuck template); a jump search has nothing to mark a release where the
sling's track goes on.

The rules (:func:`release_at_track_end` where the sling's track ends while θ and ψ go on,
:func:`release_without_track_end` where it does not):

- both confirming sources found and within ``agreement_sd`` of the sd of their difference:
  their inverse-variance mean;
- both found and disagreeing: the stone's flight (seen directly), its sd widened to cover
  the equations' release (:func:`covering_sd`), and a warning naming both;
- one found: it (the equations decide between a lost track, :data:`LOST_TRACK_SD`, a track
  that ended at the release, and one that went on past it: their release more than
  ``agreement_sd`` of their own sd before the track's end, whose own sd, a uniform
  frame's, says nothing of a tracker that followed the stone; with that sd in the
  comparison a stress-grid cell kept a track's end 2.9 frames late with an sd of 0.29
  frame);
- none: the track's end (or the jump search's release) stands, its sd widened to cover
  the scene's own release time after the detected trigger (:class:`SceneTiming`: where
  the sources cannot say, the engine filmed can), and a warning that the release is
  uncertain.

Both confirming sources' sds get a floor of ``floor_frames`` frames: on the video bench
(28 logs, both engines, tilts to 15°, 120 and 240 fps) the equations' release missed by
up to 0.75 frame (RMS 0.38) where their profile's sd said 0.03–0.09 frame (the tracked
angles' errors are not white noise), and the stone's by up to 0.71 frame (RMS 0.32).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.events.release_model import ModelRelease
from trebuchet.ingest.events.stone_flight import StoneRelease

__all__ = ["ReleaseChoice", "TrackEndRelease", "TrackEnd", "SceneTiming",
           "release_at_track_end", "release_without_track_end", "covering_sd",
           "LOST_TRACK_SD", "KINDS", "MIN_FLIGHT_FRAMES", "timing_checked",
           "SCENE_TIMING_SHARE", "STONE_ALONE_FLOOR_FRAMES", "LOOSE_MODEL_FRAMES",
           "SCENE_TIMING_FAR", "scene_reach", "scene_covering_sd"]

#: A sling track that ends is a lost track, not the release, where the engine's equations
#: put the release this many of their sd after the first frame the track misses (at 1 sd,
#: 3 of 4 simulated logs at 60–120 fps and 1–2° whose track ends at the release were
#: taken for lost ones: the sd is the model's, the track end's own is a frame).
LOST_TRACK_SD = 3.0

#: A stone's flight confirms a release only with this many frames of flight fitted: one
#: frame off the circle is as likely a wrong match as a flight (on the stress grid a fixed
#: template's single frame "of flight" put the release 29 frames early).
MIN_FLIGHT_FRAMES = 2

#: What a :class:`ReleaseChoice` says: "track end" (the track's end is the release),
#: "lost" (the track was lost before the release), "before end" (the release lies before
#: the track's end: the stone was tracked in flight), "equations" (the engine's equations'
#: release replaces the jump search's), "jump" (the jump search's release stands).
KINDS = ("track end", "lost", "before end", "equations", "jump")


@dataclass(frozen=True)
class TrackEndRelease:
    """Settings of the choice: ``floor_frames``, the floor of each confirming source's sd
    (frames); ``agreement_sd``: two sources agree within this many sd of their difference;
    ``max_misfit``: the equations' release counts only where the scene fits the angles
    this well (:attr:`.release_model.ModelRelease.misfit`)."""

    floor_frames: float = 0.5
    agreement_sd: float = 2.0
    max_misfit: float = 3.0


@dataclass(frozen=True)
class TrackEnd:
    """The sling's track ends while θ and ψ go on: ``time`` and ``sd`` (s) of the release
    the end gives by itself (between its last frame and the next, or where ``read_log`` saw
    the stone leave its circle), ``last_frame`` and ``next_frame`` (s) the track's last
    frame and the first without it, ``frame`` the frame interval (s); ``stone_held``: the
    stone's track ends where the tracker stood still on something (``ReadLog.held``)."""

    time: float
    sd: float
    last_frame: float
    next_frame: float
    frame: float
    stone_held: bool = False


@dataclass(frozen=True)
class SceneTiming:
    """The scene's own release in the log's time: ``time`` (s), the detected trigger plus
    the simulated time from trigger to release, ``span`` (s; None: no trigger detected),
    ``trigger_sd`` (s) the detected trigger's. Where no source confirms a release, the
    distance to it bounds what the log's own release may be off by; a single source
    further from it than :func:`scene_covering_sd` allows disagrees with the engine
    filmed."""

    time: float | None
    span: float = float("nan")
    trigger_sd: float = 0.0


#: The sd of a scene's own event time (the detected trigger plus the simulated span to the
#: event), as a share of that span: an event from one source alone further than 2 sd
#: (of it and the event's own sd together) from the scene's disagrees with the engine
#: (:func:`scene_covering_sd`). A filmed release lies within a few per cent of a right
#: scene's (the shipped samples within 0.2 %). At 10 % of the span (the rule before) the
#: stress grid kept sources 3–9 frames off with sds under a frame, unwarned: the normal
#: force's lift-off 2–9 frames off (a sling 10 % longer moves the scene's lift-off 6 %),
#: the equations' release 6 frames late where the sling's track went on, a track's end
#: 4 frames early that equations with a 9-frame sd "confirmed".
SCENE_TIMING_SHARE = 0.01
#: A source further than this share of the span from the scene's own time disagrees with
#: it whatever the sds say (the rule before :data:`SCENE_TIMING_SHARE`'s: a lift-off whose
#: own sd a tracking gap had widened to 1.7 frames lay 3.8 frames late, just inside 2 sd
#: of its difference from the scene's).
SCENE_TIMING_FAR = 0.1
#: A stone's flight that no other source checks gets this floor of sd (frames; with the
#: equations beside it, ``TrackEndRelease.floor_frames``): an adaptive template's drift
#: put it 2.7 frames late with a stated half frame.
STONE_ALONE_FLOOR_FRAMES = 1.5
#: Equations whose release sd (floored) exceeds this many frames cannot tell a track's end
#: at the release from a tracker that lost or followed the stone for a few frames: their
#: "agreement" confirms nothing, the track's end counts as a source alone
#: (:func:`timing_checked`). On the stress grid equations with an sd of 9 frames
#: confirmed a track's end 3.9 frames before the release (a post hid the stone), its
#: sd 0.29 frame.
LOOSE_MODEL_FRAMES = 2.0


@dataclass(frozen=True)
class ReleaseChoice:
    """The release taken: ``time`` (s, log time) and ``sd`` (s), ``kind`` (:data:`KINDS`),
    ``source`` (a phrase for ``attrs["event_sources"]``), ``note`` (a sentence for
    ``attrs["notes"]``, or None), ``warning`` (a sentence to warn, or None: the sources
    disagree, or nothing confirms the release) and ``confirmed`` (the stone's flight or the
    engine's equations place it)."""

    time: float
    sd: float
    kind: str
    source: str
    note: str | None = None
    warning: str | None = None
    confirmed: bool = True


def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.1f} ms"


def covering_sd(sd: float, gap: float) -> float:
    """The sd (s) of an estimate ``sd`` (s) whose rival lies ``gap`` (s) away: the release
    anywhere between the two (uniform, RMS distance from the estimate ``|gap|/√3``) in
    quadrature with its own sd, so that ±2 sd reach past the rival."""
    return float(math.hypot(sd, abs(gap) / math.sqrt(3.0)))


def scene_reach(span: float, frame: float, trigger_sd: float = 0.0) -> tuple[float, float]:
    """The scene's own event time's sd (s: the detected trigger's ``trigger_sd`` and
    :data:`SCENE_TIMING_SHARE` of the ``span``, s, from trigger to event) and how far (s)
    past it the truth may lie: that sd and a ``frame`` (s; the trigger is found to about a
    frame, a stress-grid trigger 0.85 frame off with an sd of 0.16; a span not known, NaN,
    adds nothing)."""
    sd = math.hypot(trigger_sd, SCENE_TIMING_SHARE * span if math.isfinite(span) else 0.0)
    return sd, math.hypot(sd, frame)


def scene_covering_sd(time: float, sd: float, scene_time: float, span: float, frame: float,
                      trigger_sd: float = 0.0, agreement_sd: float = 2.0) -> float | None:
    """The sd (s) of an event at ``time`` (sd ``sd``, s) that disagrees with the scene's own
    time of it (``scene_time``, s, the detected trigger plus the simulated ``span``, s):
    more than ``agreement_sd`` sd of their difference apart (the scene's sd from
    :func:`scene_reach`) or more than :data:`SCENE_TIMING_FAR` of the span,
    :func:`covering_sd` of the gap reaching past the scene's time by :func:`scene_reach`
    (the rival is itself uncertain); None where they agree."""
    scene_sd, reach = scene_reach(span, frame, trigger_sd)
    own = sd if np.isfinite(sd) else 0.0
    gap = abs(scene_time - time)
    far = math.isfinite(span) and gap > SCENE_TIMING_FAR * span
    if gap <= agreement_sd * math.hypot(own, scene_sd) and not far:
        return None
    return covering_sd(own, gap + reach)


def timing_checked(choice: ReleaseChoice, timing: SceneTiming | None, frame: float
                   ) -> ReleaseChoice:
    """``choice`` (from one source alone) with its sd widened to cover the scene's own
    release and a warning, where the two disagree (:func:`scene_covering_sd`); else as
    it is."""
    if timing is None or timing.time is None or not np.isfinite(timing.span):
        return choice
    gap = timing.time - choice.time
    wide = scene_covering_sd(choice.time, choice.sd, timing.time, timing.span, frame,
                             timing.trigger_sd)
    if wide is None:
        return choice
    said = (f"the release at {choice.time:.4f} s ({choice.source}) lies {abs(gap) / frame:.1f} "
            f"frames from the scene's own release {timing.time:.4f} s and nothing else "
            f"places it: it is taken with sd {_ms(wide)} ({wide / frame:.1f} frames) to cover "
            "both")
    return ReleaseChoice(choice.time, wide, choice.kind, choice.source, choice.note,
                         said if choice.warning is None else f"{choice.warning}; {said}",
                         choice.confirmed)


def _model_usable(model: ModelRelease | None, settings: TrackEndRelease) -> bool:
    return model is not None and model.time is not None and model.misfit <= settings.max_misfit


def _unconfirmed(time: float, sd: float, kind: str, source: str, why: str,
                 timing: SceneTiming | None, frame: float) -> ReleaseChoice:
    """A release no source confirms: ``time`` stands, its sd widened to cover the scene's
    own release time (:class:`SceneTiming`), with a warning saying ``why``."""
    if timing is None or timing.time is None:
        wide, against = covering_sd(sd, 3.0 * frame), "no trigger to time the scene's release"
    else:
        wide = covering_sd(sd, abs(timing.time - time)
                           + scene_reach(timing.span, frame, timing.trigger_sd)[1])
        against = (f"the scene's own release {timing.time:.4f} s lies "
                   f"{abs(timing.time - time) / frame:.1f} frames away")
    return ReleaseChoice(time, wide, kind, source, None,
                         f"the release is uncertain: {why}; it is taken at {time:.4f} s with "
                         f"sd {_ms(wide)} ({wide / frame:.1f} frames: {against})",
                         confirmed=False)


def _stone_and_model(stone: StoneRelease, model: ModelRelease, end: TrackEnd,
                     floor: float, settings: TrackEndRelease,
                     timing: SceneTiming | None) -> ReleaseChoice:
    """Both confirming sources found: their weighted mean where they agree, else the stone's
    flight with an sd that covers the equations' release, checked against the scene's own
    (:func:`timing_checked`: on the stress grid a stuck tracker's "flight" and the
    equations were 23 and 34 frames apart and both 34–57 frames late), and a warning."""
    last_frame = end.last_frame
    s_time, s_sd = float(stone.time), float(np.hypot(stone.sd, floor))
    m_time, m_sd = float(model.time), float(np.hypot(model.sd, floor))
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
    wide = covering_sd(s_sd, gap)
    return timing_checked(ReleaseChoice(
        s_time, wide, "before end" if s_time < last_frame else "track end", stone.how, None,
        f"the release sources disagree: the tracked stone leaves its sling's circle at "
        f"{s_time:.4f} s (sd {_ms(s_sd)}), the engine's equations put the release at "
        f"{m_time:.4f} s (sd {_ms(m_sd)}), {abs(gap) / both:.1f} sd apart; the stone's "
        f"flight is taken with sd {_ms(wide)} to cover both (is the scene the engine "
        "filmed?)"), timing, end.frame)


def release_at_track_end(end: TrackEnd, stone: StoneRelease | None, model: ModelRelease | None,
                         timing: SceneTiming | None = None,
                         settings: TrackEndRelease = TrackEndRelease()) -> ReleaseChoice:
    """The release where the sling's track ends (``end``) and θ, ψ go on; see the module doc.

    ``stone``: the stone's flight fit (None: no stone positions); ``model``: the engine's
    equations' release (None: not sought); ``timing``: the scene's own release (None: not
    known).
    """
    floor = settings.floor_frames * end.frame
    have_model = _model_usable(model, settings)
    seen = (stone is not None and stone.time is not None and not end.stone_held
            and stone.flight_frames >= MIN_FLIGHT_FRAMES)
    if seen and have_model:
        return _stone_and_model(stone, model, end, floor, settings, timing)
    if seen:
        s_time = float(stone.time)
        s_sd = float(np.hypot(stone.sd, STONE_ALONE_FLOOR_FRAMES * end.frame))
        kind = "before end" if s_time < end.last_frame else "track end"
        return timing_checked(ReleaseChoice(
            s_time, s_sd, kind, stone.how, f"release at {s_time:.4f} s (sd {_ms(s_sd)}): "
            f"{stone.how}; the engine's equations did not place it"), timing, end.frame)
    if not have_model:
        why = ("the stone's track ends where the tracker stood still on something, not in "
               "flight" if end.stone_held
               else "no stone positions to fit" if stone is None
               else "the stone stays on its sling's circle to its track's end"
               if stone.time is None
               else f"the stone leaves its sling's circle for only {stone.flight_frames} "
                    f"frame(s) of flight")
        return _unconfirmed(end.time, end.sd, "track end", "end of the sling track",
                            f"the end of the sling's track ({end.time:.4f} s) is confirmed by "
                            f"neither the engine's equations "
                            f"({'misfit' if model is not None else 'not sought'}) nor the "
                            f"stone's flight ({why}): if the tracker lost the stone or "
                            "followed it in flight, the release is off by that much",
                            timing, end.frame)
    m_time, m_sd = float(model.time), float(np.hypot(model.sd, floor))
    held = (" (the stone's track ends where the tracker stood still on something)"
            if end.stone_held else "")
    if m_time - LOST_TRACK_SD * m_sd > end.next_frame or (end.stone_held
                                                          and m_time > end.last_frame):
        return timing_checked(ReleaseChoice(
            m_time, m_sd, "lost", f"the engine's equations (the sling's track was lost at "
            f"{end.last_frame:.4f} s{held})"), timing, end.frame)
    gap = m_time - end.time
    if abs(gap) <= settings.agreement_sd * m_sd and not end.stone_held:
        agreed = ReleaseChoice(end.time, end.sd, "track end", "end of the sling track",
                               f"the end of the sling's track at {end.time:.4f} s is the "
                               f"release: the engine's equations put it at {m_time:.4f} s "
                               f"(sd {_ms(m_sd)})")
        loose = m_sd > LOOSE_MODEL_FRAMES * end.frame
        return timing_checked(agreed, timing, end.frame) if loose else agreed
    if gap > 0:  # later than the track's end, not far enough for a lost track
        wide = covering_sd(m_sd, gap)
        return timing_checked(ReleaseChoice(
            m_time, wide, "lost", "the engine's equations (the sling's track ends "
            f"{gap / end.frame:.1f} frames before)", None,
            f"the sling's track ends at {end.last_frame:.4f} s and the engine's equations put "
            f"the release {gap / end.frame:.1f} frames later, at {m_time:.4f} s (sd "
            f"{_ms(m_sd)}): the track lost shortly before the release, or ended at it? The "
            f"equations' release is taken with sd {_ms(wide)} to cover both"), timing,
            end.frame)
    return timing_checked(ReleaseChoice(
        m_time, m_sd, "before end", "the engine's equations (the sling's track goes on "
        "past the release)", None,
        f"the sling's track ends at {end.last_frame:.4f} s, "
        f"{(end.last_frame - m_time) / end.frame:.1f} frames after the release the engine's "
        f"equations find at {m_time:.4f} s (sd {_ms(m_sd)}), and the stone was not seen to "
        f"leave its circle{held}: the tracker followed the stone in flight? The equations' "
        "release is taken"), timing, end.frame)


def release_without_track_end(model: ModelRelease, jump: float | None, jump_sd: float,
                              frame: float, timing: SceneTiming | None = None,
                              settings: TrackEndRelease = TrackEndRelease()) -> ReleaseChoice:
    """The release where the sling's track goes on past it (an empty sling swinging, a
    tracker following the stone): the smoother's jump search (``jump`` s, log time, None =
    none found; ``jump_sd`` s) checked against the engine's equations (``model``).

    The equations' release replaces the jump's where they differ by more than
    ``agreement_sd`` of the equations' sd (on simulated logs whose sling track goes on the
    jump search lands up to 6 frames off where the equations' sd is 4, and ½ frame off
    across a frame where it is 0.2), or no jump was found (kind "equations"); where they
    agree the jump's time stands with the wider sd (kind "jump"). Where the equations do
    not fit (``misfit``) or find no release, the jump's time is unconfirmed
    (:func:`_unconfirmed`); with no jump either, ``time`` is NaN."""
    if not _model_usable(model, settings):
        why = (f"the scene's equations fit the measured accelerations of θ and ψ neither as "
               f"phase II nor as phase III (median squared residual {model.misfit:.1f} sd² "
               "per angle): is the scene the engine filmed?"
               if model.misfit > settings.max_misfit
               else "the engine's equations found no release")
        if jump is None:
            return ReleaseChoice(float("nan"), float("nan"), "jump", "none found", None,
                                 f"no release found: {why}", confirmed=False)
        return _unconfirmed(jump, jump_sd, "jump", "jump in acceleration",
                            f"{why}; only the jump in the angles' acceleration marks it",
                            timing, frame)
    m_time, m_sd = float(model.time), float(model.sd)
    if jump is None:
        return timing_checked(ReleaseChoice(
            m_time, m_sd, "equations", model.how, f"release at {m_time:.4f} s (sd "
            f"{_ms(m_sd)}) from the engine's equations; no jump in the angles' acceleration "
            "marked it"), timing, frame)
    gap = m_time - jump
    if abs(gap) <= settings.agreement_sd * m_sd:
        return ReleaseChoice(jump, max(jump_sd, m_sd), "jump", "jump in acceleration")
    return timing_checked(ReleaseChoice(
        m_time, m_sd, "equations", model.how, f"release at {m_time:.4f} s (sd {_ms(m_sd)}) "
        f"from the engine's equations, {1e3 * abs(gap):.0f} ms "
        f"{'before' if gap < 0 else 'after'} the jump in acceleration at {jump:.4f} s (the "
        "sling's track goes on past the release?)"), timing, frame)
