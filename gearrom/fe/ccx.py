"""Load steps, readout and running of the Abaqus/CalculiX decks of :mod:`gearrom.fe.export`.

A gear pair in frictionless contact has a free rigid-body rotation until its flanks touch: a static
step that loads the free gear by a moment from the unloaded state is singular (the solver's first
Newton iterations see no contact stiffness). The decks therefore carry two steps:

1. *contact closure*: the loaded gear's rotation node is turned by a prescribed angle, a fraction
   (:data:`CLOSURE_FRACTION`) of the static TE that ISO 6336's mean mesh stiffness predicts for the
   load, so that the contacts close under a part of the load;
2. *load*: ``*BOUNDARY, OP=NEW`` releases that rotation (and restates every support), and the
   moment is applied to the rotation node. The end state of a frictionless elastic contact does
   not depend on the load path, so step 2 ends in the static state under the moment alone.

Every deck names its readout in a comment line (``** gearrom-readout: key=value ...``): the rotation
node, its DOF (3: the rotation about +z [rad]), the factor from that rotation to the static TE [um]
(minus the base radius of the loaded gear: the TE is positive when the loaded gear lags), the factor
from the node's moment [N mm] to the output torque [N m], and, when the writer knew it, the LTCA's
static TE at the same position and load. :func:`read_static_te` applies it to a ``.dat`` file;
``gearrom ccx-te DECK.inp`` does the same from the command line.
"""
from __future__ import annotations

import logging
import math
import os
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from gearrom.errors import SolverError

log = logging.getLogger(__name__)

#: share of the ISO 6336 static TE estimate that step 1 prescribes (contacts closed, load below nominal)
CLOSURE_FRACTION = 0.25
READOUT_TAG = "** gearrom-readout:"


def closure_rotation(pair, torque: float, rb_loaded: float) -> float:
    """Rotation [rad] that step 1 prescribes on the loaded gear (negative: clockwise, as its moment).

    ``CLOSURE_FRACTION`` of the static TE ``F_bt / (c_gamma_alpha b)`` at output ``torque`` [N m]
    (ISO 6336-1 mean mesh stiffness, :func:`gearrom.fe.iso6336.mesh_stiffness`), turned into a
    rotation of the gear of base radius ``rb_loaded`` [m].
    """
    from gearrom.fe.iso6336 import mesh_stiffness

    force = torque / pair.rb[1]
    ste = force / (mesh_stiffness(pair) * pair.face_width)
    return -CLOSURE_FRACTION * ste / rb_loaded


def deck_steps(behaviour: str, contact_type: str, load_node: int, moment_Nmm: float, supports: list[str],
               closure: float, rotation: float | None = None) -> list[str]:
    """Contact definition and load steps shared by the spur and helical decks.

    Parameters
    ----------
    behaviour : str
        Data line of the linear pressure-overclosure ``*SURFACE BEHAVIOR`` (penalty [MPa/mm], ...).
    contact_type : str
        ``SURFACE TO SURFACE`` or ``NODE TO SURFACE`` (contact pair SLAVE1/MASTER2).
    load_node : int
        Rotation node of the loaded gear (DOF 3: rotation about +z).
    moment_Nmm : float
        Moment on ``load_node`` about +z [N mm].
    supports : list of str
        ``*BOUNDARY`` data lines of the supports (held in both steps; restated after ``OP=NEW``).
    closure : float
        Rotation of ``load_node`` prescribed in the contact-closure step [rad].
    rotation : float, optional
        Displacement control: one step with this rotation of ``load_node`` [rad] prescribed instead
        of the moment (the printed RF is then the transmitted moment).
    """
    head = ["*SURFACE INTERACTION, NAME=SI", "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR", behaviour,
            f"*CONTACT PAIR, INTERACTION=SI, TYPE={contact_type}", "SLAVE1,MASTER2"]
    out = ["*NODE PRINT, NSET=NROT", "U,RF", "*END STEP"]
    if rotation is not None:
        return head + ["** Single step, displacement control: the rotation of the loaded gear is prescribed; the",
                       "** RF of its rotation node is the transmitted moment [N mm].",
                       "*STEP, INC=200", "*STATIC", "1.0,1.0,1e-4,1.0",
                       "*BOUNDARY", *supports, f"{load_node},3,3,{rotation:.12g}", *out]
    return head + [
        "** STEP 1, contact closure: the loaded gear is turned by a prescribed angle (a part of the static TE",
        "** that ISO 6336's mesh stiffness predicts), so that its flanks touch the mate's. A moment on a gear",
        "** that can still rotate freely before its contacts close would be a singular static problem.",
        "*STEP, INC=200", "*STATIC", "1.0,1.0,1e-4,1.0",
        "*BOUNDARY", *supports, f"{load_node},3,3,{closure:.12g}", *out,
        "** STEP 2, load: OP=NEW removes the prescribed rotation (the supports are restated) and the moment is",
        "** applied. A frictionless elastic contact ends in the same state whatever the load path, so the end",
        "** of this step is the static state under the moment. The static TE is read here (readout line above).",
        "*STEP, INC=200", "*STATIC", "0.25,1.0,1e-4,1.0",
        "*BOUNDARY, OP=NEW", *supports, "*CLOAD", f"{load_node},3,{moment_Nmm:.9g}", *out]


