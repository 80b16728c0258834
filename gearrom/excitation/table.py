"""The hand-off between the quasi-static mesh analysis and the dynamic model: :class:`MeshExcitation`.

A :class:`MeshExcitation` tabulates, over the mesh phase and the load torque,

* the mesh stiffness ``k`` [N/m] (interpolated by :meth:`MeshExcitation.stiffness`),
* the static (loaded) transmission error ``e`` [m] (interpolated by :meth:`MeshExcitation.ste`),
* the load share of each tooth pair in contact [-],
* optionally the maximum contact pressure [Pa].

Conventions (binding for every producer: the analytical model here, the FE LTCA, measurements)
-----------------------------------------------------------------------------------------------
* ``theta`` is the input-gear rotation angle within one mesh period, ``theta in [0, 2 pi / z1)``
  on a uniform periodic grid of ``n_theta`` points (the end point is *not* repeated).
  Where ``theta = 0`` lies is producer-specific and recorded in ``metadata["theta_origin"]``.
* ``torque`` is the load torque on the output gear [N m], strictly increasing.
* Transmission error and deflection are measured along the line of action in the *transverse*
  plane, at the base circles: ``TE = rb1 theta1 - rb2 theta2``, positive when the output lags.
* The stiffness is transverse as well: ``k = dF_t / d(TE)`` (tangent) or ``F_t / (TE - TE_0)``
  (secant) with ``F_t = torque / rb2`` the transverse line-of-action force. The normal (3D) line of
  action values follow from ``k_n = k / cos(beta_b)^2``. ``definition`` states which variant the
  producer computed and what compliance it contains, e.g.
  ``"secant; transverse LOA; tooth bending + shear + foundation + contact; no shaft/bore"``.
  The dynamic model uses either variant through ``F_t = k (delta - e_0)`` with
  ``e_0 = e - F_t,nominal / k`` (see :mod:`gearrom.rom.mesh`).

Between grid points the data are interpolated by trigonometric (Fourier) interpolation in theta
(exact for band-limited periodic data, periodic by construction) and linearly in torque. Torques
outside the tabulated range are clamped to the nearest end with a warning.
"""
from __future__ import annotations

import json
import logging
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from gearrom.errors import ModelError

log = logging.getLogger(__name__)

FORMAT_VERSION = 1


def netcdf_engine() -> str:
    """The xarray NetCDF engine to use: ``h5netcdf`` when h5py is importable, else ``netcdf4``."""
    try:
        import h5py  # noqa: F401

        return "h5netcdf"
    except ImportError:
        return "netcdf4"


