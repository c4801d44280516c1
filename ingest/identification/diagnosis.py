"""What a fit cannot say, in words: a failed residual check with the piece the scene likely
misses, and fitted parameters the log cannot separate.

**The missing piece.** Where the check fails and the bearings' friction is not already free,
the log is fitted again with friction at pivot and hinge free (the scene's radii where it gives
them, else a nominal radius of L2/20: the couple is ``μ r |F|``, only the product matters).
Evidence the code can check: if that fit passes, the likely missing piece is friction; if not,
or friction was free already, it is a wrong engine (a length, the start pose, a mass held
fixed). The issue's measurement: a fit without the engine's friction took a 12 % lighter
counterweight at χ² 1.00, its residuals' lag-1 autocorrelation 0.23 and above; with the
friction free the fit was right again.

**Parameters the log cannot separate.** Pairs of freed keys whose correlation exceeds
:data:`NAMED_CORRELATION` are named in a warning with it; above :data:`REFUSED_CORRELATION` the
log fixes only a combination of the two (``m_b`` and ``L_CM`` with ``I`` held: only the beam's
moment ``m_b L_CM`` moves it), and the fit is refused with the option that resolves it.

**The masses' scale.** A fitted mass far from the scene's may be the held mass that is off
(:func:`mass_scale_warnings`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
import pandas as pd

from trebuchet.core.errors import Option, TrebuchetInputError
from trebuchet.ingest.identification.check import ResidualCheck
from trebuchet.ingest.identification.parameters import MASS_KEYS
from trebuchet.model.scene import Friction, Scene

__all__ = ["NAMED_CORRELATION", "REFUSED_CORRELATION", "correlated_pairs",
           "check_separable", "with_free_friction", "missing_piece_warning",
           "mass_scale_warnings", "MASS_RATIO_WARNING"]

#: Correlations beyond this are named in a warning.
NAMED_CORRELATION = 0.95
#: Correlations beyond this refuse the fit (``m_b`` and ``L_CM`` with ``I`` held, whose product
#: alone moves the engine, came out at −0.9997: the Jacobian's differences are not exact).
REFUSED_CORRELATION = 0.999
#: The nominal radius of a friction the scene does not give, a fraction of L2.
NOMINAL_RADIUS = 1.0 / 20.0


def correlated_pairs(names: Sequence[str], corr: np.ndarray, free: Sequence[str],
                     limit: float = NAMED_CORRELATION) -> list[tuple[str, str, float]]:
    """Pairs ``(a, b, ρ)`` of freed keys with ``|ρ| > limit``, strongest first (a key's
    correlation with a nuisance is the fit's business: it widens the key's sd)."""
    out = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if names[i] in free and names[j] in free and abs(corr[i, j]) > limit:
                out.append((names[i], names[j], float(corr[i, j])))
    return sorted(out, key=lambda p: -abs(p[2]))


def check_separable(names: Sequence[str], corr: np.ndarray, free: Sequence[str]) -> list[str]:
    """Refuse (TrebuchetInputError) a fit in which two freed keys are beyond
    :data:`REFUSED_CORRELATION`; warnings (sentences) for the pairs beyond
    :data:`NAMED_CORRELATION`."""
    for a, b, rho in correlated_pairs(names, corr, free, REFUSED_CORRELATION):
        raise TrebuchetInputError(
            f"identify: free keys {a} and {b}: the log cannot separate them (correlation "
            f"{rho:+.4f}: it fixes only a combination of the two); free one (drop "
            f"{Option('free', b)})")
    out = []
    for a, b, rho in correlated_pairs(names, corr, free):
        out.append(f"{a} and {b} correlate at {rho:+.3f}: the log barely separates them, so "
                   "each one's sd is large and their errors go together (hold one at the "
                   f"scene's value to fit the other: drop {Option('free', b)})")
    return out


def with_free_friction(scene: Scene) -> tuple[Scene, tuple[str, ...]]:
    """The scene with friction at pivot and hinge that a fit can free (its own radii where it
    gives them, else :data:`NOMINAL_RADIUS` × L2, coefficients 0.1 where none), and the keys
    to free."""
    fr = scene.friction or Friction()
    r = NOMINAL_RADIUS * scene.engine.L2
    values = {}
    for joint in ("pivot", "hinge"):
        radius = getattr(fr, f"{joint}_radius") or r
        mu = getattr(fr, f"{joint}_mu") or 0.1
        values[f"{joint}_radius"], values[f"{joint}_mu"] = radius, mu
    friction = Friction(**values, smoothing_rate=fr.smoothing_rate)
    return (replace(scene, engine=replace(scene.engine, friction=friction)),
            ("friction.pivot_mu", "friction.hinge_mu"))


def missing_piece_warning(check: ResidualCheck, scene: Scene, free: Sequence[str],
                          refit: Callable[[Scene, tuple[str, ...]], tuple[ResidualCheck, float]]
                          | None) -> str:
    """The warning of a failed check: what failed and the likely missing piece (module doc).
    ``refit(scene, free)`` fits the log again and returns its check and the friction's share
    of ΔU by the release; None: no refit (the friction is free already)."""
    head = (f"the fitted engine does not explain the shot ({check.describe()}): its loads "
            "would be confidently wrong, so they are not used")
    friction_free = all(k in free for k in ("friction.pivot_mu", "friction.hinge_mu"))
    if refit is not None and not friction_free:
        with_friction, keys = with_free_friction(scene)
        extra = tuple(k for k in keys if k not in free)
        try:
            again, share = refit(with_friction, tuple(free) + extra)
        except TrebuchetInputError:
            again, share = None, float("nan")
        if again is not None and again.passed:
            how = ("add a [friction] section with the radii of the beam's shaft and the hinge "
                   "pin (pivot_radius, hinge_radius; their coefficients are then fitted by "
                   "default)" if scene.friction is None or not (
                       scene.friction.pivot_radius and scene.friction.hinge_radius)
                   else "free the coefficients (" + " ".join(
                       str(Option("free", k)) for k in keys) + ")")
            return (f"{head}. The likely missing piece is friction in the bearings: with "
                    f"friction at pivot and hinge free the fit passes its check and friction "
                    f"takes {100 * share:.1f} % of ΔU by the release; {how}")
    return (f"{head}. The likely missing piece is a wrong engine: "
            + ("even with friction at pivot and hinge free " if not friction_free else
               "with the bearings' friction free ")
            + "the equations miss the angles; check the scene's lengths (L1, L2, L_CM, L3, L4), "
            "its start pose and the masses held fixed, or free more keys "
            f"({Option('free', 'engine.L3')}, ...)")


#: A fitted mass (or the beam's inertia) beyond this factor of the scene's warns.
MASS_RATIO_WARNING = 1.3


def mass_scale_warnings(table: pd.DataFrame, scene: Scene) -> list[str]:
    """A warning for each freed mass fitted beyond :data:`MASS_RATIO_WARNING` × the scene's
    (or below its inverse): a shot fixes only the masses' ratios, and their scale is the mass
    the fit holds, so a held mass that is off (a stone weighing twice what the scene says)
    moves every fitted mass and every load by the same factor, and the residual check cannot
    see it."""
    free = table[(table["kind"] == "free") & table["parameter"].isin(MASS_KEYS)]
    held = [k for k in MASS_KEYS if k not in set(free["parameter"])
            and not (k == "engine.m" and scene.engine.m == 0.0)]
    out = []
    for row in free.itertuples(index=False):
        ratio = row.value / row.scene_value
        if 1.0 / MASS_RATIO_WARNING <= ratio <= MASS_RATIO_WARNING:
            continue
        name = row.parameter.partition(".")[2]
        scale = ", ".join(f"{k} = {getattr(scene.engine, k.partition('.')[2]):g}" for k in held)
        out.append(f"{row.parameter} is fitted at {ratio:.2f} × the scene's: a shot fixes only "
                   f"the ratios of the masses, and their scale is the mass the fit holds "
                   f"({scale}); that mass off by {1 / ratio:.2f} × would look the same, and every "
                   f"load scales with it: weigh it, or check the scene's {name}")
    return out
