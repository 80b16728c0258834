"""The mesh element of an exudyn time-domain run, updated once per step: :class:`MeshStepper`.

Every model that integrates the mesh force in exudyn (the constant-speed run of
:func:`gearrom.rom.simulate.simulate_run`, the speed ramp of :mod:`gearrom.study.runup`) adds the
mesh through this class, so that one force law serves them all.

The mesh is an ``ObjectConnectorCoordinateSpringDamperExt`` between ground and the reduced mesh
coordinate ``delta_t`` with limit stops: the upper stop (drive flank) at the separation point
``e0`` with stop stiffness ``k``, the lower stop (back flank) at the mean separation point minus the
backlash, stop damping ``c``. A pre-step function sets ``k`` and ``e0`` before each step:

* secant law (:class:`~gearrom.rom.mesh.MeshLaw` without a torque map): ``k`` and ``e0 = e - F_nom/k``
  averaged over the step (4-point midpoint rule), so that the jumps of the table (pair entry/exit)
  fall at the right place within a step; they are precomputed vectorised in chunks and the
  pre-step only indexes them;
* load-dependent law (:class:`~gearrom.rom.mesh.ForceMap`): the knots of the force-deflection map
  averaged over the step likewise; the segment that holds the deflection at the start of the step
  gives ``k`` (its tangent stiffness) and ``e0`` (where its line meets ``F = 0``).

The mesh angles come from a function of time (``angles``), so a run at constant speed and a speed
ramp use the same code.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from gearrom.rom.mesh import MeshLaw

#: steps per precomputed chunk of mesh parameters
CHUNK = 1 << 16
_SUB = (np.arange(4) + 0.5) / 4


class MeshStepper:
    """Adds the mesh to an exudyn system and updates it once per step.

    Parameters
    ----------
    mbs : exudyn MainSystem
        The system; its first node must be the reduced ``NodeGenericODE2`` ``node`` (the pre-step
        reads the mesh deflection from the system coordinates).
    node : int
        The reduced node.
    i_delta : int
        Index of the mesh deflection among the node's coordinates.
    law : MeshLaw
        The mesh law (secant or load-dependent) with the run's effects.
    damping : float
        Mesh damping [N s/m] (stop damping of both flanks).
    backlash : float
        Backlash on the transverse line of action [m].
    h : float
        Fixed time step [s].
    n_steps : int
        Number of steps of the run.
    angles : callable
        ``angles(t) -> (theta1, theta2)``: drive-sense angles [rad] of both gears at times ``t`` [s].
    ripple_marker : int, optional
        Coordinate marker of the brake: adds a ``LoadCoordinate`` with the law's load ripple.
    period_steps : int, optional
        The mesh parameters repeat every ``period_steps`` steps (constant speed, a whole number of
        steps per mesh period, no effect slower than the mesh period): they are computed for one
        period only.
    """

    def __init__(self, mbs, node: int, i_delta: int, law: MeshLaw, damping: float, backlash: float, h: float,
                 n_steps: int, angles: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
                 ripple_marker: int | None = None, period_steps: int | None = None) -> None:
        from exudyn.itemInterface import (LoadCoordinate, MarkerNodeCoordinate, NodeGenericData, NodePointGround,
                                          ObjectConnectorCoordinateSpringDamperExt)

        self.mbs, self.law, self.h, self.n_steps, self.angles = mbs, law, h, n_steps, angles
        self.f_nom = law.f_nom
        ground = mbs.AddNode(NodePointGround())
        m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
        self.marker = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=i_delta))
        data = mbs.AddNode(NodeGenericData(numberOfDataCoordinates=3, initialCoordinates=[0.0, 0.0, 0.0]))
        th1, th2 = angles(np.zeros(1))
        k0, e0 = law.evaluate(float(th1[0]), float(th2[0]))
        # back-flank stop at the mean separation point minus the backlash (its fluctuation of a few um
        # is neglected against the backlash; saves one parameter update per step)
        self.lower = float(np.mean(law.e_grid - law.f_nom / law.k_grid)) - backlash
        self.conn = mbs.AddObject(ObjectConnectorCoordinateSpringDamperExt(
            markerNumbers=[m_ground, self.marker], nodeNumber=data, useLimitStops=True,
            limitStopsUpper=e0 - law.f_nom / k0, limitStopsLower=self.lower,
            limitStopsStiffness=k0, limitStopsDamping=damping))
        self.load = None
        if ripple_marker is not None:
            self.load = mbs.AddLoad(LoadCoordinate(markerNumber=ripple_marker, load=0.0))
        self._load_dependent = law.load_dependent
        self._last = law.force_map.n_torques - 1 if law.load_dependent else 0  # last segment
        self._coords = mbs.systemData.GetODE2Coordinates
        self._set_object, self._set_load = mbs.SetObjectParameter, mbs.SetLoadParameter
        self._i_delta = i_delta
        self._inv_h = 1.0 / h
        self._period = int(period_steps) if period_steps and ripple_marker is None else 0
        self._start = -1
        self._fill(0)
        self._update = self._make_update()

    def _fill(self, start: int) -> None:
        law, h = self.law, self.h
        idx = np.arange(self._period) if self._period else np.arange(start, min(start + CHUNK, self.n_steps + 1))
        th1, th2 = self.angles(((idx[:, None] + _SUB[None, :]) * h).ravel())
        self._start = start
        if self._load_dependent:
            knots, scale = law.knots_array(th1, th2)
            kn = knots.reshape(-1, 4, knots.shape[1]).mean(axis=1)
            sc = scale.reshape(-1, 4).mean(axis=1)[:, None]
            f = law.force_map.f
            # per step and segment: slope (stop stiffness) and where its line meets F = 0 (stop position)
            k_seg = sc * (f[1:] - f[:-1]) / (kn[:, 1:] - kn[:, :-1])
            up_seg = kn[:, :-1] - sc * f[:-1] / k_seg
            # flat lists, row after row: cheaper to build and to index than lists of rows
            self._knots, self._k, self._up = kn.ravel().tolist(), k_seg.ravel().tolist(), up_seg.ravel().tolist()
        else:
            k_arr, e_arr = law.evaluate_array(th1, th2)
            k_avg = k_arr.reshape(-1, 4).mean(axis=1)
            f0_avg = (k_arr * e_arr - self.f_nom).reshape(-1, 4).mean(axis=1)
            self._k, self._up = k_avg.tolist(), (f0_avg / k_avg).tolist()
        if self.load is not None:
            self._rip = [law.ripple(a) for a in self.angles((idx + 0.5) * h)[1]]

    def step_index(self, t: float) -> int:
        """Index of the coming step: exudyn passes the END time ``t_n + h`` of the coming step."""
        return int(t * self._inv_h + 0.5) - 1

    def _make_update(self) -> Callable[[int], None]:
        """The per-step update :meth:`update` as a closure over everything it reads (it runs once per
        time step, where attribute lookups are a noticeable share of the step)."""
        set_object, set_load, conn, load = self._set_object, self._set_load, self.conn, self.load
        coords, i_delta, last, ld = self._coords, self._i_delta, self._last, self._load_dependent
        w = last + 2  # knots per step
        period = self._period
        state = [0, None]  # segment of the previous step; view of the system state (taken once per solve)

        def update(n: int) -> None:
            if period:
                i = n % period
            else:
                i = n - self._start
                if i >= CHUNK or i < 0:
                    self._fill(n)
                    i = 0
            c = i
            if ld:
                q = state[1]
                if q is None:
                    q = state[1] = coords(copy=False)
                kn, j, b = self._knots, state[0], i * w
                d = q.item(i_delta)
                while j > 0 and d < kn[b + j]:
                    j -= 1
                while j < last and d >= kn[b + j + 1]:
                    j += 1
                state[0] = j
                c = i * (last + 1) + j
            set_object(conn, "limitStopsStiffness", self._k[c])
            set_object(conn, "limitStopsUpper", self._up[c])
            if load is not None:
                set_load(load, "load", self._rip[i])

        return update

    def update(self, n: int) -> None:
        """Set the mesh parameters (and the load ripple) for step ``n``.

        Load-dependent law: the segment of the force-deflection map that holds the current
        deflection gives the stop stiffness (its slope) and stop position (where its line meets
        ``F = 0``); it is searched from the previous step's segment, since the deflection moves
        little within a step.
        """
        self._update(n)

    def pre_step(self, mbs, t: float) -> bool:
        """The exudyn pre-step user function of a run that needs nothing else per step (the step index
        of :meth:`step_index` written out: this runs once per time step)."""
        self._update(int(t * self._inv_h + 0.5) - 1)
        return True


def rk44_settings(n_steps: int, t_end: float, write_period: float):
    """exudyn settings of a fixed-step RK44 run with sensors stored in memory every ``write_period``
    [s]: no solution file, no console output, and no extra right-hand side per step for the
    end-of-step accelerations (no sensor reads them)."""
    import exudyn as exu

    s = exu.SimulationSettings()
    s.timeIntegration.numberOfSteps = n_steps
    s.timeIntegration.endTime = t_end
    s.timeIntegration.verboseMode = 0
    s.timeIntegration.solverType = exu.DynamicSolverType.RK44
    s.timeIntegration.explicit.computeEndOfStepAccelerations = False
    s.solution.file.write = False
    s.solution.sensors.writePeriod = write_period
    return s



def reduced_system(red, y0: np.ndarray, v0: np.ndarray):
    """An exudyn system of a reduced drivetrain: one node of the reduced coordinates (initial state ``y0``,
    ``v0``), one GenericODE2 object with the reduced matrices and constant load, and a sensor of the
    coordinates stored in memory. Returns ``(system container, mbs, node, object, sensor)``."""
    import exudyn as exu
    from exudyn.itemInterface import NodeGenericODE2, ObjectGenericODE2, SensorNode

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    r = len(y0)
    node = mbs.AddNode(NodeGenericODE2(referenceCoordinates=[0.0] * r, initialCoordinates=list(y0),
                                       initialCoordinates_t=list(v0), numberOfODE2Coordinates=r))
    body = mbs.AddObject(ObjectGenericODE2(nodeNumbers=[node], massMatrix=red.M, stiffnessMatrix=red.K,
                                           dampingMatrix=red.D, forceVector=list(red.F)))
    sens = mbs.AddSensor(SensorNode(nodeNumber=node, outputVariableType=exu.OutputVariableType.Coordinates,
                                    storeInternal=True, writeToFile=False))
    return SC, mbs, node, body, sens


def solve_rk44(mbs, sensor: int, n_steps: int, t_end: float, fs: float, what: str) -> tuple[np.ndarray, float, float]:
    """Assemble and integrate ``mbs`` with fixed-step RK44; the stored data of ``sensor``, wall and CPU time [s].

    Raises
    ------
    SolverError
        The solver stops or the coordinates are not finite (``what`` names the run in the message).
    """
    import time

    import exudyn as exu

    from gearrom.errors import SolverError

    mbs.Assemble()
    s = rk44_settings(n_steps, t_end, 1.0 / fs)
    t0, c0 = time.perf_counter(), time.process_time()
    ok = mbs.SolveDynamic(s, solverType=exu.DynamicSolverType.RK44)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    raw = mbs.GetSensorStoredData(sensor)
    if not ok or not np.all(np.isfinite(raw)):
        raise SolverError(f"{what} failed (h = {t_end / n_steps:.3g} s); try a smaller rom.max_step_us")
    return raw, wall, cpu
