"""The fuzz corpus of the FMU abuse host (``fmu/host/fmu_abuse.c``): hostile call sequences.

:func:`corpus` writes, from a seed, the cases the host runs (its file format is described at
the top of the C file): corrupted, truncated and random serialised states (with and without
a recomputed checksum, so that the checks behind the checksum are reached), states of another
instance or type, NULL pointers in every pointer argument of every function, NaN, infinite,
huge, tiny and negative numbers for times, step sizes, states and every parameter, calls in
the wrong order and after an error, and bad ``fmuType`` / instance types and tokens; FMI 2.0
and 3.0, co-simulation and model exchange. The same seed gives the same corpus.

Run ``python -m trebuchet.fmu.abuse_corpus -o corpus.txt --seed 1 --random 400`` to write
one; :mod:`trebuchet.fmu.abuse` runs it.
"""

from __future__ import annotations

import argparse
import random
import sys
from dataclasses import dataclass
from pathlib import Path

from trebuchet.fmu.interface import PARAMETERS, VARIABLES

__all__ = ["Case", "corpus", "write_corpus", "FAMILIES"]

VR = {v.name: i for i, v in enumerate(VARIABLES)}
REALS = [i for i, v in enumerate(VARIABLES) if v.type == "Real"]
FIRST_OUTPUT = VR["theta"]
N_OUTPUTS = sum(1 for v in VARIABLES if v.causality == "output" and v.type == "Real")
PHASE, COMMAND = VR["phase"], VR["release_command"]
#: Directional derivative of every Real output by theta (a continuous state).
DIR = f"dir {VR['theta']} {FIRST_OUTPUT} {N_OUTPUTS}"


def _set(name: str, value: object) -> str:
    """The host's line that sets the variable ``name``."""
    kind = VARIABLES[VR[name]].type
    op = "setr" if kind == "Real" else "setb" if kind == "Boolean" else "seti"
    return f"{op} {VR[name]} {value}"


DRAG = (_set("flight.model", 2), _set("flight.diameter", 0.3))
SLING = (_set("start.projectile", 2), _set("engine.H", 12), _set("start.phi_deg", -90))
DRY = (_set("start.projectile", 3), _set("release.time", 0))
ANGLE = (_set("release.velocity_angle_deg", 45), _set("release.time", 0))

#: Numbers no caller should pass, and a few that are merely large or small.
NASTY = ("nan", "-nan", "inf", "-inf", "1e308", "-1e308", "1e300", "1e9", "1e4", "-1", "-1e-3",
         "0", "-0", "5e-324", "-5e-324", "1e-300", "2.2250738585072014e-308")
TIMES = ("nan", "inf", "-inf", "-1", "-1e-9", "0", "1e-300", "0.5", "59.99", "60", "60.001",
         "1e4", "1e9", "1e300", "1e308")
STEPS = ("nan", "inf", "-inf", "-1e-3", "0", "5e-324", "1e-300", "1e-3", "0.5", "60", "1e4",
         "1e9", "1e300", "1e308")
INTEGERS = ("0", "-1", "4", "77", "2147483647", "-2147483648", "1099511627776",
            "-9223372036854775808")
I32 = ("-1", "0", "1", "2", "3", "4", "5", "6", "7", "8", "100", "65536", "2147483647",
       "-2147483648")
U64 = ("0", "1", "4096", "18446744073709551615", "9223372036854775808", "4294967296")
NULL_FUNCTIONS = {  # name -> number of pointer arguments (FMI 2, FMI 3)
    "getr": (2, 2), "geti": (2, 2), "getb": (2, 2), "gets": (2, 0), "getbin": (0, 3),
    "setr": (2, 2), "seti": (2, 2), "setb": (2, 2), "sets": (2, 0), "gst": (1, 1),
    "fst": (1, 1), "sst": (1, 1), "sersize": (2, 2), "ser": (2, 2), "des": (2, 2),
    "dir": (4, 4), "inder": (3, 0), "outder": (3, 3), "status": (1, 0), "rstatus": (1, 0),
    "istatus": (1, 0), "bstatus": (1, 0), "sstatus": (1, 0), "disc": (1, 6), "done": (2, 2),
    "setx": (1, 1), "getx": (1, 1), "der": (1, 1), "ind": (1, 1), "nominal": (1, 1),
    "nind": (0, 1), "nx": (0, 1), "debug": (1, 1), "step": (0, 4),
}
LIFE = ("setup", "init", "exit", "step", "term", "reset", "time", "event", "disc", "cont",
        "done", "cancel", "stepmode", "free")