def readout_line(node: int, steps: int, rb_loaded_mm: float, torque_out_per_Nmm: float,
                 ltca_ste: float | None = None) -> list[str]:
    """Comment lines that say where and how the static TE is read (parsed by :func:`read_readout`)."""
    ltca = "" if ltca_ste is None else f" ltca_ste_um={ltca_ste * 1e6:.9g}"
    return [f"** Static TE [um] = -U3 x r_b x 1e3 of node {node} (U3: rotation about +z [rad] at the end of the last",
            f"** step; r_b = {rb_loaded_mm:.9g} mm, base radius of the loaded gear; positive when it lags). Output",
            f"** torque [N m] = |RF3| x {torque_out_per_Nmm:.9g}. Read it with: gearrom ccx-te DECK.inp",
            f"{READOUT_TAG} node={node} dof=3 steps={steps} te_um_per_rad={-rb_loaded_mm * 1e3:.12g} "
            f"torque_Nm_per_Nmm={torque_out_per_Nmm:.12g}{ltca}"]


def write_deck(path: str | Path, lines: list[str]) -> Path:
    """Write the deck ``lines`` to ``path`` (folders created)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def read_ccx_rotation(dat_path: str | Path, rot_node: int, end_time: float | None = None) -> tuple[float, float]:
    """(rotation about z [rad], moment about z [N mm]) of the ROT node: the last U and RF blocks of a ccx .dat.

    With ``end_time`` (the total step time of the deck: 1 per step), a last block at an earlier time
    (a step that did not converge) raises :class:`~gearrom.errors.SolverError`.
    """
    block, out, last_time = None, {}, math.nan
    try:
        text = Path(dat_path).read_text()
    except OSError as exc:
        raise SolverError(f"{dat_path}: cannot read the ccx result ({exc.strerror or exc}); did ccx run?") from None
    for line in text.splitlines():
        low = line.strip().lower()
        if low.startswith("displacements"):
            block = "U"
            try:
                last_time = float(low.rsplit("time", 1)[1])
            except (IndexError, ValueError):
                last_time = math.nan
        elif low.startswith("forces"):
            block = "RF"
        parts = line.split()
        if block and len(parts) == 4 and parts[0] == str(rot_node):
            out[block] = float(parts[3])
    if "U" not in out:
        raise SolverError(f"{dat_path}: no result for node {rot_node} (did ccx converge?)")
    if end_time is not None and not abs(last_time - end_time) < 1e-6 * max(1.0, end_time):
        raise SolverError(f"{dat_path}: the last result of node {rot_node} is at step time {last_time:g}, not at the "
                          f"deck's end {end_time:g}: a step did not converge")
    return out["U"], out.get("RF", float("nan"))


@dataclass(frozen=True)
class Readout:
    """The readout comment of a deck: rotation node, step count, TE per rotation [um/rad], torque per
    moment [N m per N mm], LTCA STE [um]."""

    node: int
    steps: int
    te_um_per_rad: float
    torque_Nm_per_Nmm: float
    ltca_ste_um: float | None


def read_readout(deck: str | Path) -> Readout:
    """Parse the ``** gearrom-readout:`` line of a deck written by :mod:`gearrom.fe.export`."""
    deck = Path(deck)
    try:
        with deck.open() as fh:
            for lineno, line in enumerate(fh, 1):
                if line.startswith(READOUT_TAG):
                    kv = dict(item.split("=", 1) for item in line[len(READOUT_TAG):].split())
                    try:
                        return Readout(int(kv["node"]), int(kv["steps"]), float(kv["te_um_per_rad"]),
                                       float(kv["torque_Nm_per_Nmm"]),
                                       float(kv["ltca_ste_um"]) if "ltca_ste_um" in kv else None)
                    except (KeyError, ValueError) as exc:
                        raise SolverError(f"{deck}, line {lineno}: readout line is damaged ({exc})") from None
    except OSError as exc:
        raise SolverError(f"{deck}: cannot read the deck ({exc.strerror or exc})") from None
    raise SolverError(f"{deck}: no '{READOUT_TAG}' line; it is not a deck written by gearrom stiffness --inp")


def read_static_te(deck: str | Path, dat: str | Path | None = None) -> dict:
    """Static TE and torque of a solved deck.

    Parameters
    ----------
    deck : path
        The ``.inp`` written by :func:`gearrom.fe.export.export_inp`.
    dat : path, optional
        The ccx result (default: the deck's path with suffix ``.dat``).

    Returns
    -------
    dict
        ``ste_um`` (static TE [um], positive when the loaded gear lags), ``torque_out_Nm``,
        ``rotation_rad``, ``node``, and with an LTCA value in the deck ``ltca_ste_um`` and ``ratio_to_ltca``.
    """
    r = read_readout(deck)
    dat = Path(dat) if dat is not None else Path(deck).with_suffix(".dat")
    rot, moment = read_ccx_rotation(dat, r.node, end_time=float(r.steps))
    out = {"deck": str(deck), "dat": str(dat), "node": r.node, "rotation_rad": rot,
           "ste_um": rot * r.te_um_per_rad, "torque_out_Nm": abs(moment) * r.torque_Nm_per_Nmm}
    if r.ltca_ste_um is not None:
        out["ltca_ste_um"] = r.ltca_ste_um
        out["ratio_to_ltca"] = out["ste_um"] / r.ltca_ste_um if r.ltca_ste_um else math.nan
    return out


def run_ccx(deck: str | Path, threads: int = 2, timeout_s: float = 7200.0) -> float:
    """Run ``ccx -i`` on ``deck`` in its folder; return the wall time [s].

    Raises :class:`~gearrom.errors.SolverError` when ccx is missing, fails, or does not converge
    (its ``.dat`` has no result).
    """
    exe = shutil.which("ccx")
    if exe is None:
        raise SolverError("CalculiX (ccx, Debian package calculix-ccx) is not installed")
    deck = Path(deck)
    t0 = time.perf_counter()
    run = subprocess.run([exe, "-i", deck.stem], cwd=deck.parent, capture_output=True, text=True, timeout=timeout_s,
                         env={**os.environ, "OMP_NUM_THREADS": str(threads), "CCX_NPROC_EQUATION_SOLVER": str(threads)})
    wall = time.perf_counter() - t0
    tail = run.stdout[-1500:]
    if run.returncode != 0 or "Job finished" not in run.stdout:
        raise SolverError(f"ccx {deck.name} failed (exit {run.returncode}): {tail}")
    log.info("ccx %s: %.1f s", deck.name, wall)
    return wall
