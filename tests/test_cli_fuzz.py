"""Property test of the command line: a wrong option value is refused early, as one line naming the option.

The options are discovered from the argparse parsers of :func:`gearrom.cli.build_parser`, so a new
option is fuzzed without touching this file. For each option of the cheap-to-reach subcommands the
test feeds wrong values (negative, zero, NaN, inf, huge, text where a number belongs, bad paths and
extensions, unknown choices) and requires exit code 2 with one ``error:`` line that names the option
and no traceback. The expensive step of every subcommand is replaced by a sentinel: reaching it means
the value was accepted, which is allowed only where the value is valid (:func:`_valid`). So the
whole run stays fast, and a value that slips through validation shows up as a failure.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import gearrom
from gearrom.cli import build_parser, main

EXAMPLE = Path(gearrom.__file__).parent / "data" / "examples" / "measurements" / "sim_1250rpm_edges.json"

#: Subcommands fuzzed, with the positional arguments of a valid call.
BASE = {
    "te": [str(EXAMPLE)],
    "campbell": ["thesis-rig"],
    "diagnose": ["thesis-helical", str(EXAMPLE)],
    "validate": ["thesis-spur"],
    "stiffness": ["thesis-spur"],
    "geometry": ["thesis-spur"],
    "sweep": ["thesis-rig", "--out", "{tmp}/sweep_out"],
}

#: The expensive step of each subcommand: replaced by the sentinel while fuzzing.
EXPENSIVE = [("gearrom.signal", "load_angles"), ("gearrom.rom.rig", "build_rig"),
             ("gearrom.calibrate.simulator", "default_simulator"), ("gearrom.validation.report", "validate"),
             ("gearrom.fe.sweep", "build_ltca"), ("gearrom.rom.sweep", "run_sweep")]

PLOT_OPTIONS = {"--plot", "--pattern"}  # figures: the extension selects the format and must be supported
#: Options where a negative or zero number is valid (with the reason).
ALLOW_NEGATIVE = {("diagnose", "--torque-out-Nm")}  # a load torque may have either sign, as in torque_out_Nm
ALLOW_ZERO = {("diagnose", "--torque-out-Nm"), ("diagnose", "--max-effects"),  # 0: measure only, no fit
              ("validate", "--damping-ratio"),  # an undamped mesh (the fully integrated FE records)
              ("campbell", "--min-share"),  # list every crossing
              ("te", "--t-start"), ("diagnose", "--t-start"),  # the record's start
              *((c, o) for c in ("te", "diagnose") for o in ("--max-fill-edges", "--max-repairs"))}  # no repair
#: Options not fuzzed, and why (every option with a value is cheap to check early at present).
EXCLUDED: set[tuple[str, str]] = set()

#: Findings not fixed yet: strict xfails with the reason.
XFAIL: dict[tuple[str, str], str] = {}


class Reached(Exception):
    """The expensive step was reached: the value was accepted."""


def _reach(*args, **kwargs):
    raise Reached


def _kind(action: argparse.Action) -> str:
    if action.choices is not None:
        return "choice"
    if action.type in (float,):
        return "float"
    if action.type in (int,):
        return "int"
    if (action.metavar or "") == "DIR" or action.dest.endswith("_dir") or action.dest == "out":
        return "dir"
    if action.type is Path or action.dest in ("json", "json_out", "plot", "save", "report") or \
            (action.metavar or "") in ("OUT", "PNG", "NPZ", "DIR", "NC", "VTU", "INP"):
        return "path"
    return "text"


def _options():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for cmd in BASE:
        for action in sub.choices[cmd]._actions:
            if not action.option_strings or action.nargs == 0 or isinstance(action, argparse._HelpAction):
                continue
            opt = max(action.option_strings, key=len)
            if (cmd, opt) in EXCLUDED:
                continue
            yield cmd, opt, _kind(action)


OPTIONS = list(_options())

NUMBERS = ["nan", "inf", "-inf", "-1", "-1e-3", "0", "1e300", "1e13", "abc", "", "1,5"]
INTEGERS = ["-1", "0", "1000000000000", "abc", "1.5", "nan", ""]
TEXT = ["", "nan", "-1", "1:1e12:1", "abc:def", "x\x00y", "/nonexistent/x.toml", "5:1:1", "0"]
PATHS = ["", "x\x00y", "{file}/sub/out.png", "{dir}", "out.xyz", "{file}/out.json"]
DIRS = ["", "x\x00y", "{file}", "{file}/sub", "{dir}"]


BASE_VALUES = {"float": NUMBERS, "int": INTEGERS, "text": TEXT, "path": PATHS, "dir": DIRS, "choice": ["bogus", ""]}


def _values(kind: str):
    """Generated wrong values beyond the fixed lists (which are all tried)."""
    extra = st.sampled_from(BASE_VALUES[kind])
    if kind == "float":
        extra = st.one_of(st.floats(max_value=-1e-6).map(repr), st.floats(min_value=1e13).map(repr),
                          st.text("abcxyz%-", min_size=1, max_size=4))
    elif kind == "int":
        extra = st.one_of(st.integers(max_value=-1).map(str), st.integers(min_value=10**9).map(str))
    return extra


def _valid(cmd: str, opt: str, kind: str, value: str) -> bool:
    """Whether ``value`` is a valid value of the option (accepting it is then no finding)."""
    if kind == "path":
        return value == "out.xyz" and opt not in PLOT_OPTIONS
    if kind == "dir":
        return value.endswith("/dir")  # the existing directory
    if kind in ("float", "int"):
        try:
            v = float(value)
        except ValueError:
            return False
        if not math.isfinite(v) or abs(v) > 1e12 or (kind == "int" and v != int(v)):
            return False
        return v > 0 or (v == 0 and (cmd, opt) in ALLOW_ZERO) or (v < 0 and (cmd, opt) in ALLOW_NEGATIVE)
    return False  # the text and choice values above are all invalid


def _run(argv: list[str]) -> tuple[int | None, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            rc = main(argv)
        except SystemExit as exc:
            rc = exc.code
        except Reached:
            rc = None
    return rc, err.getvalue()


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzz")
    (root / "file").write_text("x")
    (root / "dir").mkdir()
    with pytest.MonkeyPatch.context() as mp:
        import importlib

        for mod, name in EXPENSIVE:
            mp.setattr(importlib.import_module(mod), name, _reach)
        mp.chdir(root)
        yield root


@pytest.mark.parametrize("cmd, opt, kind", [
    pytest.param(*o, marks=pytest.mark.xfail(strict=True, reason=XFAIL[o[:2]])) if o[:2] in XFAIL else o
    for o in OPTIONS], ids=[f"{c}{o}" for c, o, _ in OPTIONS])
def test_bad_option_value_is_refused_early(sandbox, cmd, opt, kind):
    def check(value):
        value = value.replace("{file}", str(sandbox / "file")).replace("{dir}", str(sandbox / "dir"))
        base = [a.replace("{tmp}", str(sandbox)) for a in BASE[cmd]]
        argv = [cmd, *base, f"{opt}={value}" if value.startswith("-") or not value else opt, value]
        if argv[-2] != opt:
            argv = argv[:-1]
        rc, err = _run(argv)
        assert "Traceback" not in err, (argv, err)
        if rc is None or rc == 0:
            assert _valid(cmd, opt, kind, value), f"{argv}: bad value accepted (reached the computation)"
            return
        assert rc == 2, (argv, rc, err)
        lines = [ln for ln in err.strip().splitlines() if "error:" in ln]
        assert len(lines) == 1 and opt in lines[0], (argv, err)

    for value in BASE_VALUES[kind]:  # every fixed wrong value, then generated ones
        check(value)
    settings(max_examples=6, deadline=None, derandomize=True, database=None,
             suppress_health_check=[HealthCheck.function_scoped_fixture])(given(value=_values(kind))(check))()


def test_every_subcommand_is_fuzzed():
    """The options come from the parsers: each fuzzed subcommand contributes options (or has none)."""
    cmds = {c for c, _, _ in OPTIONS}
    assert {"te", "campbell", "diagnose", "validate", "stiffness", "sweep"} <= cmds