def write_netcdf(dataset, path: str | Path) -> Path:
    """Write an xarray ``dataset`` to ``path`` (parents created) with :func:`netcdf_engine`."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    dataset.to_netcdf(path, engine=netcdf_engine())
    return path


@dataclass(frozen=True)
class Harmonics:
    """Mesh-order harmonics at one torque.

    ``x(theta) = Re(sum_m c[m] exp(i m z1 theta))`` for ``m = 0..n``; ``c[0]`` is the mean,
    ``abs(c[m])`` the amplitude (zero-to-peak) of mesh order ``m``.

    Attributes
    ----------
    order : ndarray of int
        Mesh orders 0..n.
    stiffness : ndarray of complex
        Stiffness coefficients [N/m].
    ste : ndarray of complex
        Static TE coefficients [m].
    """

    order: np.ndarray
    stiffness: np.ndarray
    ste: np.ndarray


@dataclass(frozen=True, eq=False)
class MeshExcitation:
    """Mesh stiffness and static transmission error over mesh phase and torque.

    Parameters
    ----------
    z1 : int
        Teeth of the input gear (sets the mesh period ``2 pi / z1`` of ``theta``).
    theta : ndarray, shape (n_theta,)
        Input-gear angle within one mesh period [rad], uniform, ``theta[0] = 0``, end excluded.
    torque : ndarray, shape (n_torque,)
        Output load torque [N m], strictly increasing, positive.
    k : ndarray, shape (n_torque, n_theta)
        Transverse mesh stiffness [N/m] (> 0).
    e : ndarray, shape (n_torque, n_theta)
        Static transmission error along the transverse line of action [m], positive = output lags.
    load_share : ndarray, shape (n_torque, n_theta, n_pairs)
        Share of the load carried by each tooth pair [-]; pair 0 is the one that enters contact at
        ``theta = 0``. Rows sum to 1 wherever the pair carries load.
    pairs : ndarray of int, shape (n_pairs,), optional
        Pair index of each ``load_share`` column, consecutive (default ``0 .. n_pairs-1``: column j is
        pair j). Pair ``p`` entered contact ``p`` mesh periods before ``theta = 0``; ``-1`` is the next
        pair, which may touch early (premature contact of deflected teeth). Use :meth:`share_of`.
    definition : str
        Which stiffness (secant/tangent) and which compliances it includes.
    max_pressure : ndarray, shape (n_torque, n_theta), optional
        Largest contact pressure [Pa].
    metadata : dict
        Provenance: ``source`` (producer), ``config`` (name), ``config_digest``, ``theta_origin``...
    """

    z1: int
    theta: np.ndarray
    torque: np.ndarray
    k: np.ndarray
    e: np.ndarray
    load_share: np.ndarray
    definition: str
    max_pressure: np.ndarray | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    pairs: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.z1, (int, np.integer)) or self.z1 < 1:
            raise ModelError(f"MeshExcitation.z1 must be a positive integer, got {self.z1!r}")
        th = np.asarray(self.theta, dtype=float)
        tq = np.atleast_1d(np.asarray(self.torque, dtype=float))
        n_th, n_tq = th.size, tq.size
        period = 2 * math.pi / self.z1
        if th.ndim != 1 or n_th < 4:
            raise ModelError(f"MeshExcitation.theta must be 1-D with >= 4 points, got shape {th.shape}")
        if abs(th[0]) > 1e-12 * period or not np.allclose(np.diff(th), period / n_th, rtol=1e-6, atol=0):
            raise ModelError(
                f"MeshExcitation.theta must be uniform on [0, 2 pi/z1) = [0, {period:.6g}) rad without the end "
                f"point (n_theta={n_th}, spacing should be {period / n_th:.6g})"
            )
        if np.any(~np.isfinite(tq)) or np.any(np.diff(tq) <= 0):
            raise ModelError(f"MeshExcitation.torque must be finite and strictly increasing, got {tq}")
        arrays = {"k": self.k, "e": self.e}
        if self.max_pressure is not None:
            arrays["max_pressure"] = self.max_pressure
        for name, arr in arrays.items():
            a = np.asarray(arr, dtype=float)
            if a.shape != (n_tq, n_th):
                raise ModelError(f"MeshExcitation.{name} has shape {a.shape}; expected (n_torque, n_theta) = ({n_tq}, {n_th})")
            if not np.all(np.isfinite(a)):
                raise ModelError(f"MeshExcitation.{name} contains non-finite values")
            object.__setattr__(self, name, a)
        if np.any(self.k <= 0):
            raise ModelError("MeshExcitation.k must be > 0 everywhere (contact loss is the ROM's job)")
        ls = np.asarray(self.load_share, dtype=float)
        if ls.ndim != 3 or ls.shape[:2] != (n_tq, n_th):
            raise ModelError(f"MeshExcitation.load_share has shape {ls.shape}; expected ({n_tq}, {n_th}, n_pairs)")
        pairs = np.arange(ls.shape[2]) if self.pairs is None else np.asarray(self.pairs)
        if (pairs.shape != (ls.shape[2],) or not np.all(pairs == np.round(pairs))
                or (pairs.size > 1 and np.any(np.diff(pairs) != 1))):
            raise ModelError(f"MeshExcitation.pairs must be {ls.shape[2]} consecutive integers (one per load_share "
                             f"column), got {self.pairs!r}")
        object.__setattr__(self, "pairs", pairs.astype(int))
        if not isinstance(self.definition, str) or not self.definition.strip():
            raise ModelError("MeshExcitation.definition must say which stiffness this is (secant/tangent, compliances)")
        object.__setattr__(self, "theta", th)
        object.__setattr__(self, "torque", tq)
        object.__setattr__(self, "load_share", ls)
        object.__setattr__(self, "metadata", dict(self.metadata))
        # Fourier coefficients per torque (one-sided, amplitude-scaled) for interpolation
        object.__setattr__(self, "_ck", np.fft.rfft(self.k, axis=1) / n_th)
        object.__setattr__(self, "_ce", np.fft.rfft(self.e, axis=1) / n_th)

    # ------------------------------------------------------------------ basics
    @property
    def period(self) -> float:
        """Mesh period in input-gear angle, 2 pi / z1 [rad]."""
        return 2 * math.pi / self.z1

    @property
    def n_theta(self) -> int:
        return self.theta.size

    @property
    def n_torque(self) -> int:
        return self.torque.size

    def _torque_weights(self, torque: float) -> tuple[int, int, float]:
        tq = self.torque
        t = float(torque)
        if tq.size == 1:
            return 0, 0, 0.0
        if t < tq[0] or t > tq[-1]:
            warnings.warn(
                f"torque {t:.4g} N m lies outside the excitation table [{tq[0]:.4g}, {tq[-1]:.4g}] N m; "
                "the nearest end is used",
                stacklevel=3,
            )
            t = min(max(t, tq[0]), tq[-1])
        j = int(np.clip(np.searchsorted(tq, t) - 1, 0, tq.size - 2))
        w = (t - tq[j]) / (tq[j + 1] - tq[j])
        return j, j + 1, w

    def _coeffs(self, which: str, torque: float) -> np.ndarray:
        c = self._ck if which == "k" else self._ce
        j0, j1, w = self._torque_weights(torque)
        return (1 - w) * c[j0] + w * c[j1]

    def _evaluate(self, coeffs: np.ndarray, theta: np.ndarray) -> np.ndarray:
        n = self.n_theta
        m = np.arange(coeffs.size)
        scale = np.where((m == 0) | ((n % 2 == 0) & (m == n // 2)), 1.0, 2.0)
        ph = np.multiply.outer(np.asarray(theta, dtype=float) * self.z1, m)
        return (np.exp(1j * ph) @ (scale * coeffs)).real

    def load_share_at(self, torque: float) -> np.ndarray:
        """Load share (n_theta, n_pairs) at ``torque`` [N m], linear between the table's torques."""
        j0, j1, w = self._torque_weights(torque)
        return (1 - w) * self.load_share[j0] + w * self.load_share[j1]

    def share_of(self, pair: int) -> np.ndarray:
        """Load share of tooth pair ``pair`` (n_torque, n_theta); zeros for a pair without a column."""
        k = np.flatnonzero(self.pairs == pair)
        return self.load_share[..., k[0]] if k.size else np.zeros(self.load_share.shape[:2])

    # ------------------------------------------------------------- evaluation
    def stiffness(self, theta: float | np.ndarray, torque: float) -> np.ndarray:
        """Mesh stiffness [N/m] at input-gear angle(s) ``theta`` [rad] (any value: periodic) and ``torque`` [N m]."""
        return self._evaluate(self._coeffs("k", torque), theta)

    def ste(self, theta: float | np.ndarray, torque: float) -> np.ndarray:
        """Static transmission error [m] at ``theta`` [rad] (periodic) and output ``torque`` [N m]."""
        return self._evaluate(self._coeffs("e", torque), theta)

    def harmonics(self, torque: float, n: int = 5) -> Harmonics:
        """Mesh orders 0..n of stiffness and STE at ``torque`` [N m] (see :class:`Harmonics`)."""
        if n < 0 or n > self.n_theta // 2:
            raise ModelError(f"harmonics: n={n} must lie in [0, n_theta/2 = {self.n_theta // 2}]")
        m = np.arange(n + 1)
        scale = np.where(m == 0, 1.0, 2.0)
        return Harmonics(order=m, stiffness=scale * self._coeffs("k", torque)[: n + 1],
                         ste=scale * self._coeffs("e", torque)[: n + 1])

    def mean_stiffness(self, torque: float) -> float:
        """Mesh-period mean stiffness at ``torque`` [N/m]."""
        return float(self._coeffs("k", torque)[0].real)

    def mean_ste(self, torque: float) -> float:
        """Mesh-period mean static TE at ``torque`` [m]."""
        return float(self._coeffs("e", torque)[0].real)

    def sampled(self, torque: float, n: int = 512) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(theta, k, e)`` on a uniform grid of ``n`` points over one mesh period at ``torque``."""
        th = np.arange(n) * self.period / n
        return th, self._evaluate(self._coeffs("k", torque), th), self._evaluate(self._coeffs("e", torque), th)

    # ------------------------------------------------------------------- I/O
    def to_dataset(self):
        """The table as an :class:`xarray.Dataset` (SI units in attributes)."""
        import xarray as xr

        data = {
            "k": (("torque", "theta"), self.k, {"units": "N/m"}),
            "e": (("torque", "theta"), self.e, {"units": "m"}),
            "load_share": (("torque", "theta", "pair"), self.load_share, {"units": "1"}),
        }
        if self.max_pressure is not None:
            data["max_pressure"] = (("torque", "theta"), self.max_pressure, {"units": "Pa"})
        return xr.Dataset(
            data,
            coords={"torque": ("torque", self.torque, {"units": "N m"}), "theta": ("theta", self.theta, {"units": "rad"}),
                    "pair": ("pair", self.pairs, {"long_name": "tooth pair index (p entered p mesh periods earlier)"})},
            attrs={"format": "gearrom.MeshExcitation", "format_version": FORMAT_VERSION, "z1": int(self.z1),
                   "definition": self.definition, "metadata_json": json.dumps(self.metadata, default=str)},
        )

    def save(self, path: str | Path) -> Path:
        """Write the table to NetCDF (h5netcdf engine, netcdf4 when h5py is missing). Returns the path."""
        return write_netcdf(self.to_dataset(), path)

    @classmethod
    def load(cls, path: str | Path) -> "MeshExcitation":
        """Read a table written by :meth:`save`.

        Raises
        ------
        ModelError
            The file is not a gearrom mesh excitation table.
        """
        import xarray as xr

        path = Path(path)
        with xr.open_dataset(path, engine=netcdf_engine()) as ds:
            if ds.attrs.get("format") != "gearrom.MeshExcitation":
                raise ModelError(f"{path}: not a gearrom MeshExcitation file (attribute 'format' is {ds.attrs.get('format')!r})")
            mp = ds["max_pressure"].values if "max_pressure" in ds else None
            return cls(
                z1=int(ds.attrs["z1"]), theta=ds["theta"].values, torque=ds["torque"].values,
                k=ds["k"].values, e=ds["e"].values, load_share=ds["load_share"].values,
                definition=str(ds.attrs["definition"]), max_pressure=mp,
                metadata=json.loads(ds.attrs.get("metadata_json", "{}")),
                pairs=ds["pair"].values if "pair" in ds.coords else None,
            )

    # ------------------------------------------------------------------ plot
    def plot(self, torque: float | None = None):
        """Stiffness, STE and load share over one mesh period (at ``torque``, default all torques)."""
        from gearrom.plotting import subplots

        fig, axes = subplots(3, 1, figsize=(7, 8), sharex=True)
        deg = np.degrees(self.theta)
        rows = range(self.n_torque) if torque is None else [int(np.argmin(abs(self.torque - torque)))]
        for j in rows:
            lab = f"{self.torque[j]:.4g} N m"
            axes[0].plot(deg, self.k[j] * 1e-6, label=lab)
            axes[1].plot(deg, self.e[j] * 1e6, label=lab)
        j = list(rows)[-1]
        for n, p in enumerate(self.pairs):
            axes[2].plot(deg, self.load_share[j, :, n], label=f"pair {p}")
        axes[0].set_ylabel("stiffness [N/um]")
        axes[1].set_ylabel("STE [um]")
        axes[2].set_ylabel(f"load share @ {self.torque[j]:.4g} N m")
        axes[2].set_xlabel("input gear angle in mesh period [deg]")
        axes[0].legend(fontsize=7)
        axes[0].set_title(f"{self.metadata.get('source', 'mesh excitation')}: {self.definition}", fontsize=8)
        fig.tight_layout()
        return fig