@dataclass(frozen=True)
class Case:
    """One case: its name (family and number) and its lines."""

    name: str
    lines: tuple[str, ...]


def _start(fmi: int, kind: str, *, setup: str = "0", params: tuple[str, ...] = ()) -> list[str]:
    """Instantiate, set parameters, initialise."""
    return [f"fmi {fmi}", f"inst {kind}", *params, f"setup {setup}", "init", "exit"]


def _running(rng: random.Random, fmi: int, kind: str) -> list[str]:
    """An instance a little way into the shot (co-simulation steps or model exchange)."""
    lines = _start(fmi, kind, params=rng.choice(((), DRAG, SLING, DRY, ANGLE)))
    if kind == "cs":
        lines.append(f"run {rng.choice((1, 5, 50, 400, 900))} 1e-3")
    else:
        lines += ["event", "disc", f"merun {rng.choice((1, 20, 200))} 1e-3"]
    return lines


def _mutation(rng: random.Random, buf: int = 0) -> list[str]:
    """One to four corruptions of buffer ``buf``; often the checksum is made right again."""
    out = []
    for _ in range(rng.randint(1, 4)):
        frac = f"{rng.random():.6f}"
        kind = rng.choice(("flip", "set", "rand", "trunc", "grow", "f64", "i32", "u64", "fill"))
        if kind == "flip":
            out.append(f"mut {buf} flip {frac} {rng.randrange(8)}")
        elif kind == "set":
            out.append(f"mut {buf} set {frac} {rng.randrange(256)}")
        elif kind == "rand":
            out.append(f"mut {buf} rand {frac} {rng.choice((1, 8, 64, 4096))} "
                       f"{rng.randrange(1, 2**31)}")
        elif kind == "trunc":
            out.append(f"mut {buf} trunc {frac}")
        elif kind == "grow":
            out.append(f"mut {buf} grow {rng.choice((1, 7, 400, 4096))}")
        elif kind == "f64":
            out.append(f"mut {buf} f64 {frac} {rng.choice(NASTY)}")
        elif kind == "i32":
            out.append(f"mut {buf} i32 {frac} {rng.choice(I32)}")
        elif kind == "u64":
            out.append(f"mut {buf} u64 {frac} {rng.choice(U64)}")
        else:
            out.append(f"mut {buf} fill {rng.randrange(256)}")
    fix = rng.random()
    if fix < 0.6:
        out.append(f"mut {buf} {'fixsize' if fix < 0.4 else 'fix'}")
    return out


def _after_restore(rng: random.Random, kind: str) -> list[str]:
    if kind == "cs":
        return ["getr", f"geti {PHASE}",
                f"run {rng.choice((1, 20, 300))} {rng.choice(('1e-3', '0.1'))}", "status",
                f"setb {COMMAND} 1", "run 5 1e-3", "gst 1", "ser 1 1", "des 1 2", "sst 2",
                "getr"]
    return ["getr", "getx", "der", "ind", "event", "disc", "merun 20 1e-3", DIR]


