"""Option checks and output-path helpers shared by the subcommands.

Each subcommand checks its options at the start of ``run``, before any computation, so a wrong
value costs nothing and is reported as one line naming the option (``gearrom CMD: error:
--OPTION=VALUE: why``, exit code 2, through :class:`~gearrom.errors.ConfigError`). Output paths
are checked up front too (name, suffix, a folder that can be created), and :func:`prepare_output`
creates the missing parent directories when the result is written.
"""
from __future__ import annotations

import math
import os
from collections.abc import Iterable
from pathlib import Path

from gearrom.errors import ConfigError

#: Figure formats accepted for ``--plot``-like options (matplotlib's raster and vector backends).
PLOT_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff", ".webp")


def option_error(option: str, value: object, why: str) -> ConfigError:
    """The error for a bad command-line option: names the option and its value, and says why."""
    return ConfigError(f"{option}={value!r}: {why}")


def check_number(option: str, value: float | int | None, *, gt: float | None = None, ge: float | None = None,
                 le: float | None = None, integer: bool = False, unit: str = "", key: str = "") -> None:
    """Check a numeric option: finite (an integer if ``integer``) and within the bounds; None passes.

    Parameters
    ----------
    option : str
        The option as typed, e.g. ``"--fs-hz"`` (named in the message).
    value : float or int or None
        The parsed value.
    gt, ge : float, optional
        Exclusive / inclusive lower bound.
    le : float, optional
        Inclusive upper bound (keeps memory and run time bounded for rates, counts and sizes).
    integer : bool
        The value must be an integer.
    unit : str
        Unit shown in the message, e.g. ``"Hz"``.
    key : str
        Setting the option sets (e.g. ``"grid_fs_hz"``), shown in the message.

    Raises
    ------
    ConfigError
        One line naming the option, the value and the allowed range.
    """
    if value is None:
        return
    parts = [f"> {gt:g}" if gt is not None else "", f">= {ge:g}" if ge is not None else "",
             f"<= {le:g}" if le is not None else ""]
    rng = " and ".join(p for p in parts if p)
    what = ("an integer" if integer else "a finite number") + (f" {rng}" if rng else "") + (f" {unit}" if unit else "")
    what += f" ({key})" if key else ""
    ok = (isinstance(value, int) and not isinstance(value, bool)) if integer else \
        (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value))
    if not ok or (gt is not None and not value > gt) or (ge is not None and not value >= ge) \
            or (le is not None and not value <= le):
        raise option_error(option, value, f"must be {what}")


def _check_creatable(path: Path) -> None:
    """Raise ValueError unless ``path`` can be written: not a directory, its first existing ancestor a
    writable directory (the missing parents are created when the result is written)."""
    if path.is_dir():
        raise ValueError(f"{str(path)!r} is a directory")
    parent = path.parent
    while not parent.exists():
        if parent.parent == parent:
            break
        parent = parent.parent
    if not parent.is_dir():
        raise ValueError(f"cannot create the folder for {str(path)!r}: {str(parent)!r} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write to {str(parent)!r} (permission denied)")


def check_output(option: str, value: str | Path | None, suffixes: Iterable[str] | None = None, *,
                 stdout: bool = False, what: str = "file") -> Path | str | None:
    """Check an output file before any computation: valid name, supported suffix, writable folder.

    Parameters
    ----------
    option : str
        The option, named in the message.
    value : str or Path or None
        The path given (None: the output is not requested).
    suffixes : iterable of str, optional
        Accepted suffixes (lower case, with the dot); None accepts any.
    stdout : bool
        Accept ``"-"`` (standard output), returned as the string ``"-"``.
    what : str
        What the file is, for messages.

    Returns
    -------
    Path or str or None
        The path, ``"-"`` or None.

    Raises
    ------
    ConfigError
        Names the option and why the file cannot be written.
    """
    if value is None:
        return None
    text = str(value)
    if stdout and text == "-":
        return "-"
    if not text or "\x00" in text:
        raise option_error(option, text, f"invalid {what} name")
    path = Path(text)
    allowed = tuple(suffixes) if suffixes is not None else None
    if allowed is not None and path.suffix.lower() not in allowed:
        raise option_error(option, text, f"unsupported {what} type {path.suffix or '(none)'!r}; supported: {', '.join(allowed)}")
    try:
        _check_creatable(path)
    except (OSError, ValueError) as exc:
        raise option_error(option, text, str(exc)) from None
    return path


def check_output_dir(option: str, value: str | Path | None) -> Path | None:
    """Check an output directory (existing, or creatable) before any computation; None passes."""
    if value is None:
        return None
    text = str(value)
    if not text or "\x00" in text:
        raise option_error(option, text, "invalid directory name")
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise option_error(option, text, "exists and is not a directory")
    try:
        _check_creatable(path / "_")
    except (OSError, ValueError) as exc:
        raise option_error(option, text, str(exc)) from None
    return path


def check_input_dir(option: str, value: str | Path | None) -> Path | None:
    """Check an existing directory to read from; None passes."""
    if value is None:
        return None
    text = str(value)
    if not text or "\x00" in text or not Path(text).is_dir():
        raise option_error(option, text, "not an existing directory")
    return Path(text)


def prepare_output(path: str | Path) -> Path:
    """Create the missing parent directories of an output file and return it as a Path.

    Raises
    ------
    ConfigError
        The parent cannot be created (a file is in the way, no permission).
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot create the folder of {path}: {exc.strerror or exc}") from None
    return path


def check_rpm_spec(option: str, spec: str | None, *, max_points: int = 1000, max_rpm: float = 1e5) -> None:
    """Check a speed grid ``START:STOP:STEP`` or ``A,B,C`` [rpm] before it is expanded.

    The number of points is computed from the three numbers, so an enormous grid is refused
    without allocating it. None passes.

    Raises
    ------
    ConfigError
        Not a grid or list of finite positive speeds up to ``max_rpm``, or more than ``max_points``.
    """
    if spec is None:
        return
    try:
        if ":" in spec:
            a, b, step = (float(v) for v in spec.split(":"))
            if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(step)) or step <= 0 or b < a:
                raise ValueError
            n = math.floor((b - a) / step + 1e-9) + 1
            vals = [a, b]
        else:
            vals = [float(v) for v in spec.split(",")]
            n = len(vals)
    except ValueError:
        raise option_error(option, spec, "must be START:STOP:STEP (STEP > 0, STOP >= START) or a comma list of "
                                  "speeds [rpm]") from None
    if not all(math.isfinite(v) and 0 < v <= max_rpm for v in vals):
        raise option_error(option, spec, f"speeds must be finite, > 0 and <= {max_rpm:g} rpm")
    if n > max_points:
        raise option_error(option, spec, f"gives {n:g} speeds, more than {max_points}")


#: a load torque beyond this multiple of the operating torque exceeds any tooth's strength
TORQUE_FACTOR = 100.0


def check_load_torque(option: str, value: float | None, operating_torque: float) -> None:
    """A load torque option [N m]: positive and at most :data:`TORQUE_FACTOR` x the config's
    ``operating.torque_out_Nm``; None passes."""
    check_number(option, value, gt=0, le=TORQUE_FACTOR * operating_torque, unit="N m",
                 key=f"<= {TORQUE_FACTOR:g} x operating.torque_out_Nm")
