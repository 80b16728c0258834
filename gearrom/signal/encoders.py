"""Encoder channels of a measurement: the channel names and one encoder's description."""
from __future__ import annotations

import math
from dataclasses import dataclass

from gearrom.errors import MeasurementError

__all__ = ["CHANNELS", "EncoderInfo", "encoder_table", "encoder_ratio"]

#: the two encoder channels of a measurement: input and output shaft
CHANNELS = ("input", "output")


@dataclass(frozen=True)
class EncoderInfo:
    """One encoder channel.

    Parameters
    ----------
    edges_per_rev : int
        Counted edges per encoder revolution (pulses/rev times the decoding factor, e.g. 4; for
        kind ``quadrature`` lines times the decoding factor).
    location : str
        Where the encoder sits, e.g. ``"sensor"`` or ``"clutch"`` (informative only).
    ratio : float
        Encoder revolutions per shaft revolution (a sensor gear or belt; 1 on the shaft). The
        shaft angle of edge n is ``n * 2*pi / (edges_per_rev * ratio)``.
    lines : int or None
        Lines (pulses) per revolution of a sampled quadrature encoder.
    a, b, z : str or None
        Names of the A, B and (optional) index channels in a sampled data file.
    """

    edges_per_rev: int
    location: str = "sensor"
    ratio: float = 1.0
    lines: int | None = None
    a: str | None = None
    b: str | None = None
    z: str | None = None

    @property
    def counts_per_shaft_rev(self) -> float:
        """Counted edges per shaft revolution, ``edges_per_rev * ratio``."""
        return self.edges_per_rev * self.ratio


def encoder_ratio(e: dict, where: str) -> float:
    """The optional ``ratio`` key of an encoder (encoder revolutions per shaft revolution, default 1)."""
    val = e.get("ratio", 1.0)
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not (math.isfinite(val) and 0 < val <= 1e3):
        raise MeasurementError(f"{where}: 'ratio' must be a number in (0, 1000] (encoder revolutions per shaft "
                               f"revolution), got {val!r}")
    return float(val)


def encoder_table(e, where: str, allowed: set[str], kind: str = "") -> dict:
    """The JSON object of one encoder channel, checked: an object whose keys are all ``allowed``.

    Raises
    ------
    MeasurementError
        Not an object, or an unknown key (``where`` names the file and channel).
    """
    if not isinstance(e, dict):
        raise MeasurementError(f"{where} must be an object, got {e!r}")
    bad = sorted(set(e) - allowed)
    if bad:
        raise MeasurementError(f"{where}: unknown key(s) {bad}; allowed{kind}: {sorted(allowed)}")
    return e