def states(rng: random.Random, n: int) -> list[Case]:
    """Serialised states corrupted, truncated, grown, random; of another type or instance."""
    cases = []
    for k in range(n):
        fmi, kind = rng.choice((2, 3)), rng.choice(("cs", "me"))
        lines = [*_running(rng, fmi, kind), "gst 0", "ser 0 0"]
        target = rng.random()
        if target < 0.15:  # into another instance, maybe of the other type
            other = rng.choice(("cs", "me"))
            lines += ["use 1", f"inst {other}", "setup 0", "init", "exit"]
            kind = other
        lines += _mutation(rng)
        lines += ["des 0 3", "sst 3", *_after_restore(rng, kind)]
        cases.append(Case(f"state-{k}", tuple(lines)))
    return cases


#: Bytes of a serialised state's structured part (head, model, shot) that "fields" covers:
#: every 4-byte word set to each of FIELD_INTS (and every 8-byte one to each of
#: FIELD_DOUBLES) with the checksum made right, so that the checks behind it are reached.
FIELD_BYTES = 3072
FIELD_INTS = ("-1", "7", "65536", "2147483647")
FIELD_DOUBLES = ("nan", "-1e300")


def fields(rng: random.Random, per_case: int = 24, stride: int = 1) -> list[Case]:
    """Every word of the structured part of a state, one at a time, set to extreme values
    behind a right checksum; after each, the state is restored and the run goes on."""
    cases = []
    for fmi in (2, 3):
        for kind in ("cs", "me"):
            step = "run 3 1e-3" if kind == "cs" else "merun 3 1e-3"
            words = list(range(0, FIELD_BYTES, 4 * stride))
            for k in range(0, len(words), per_case):
                lines = [*_running(rng, fmi, kind), "gst 0", "ser 0 0"]
                for at in words[k:k + per_case]:
                    values = [f"i32 @{at} {v}" for v in FIELD_INTS]
                    values += [f"f64 @{at} {v}" for v in FIELD_DOUBLES if at % 8 == 0]
                    for value in values:
                        lines += ["mut 1 copy 0", f"mut 1 {value}", "mut 1 fix", "des 1 2",
                                  "sst 2", step, "getr", "fst 2", "sst 0"]
                cases.append(Case(f"fields-{fmi}{kind}-{words[k]}", tuple(lines)))
    return cases


def state_misuse(rng: random.Random) -> list[Case]:
    """States that are no states, states of another instance, freed states."""
    cases = []
    for fmi in (2, 3):
        for kind in ("cs", "me"):
            base = _running(rng, fmi, kind)
            variants = {
                "wild": ["sstwild", "getr"], "self": ["sstself", "getr"],
                "other-instance": ["gst 0", "use 1", f"inst {kind}", "setup 0", "init", "exit",
                                   "sst 0", "getr", "use 0", "fst 0"],
                "freed": ["gst 0", "fst 0", "sst 0", "getr"],
                "twice": ["gst 0", "gst 0", "ser 0 0", "des 0 0", "des 0 0", "sst 0", "getr"],
                "empty": ["gst 0", "ser 0 0", "mut 0 trunc 0", "des 0 1", "sst 1", "getr"],
                "before-init": [f"fmi {fmi}", f"inst {kind}", "gst 0", "ser 0 0", "des 0 1",
                                "sst 1", "setup 0", "init", "exit", "run 3 1e-3"],
                "error-state": ["step cur nan", "gst 0", "ser 0 0", "reset", "des 0 1", "sst 1",
                                "getr", "step cur 1e-3"],
            }
            for name, tail in variants.items():
                lines = tail if name == "before-init" else [*base, *tail]
                cases.append(Case(f"misuse-{fmi}{kind}-{name}", tuple(lines)))
    return cases


def nulls() -> list[Case]:
    """Every pointer argument of every function NULL (one at a time and all), and every
    function with a NULL instance, before and after initialisation."""
    cases = []
    for fmi in (2, 3):
        for kind in ("cs", "me"):
            stages = [("instantiated", [f"fmi {fmi}", f"inst {kind}"], "reset"),
                      ("running", [*_start(fmi, kind), "gst 0"], "sst 0")]
            if kind == "me":
                stages.append(("continuous", [*_start(fmi, kind), "event", "disc", "cont",
                                              "gst 0"], "sst 0"))
            for stage, pre, again in stages:  # after each error: reset, or the saved state
                lines = list(pre)
                for fn, counts in NULL_FUNCTIONS.items():
                    n = counts[fmi - 2]
                    masks = sorted({(1 << n) - 1, *(1 << i for i in range(n))}) if n else []
                    for m in masks:
                        lines += [f"null {fn} {m}", again]
                lines.append("getr")
                cases.append(Case(f"null-{fmi}{kind}-{stage}", tuple(lines)))
        lines = [f"fmi {fmi}", *(f"nullc {fn}" for fn in (*NULL_FUNCTIONS, *LIFE))]
        cases.append(Case(f"null-instance-{fmi}", tuple(lines)))
    return cases


def numbers() -> list[Case]:
    """NaN, infinite, huge, tiny and negative times, steps, states and parameters."""
    cases = []
    for fmi in (2, 3):
        for h in STEPS:
            for t in ("cur", "-1", "nan", "1e300"):
                cases.append(Case(f"step-{fmi}-{t}-{h}", (*_start(fmi, "cs"), "run 3 1e-3",
                                                         f"step {t} {h}", "status",
                                                         "step cur 1e-3", "term", "getr")))
        for t0 in TIMES:
            for kind in ("cs", "me"):
                tail = ("run 3 1e-3",) if kind == "cs" else ("event", "disc", "merun 3 1e-3")
                cases.append(Case(f"start-{fmi}{kind}-{t0}", (*_start(fmi, kind, setup=t0),
                                                             "getr", *tail)))
        for t in TIMES:
            for flight in ("1", "2"):
                cases.append(Case(f"time-{fmi}-{t}-{flight}", (
                    f"fmi {fmi}", "inst me", _set("flight.model", flight), DRAG[1], "setup 0",
                    "init", "exit", "event", "disc", "cont", f"time {t}", "getr", "der",
                    "ind", "done", "event", "disc")))
        for i in range(6):
            for x in ("nan", "inf", "-inf", "1e300", "1e154"):
                xs = ["0"] * 6
                xs[i] = x
                cases.append(Case(f"setx-{fmi}-{i}-{x}", (
                    f"fmi {fmi}", "inst me", "setup 0", "init", "exit", "event", "disc", "cont",
                    "getx", f"setx {' '.join(xs)}", "der", "ind", "getr", DIR,
                    "done", "event", "disc")))
        for n in ("0", "5", "7", "1000"):
            cases.append(Case(f"setx-count-{fmi}-{n}", (
                f"fmi {fmi}", "inst me", "setup 0", "init", "exit", "event", "disc", "cont",
                f"setx 0 0 0 0 0 0 {n}", "der")))
        cases += _parameters(fmi)
    return cases


def _parameters(fmi: int) -> list[Case]:
    cases = []
    for p in PARAMETERS:
        vr = VR[p.name]
        values = INTEGERS if p.type == "Enumeration" else NASTY
        op = "seti" if p.type == "Enumeration" else "setr"
        for value in values:
            for kind in ("cs", "me"):
                tail = ("run 20 1e-2", "step cur 1e4") if kind == "cs" else (
                    "event", "disc", "merun 50 1e-3", "time 1e9", "getr")
                cases.append(Case(f"param-{fmi}{kind}-{p.name}-{value}", (
                    f"fmi {fmi}", f"inst {kind}", f"{op} {vr} {value}", "setup 0", "init",
                    "exit", "getr", *tail)))
    for value in ("2", "-1", "255"):
        cases.append(Case(f"param-{fmi}-command-{value}", (
            *_start(fmi, "cs"), "run 400 1e-3", f"setb {COMMAND} {value}",
            "run 5 1e-3")))
    cases.append(Case(f"param-{fmi}-set-output", (
        *_start(fmi, "cs"), f"setr {FIRST_OUTPUT} 1", "run 2 1e-3")))
    cases.append(Case(f"param-{fmi}-after-init", (
        *_start(fmi, "cs"), f"setr {VR['engine.L1']} 7", "run 2 1e-3")))
    return cases


def types() -> list[Case]:
    """Bad fmuType, instance kinds and tokens, missing callbacks."""
    cases = []
    for kind in ("77", "-1", "2", "1000000"):
        cases.append(Case(f"type-2-{kind}", ("fmi 2", f"inst {kind}", "setup 0", "init", "exit",
                                             "run 5 1e-3", "der", "getr")))
    for kind in ("se", "csev"):
        cases.append(Case(f"type-3-{kind}", ("fmi 3", f"inst {kind}", "init", "exit",
                                             "run 5 1e-3")))
    for fmi in (2, 3):
        for extra in ("guid=bad", "guid=null", "guid=empty", "cb=null", "log=null", "name=null"):
            if fmi == 3 and extra == "cb=null":
                continue
            cases.append(Case(f"inst-{fmi}-{extra}", (f"fmi {fmi}", f"inst cs {extra}",
                                                      "setup 0", "init", "exit", "run 5 1e-3",
                                                      "step cur nan", "getr")))
        cases.append(Case(f"inst-{fmi}-me-as-cs", (
            f"fmi {fmi}", "inst me", "setup 0", "init", "exit", "run 3 1e-3", "status")))
        cases.append(Case(f"inst-{fmi}-cs-as-me", (
            f"fmi {fmi}", "inst cs", "setup 0", "init", "exit", "event", "disc", "cont",
            "merun 5 1e-3")))
    return cases


def after_errors() -> list[Case]:
    """Calls after an error, a stop or termination: all must be refused until a reset."""
    cases = []
    for fmi in (2, 3):
        bad_init = (_set("engine.L4", 0),)
        cases.append(Case(f"after-error-{fmi}-init", (
            f"fmi {fmi}", "inst cs", *bad_init, "setup 0", "init", "exit", "run 3 1e-3",
            "exit", "init", "term", "getr", "reset", "setup 0", "init", "exit", "run 3 1e-3")))
        for bad in ("step cur nan", "step cur -1", "step -5 1e-3", "step cur 1e4",
                    "null getr 3", _set("engine.L1", 5), f"getb {VR['engine.L1']}",
                    f"dir {VR['engine.L1']} {FIRST_OUTPUT} 1"):
            cases.append(Case(f"after-error-{fmi}-{bad.replace(' ', '_')}", (
                *_start(fmi, "cs"), "run 3 1e-3", bad, "run 3 1e-3", "gst 0", "ser 0 0",
                "reset", "run 2 1e-3", "setup 0", "init", "exit", "run 2 1e-3")))
        cases.append(Case(f"after-terminate-{fmi}", (
            *_start(fmi, "cs"), "run 3 1e-3", "term", "run 3 1e-3", "exit", "getr")))
        cases.append(Case(f"after-error-{fmi}-me", (
            f"fmi {fmi}", "inst me", "setup 0", "init", "exit", "event", "disc", "cont",
            "setx nan 0 0 0 0 0", "der", "time 0.1", "done", "event", "disc", "cont",
            "merun 3 1e-3")))
    return cases


def runaway() -> list[Case]:
    """Long steps, the horizon, a drag flight asked for far in the future."""
    cases = []
    for fmi in (2, 3):
        for h in ("1e4", "1e9", "1e300", "60", "59.999", "120"):
            for params in ((), DRAG, DRY):
                cases.append(Case(f"runaway-{fmi}-{h}-{len(params)}", (
                    *_start(fmi, "cs", params=params), f"step cur {h}", "status", "getr",
                    "step cur 1e-3", "term")))
        cases.append(Case(f"runaway-{fmi}-many", (*_start(fmi, "cs"), "run 200 0.5", "term")))
        cases.append(Case(f"runaway-{fmi}-me-drag", (
            f"fmi {fmi}", "inst me", *DRAG, *SLING, "setup 0",
            "init", "exit", "event", "disc", "cont", "time 0.5", "event", "disc", "cont",
            "time 1e6", "getr", "done")))
    return cases


def random_orders(rng: random.Random, n: int) -> list[Case]:
    """Random calls in random order with random arguments, two instances."""
    ops = ("setup {t}", "init", "exit", "step cur {h}", "step {t} {h}", "run 3 {h}", "term",
           "reset", "time {t}", "event", "disc", "cont", "done", "der", "ind", "getx",
           "setx {x} {x} {x} {x} {x} {x}", "getr", f"geti {PHASE}", f"getb {COMMAND}",
           f"setb {COMMAND} {{b}}",
           "setr {p} {x}", "seti {e} {i}", "gst {s}", "sst {s}", "fst {s}", "ser {s} {s}",
           "des {s} {s}", "status", DIR, "use {u}", "merun 5 {h}", "sstwild",
           "null {fn} {m}", "free", "geti {v}", "getb {v}", "setr {v} 1", "seti {v} 1")
    reals = [VR[p.name] for p in PARAMETERS if p.type == "Real"]
    enums = [VR[p.name] for p in PARAMETERS if p.type == "Enumeration"]
    cases = []
    for k in range(n):
        fmi = rng.choice((2, 3))
        kinds = [rng.choice(("cs", "me", "cs", "me", "77" if fmi == 2 else "se")) for _ in "ab"]
        lines = [f"fmi {fmi}", f"inst {kinds[0]}", "use 1", f"inst {kinds[1]}", "use 0"]
        for _ in range(rng.randint(5, 40)):
            fill = {"t": rng.choice(TIMES), "h": rng.choice(STEPS[5:] * 3 + STEPS),
                    "x": rng.choice(("0", "0.1", "-1", "3", *NASTY)), "b": rng.choice("0112"),
                    "p": rng.choice(reals), "e": rng.choice(enums),
                    "i": rng.choice(("1", "2", "3", *INTEGERS)), "s": rng.randrange(4),
                    "u": rng.randrange(2), "fn": rng.choice(list(NULL_FUNCTIONS)),
                    "m": rng.randrange(1, 16),
                    "v": rng.choice((len(VARIABLES), len(VARIABLES) + 3, 4294967295,
                                     PHASE, COMMAND, FIRST_OUTPUT))}
            lines.append(rng.choice(ops).format(**fill))
            if rng.random() < 0.1:
                lines += _mutation(rng, rng.randrange(4))
        cases.append(Case(f"order-{k}", tuple(lines)))
    return cases


#: The families of :func:`corpus`, in order.
FAMILIES = ("states", "fields", "state_misuse", "nulls", "numbers", "types", "after_errors",
            "runaway", "random_orders")


def corpus(seed: int = 1, random_cases: int = 400) -> list[Case]:
    """Every family's cases; ``random_cases`` corrupted states and as many random orders."""
    rng = random.Random(seed)
    return [*states(rng, random_cases), *fields(rng), *state_misuse(rng), *nulls(),
            *numbers(), *types(), *after_errors(), *runaway(), *random_orders(rng, random_cases)]


def write_corpus(path: Path, cases: list[Case]) -> Path:
    """Write ``cases`` in the host's format (first the Real value references, and those that
    are NaN by definition in a dry fire: the projectile's position and velocity)."""
    dry = " ".join(str(VR[n]) for n in ("x_m", "y_m", "vx_m", "vy_m"))
    lines = ["reals " + " ".join(map(str, REALS)), f"dry {VR['start.projectile']} 3 {dry}"]
    for case in cases:
        lines += [f"case {case.name}", *case.lines]
    path.write_text("\n".join(lines) + "\n")
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m trebuchet.fmu.abuse_corpus",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--output", type=Path, required=True, help="corpus file to write")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--random", type=int, default=400,
                    help="corrupted states and random call orders, each (default 400)")
    args = ap.parse_args(argv)
    cases = corpus(args.seed, args.random)
    write_corpus(args.output, cases)
    print(f"{len(cases)} cases -> {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
