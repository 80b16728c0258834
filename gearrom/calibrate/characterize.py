"""Physical characterization of a residual: order lines, sidebands (AM/PM), peaks, fixed vs tracking.

* :func:`order_table`: amplitudes of the standard lines (orders 1-3 of each shaft, GMF 1-3 and their
  first sidebands at both shaft orders) by joint least squares on the shaft angles, so that short
  records (2 output revolutions) and the non-integer ratio of the two shafts are handled.
* :func:`sideband_modulation`: for each GMF harmonic and shaft, the product of the upper and lower
  sideband over the carrier squared: ``U L / C^2`` is real positive for amplitude modulation and
  real negative for phase modulation (``x = C(1 + m cos)`` vs ``C exp(i b cos)``).
* :func:`spectral_peaks` and :func:`classify_peaks`: lines in the residual spectrum above the
  noise, grouped across runs as ``fixed_frequency`` (same Hz at different speeds: a resonance) or
  ``order_tracking`` (same order), ``undetermined`` when one speed cannot tell.
* :func:`impulsiveness`: crest factor of the synchronous average per revolution of each shaft
  (a displaced tooth gives an impulsive once-per-rev pattern, runout a smooth one).
* :func:`tooth_local_pulses`: a pulse at one tooth of either gear left in a residual, from the
  synchronous average over that gear's revolutions with its tooth-periodic part removed; it reports
  out-of-library tooth damage (a pit, a chipped tooth) that no order line shows on its own.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import signal

from gearrom.calibrate.residual import RunData, coinciding_lines, fit_lines

UM = 1e-6


def standard_lines(run: RunData) -> list[tuple[str, float, float]]:
    """``(label, a, b)``: line ``a theta_in + b theta_out``; orders 1-3 per shaft, GMF 1-3, sidebands +-1."""
    z1 = run.mesh.z1
    out = [(f"{q}x f_in", float(q), 0.0) for q in (1, 2, 3)]
    out += [(f"{q}x f_out", 0.0, float(q)) for q in (1, 2, 3)]
    for h in (1, 2, 3):
        out.append((f"{h}xGMF", float(h * z1), 0.0))
        for sgn in (-1, 1):
            s = "+" if sgn > 0 else "-"
            out.append((f"{h}xGMF{s}1x f_in", float(h * z1 + sgn), 0.0))
            out.append((f"{h}xGMF{s}1x f_out", float(h * z1), float(sgn)))
    return out


def line_order(run: RunData, a: float, b: float) -> float:
    """Order of a line in input-shaft orders."""
    return a + b * run.mesh.ratio


def order_table(run: RunData, before: np.ndarray, after: np.ndarray) -> list[dict]:
    """Before/after amplitudes (um) of the standard lines in the TE residuals of one run.

    Standard lines that are the same line (an integer ratio: order 1 of the input and order 2 of the
    output of a 15/30 pair) are fitted once and reported once, under all their names (``names``,
    ``label`` joins them with ``" = "``).
    """
    lab = standard_lines(run)
    lines = np.array([[a, b] for _, a, b in lab])
    keep, inv = coinciding_lines(run.theta_in_rad, run.theta_out_rad, lines)
    lab_u = [lab[k] for k in keep]
    names = [[name for (name, _, _), j in zip(lab, inv) if j == u] for u in range(len(keep))]
    lines_u = lines[keep]
    cb = fit_lines(before, run.theta_in_rad, run.theta_out_rad, lines_u)
    ca = fit_lines(after, run.theta_in_rad, run.theta_out_rad, lines_u)
    return [{"label": " = ".join(nm), "names": nm, "order": line_order(run, a, b),
             "order_out": line_order(run, a, b) / run.mesh.ratio, "before_um": abs(x) / UM, "after_um": abs(y) / UM}
            for (_, a, b), nm, x, y in zip(lab_u, names, cb, ca)]


def sideband_modulation(run: RunData, te: np.ndarray, noise_line_m: float) -> list[dict]:
    """AM/PM classification of the first sidebands of GMF 1-3 at each shaft order in a TE signal."""
    z1 = run.mesh.z1
    out = []
    for h in (1, 2, 3):
        for shaft, side in (("input", ((h * z1 - 1, 0), (h * z1 + 1, 0))), ("output", ((h * z1, -1), (h * z1, 1)))):
            lines = np.array([[h * z1, 0], side[0], side[1]], float)
            c, lo, up = fit_lines(te, run.theta_in_rad, run.theta_out_rad, lines)
            if abs(c) < 5 * noise_line_m or max(abs(lo), abs(up)) < 5 * noise_line_m:
                continue
            r = up * lo / c**2
            ang = math.degrees(math.atan2(r.imag, r.real))
            kind = "AM" if abs(ang) < 45 else ("PM" if abs(ang) > 135 else "mixed AM/PM")
            out.append({"harmonic": h, "shaft": shaft, "carrier_um": abs(c) / UM, "lower_um": abs(lo) / UM,
                        "upper_um": abs(up) / UM, "modulation": kind, "angle_deg": ang})
    return out


def noise_per_bin(noise_rms_m: float, n: int) -> float:
    """Amplitude of white noise in one bin of a Hann-windowed, coherent-gain corrected spectrum, m."""
    return 2 * noise_rms_m * math.sqrt(1.5 / n)


def spectral_peaks(x: np.ndarray, fs_hz: float, noise_rms_m: float, snr: float = 6.0,
                   floor_m: float = 0.0, fmax_hz: float | None = None) -> list[tuple[float, float]]:
    """Peaks ``(frequency_hz, amplitude_m)`` of a Hann amplitude spectrum above ``snr`` x the noise per bin."""
    n = x.size
    w = signal.get_window("hann", n)
    pad = 8 * n
    X = np.fft.rfft((x - x.mean()) * w, pad)
    amp = 2 * np.abs(X) / w.sum()
    f = np.fft.rfftfreq(pad, 1 / fs_hz)
    thr = max(snr * noise_per_bin(noise_rms_m, n), floor_m)
    fmin = 2.0 * fs_hz / n
    fmax = fmax_hz or 0.4 * fs_hz
    idx, _ = signal.find_peaks(amp, height=thr, distance=max(1, int(pad / n * 2)))
    return [(float(f[i]), float(amp[i])) for i in idx if fmin <= f[i] <= fmax]


def nearest_integer_order(run: RunData, f_hz: float, tol_orders: float) -> str | None:
    """Label of an integer order of either shaft (or a GMF harmonic) within ``tol_orders``, else None.

    An order of both shafts (integer ratio) is named for both, joined by ``" = "``."""
    f_in = run.rpm_in / 60
    o_in = f_hz / f_in
    o_out = o_in / run.mesh.ratio
    names = []
    if abs(o_in - round(o_in)) <= tol_orders and round(o_in) >= 1:
        q = int(round(o_in))
        names.append(f"{q // run.mesh.z1}xGMF" if q % run.mesh.z1 == 0 else f"input order {q}")
    # a GMF harmonic is always an output order too (named as GMF); otherwise, with an integer ratio, an
    # order of both shafts gets both names ("input order 1 = output order 2" for z2 = 2 z1)
    if abs(o_out - round(o_out)) <= tol_orders / run.mesh.ratio and round(o_out) >= 1 \
            and not (names and "GMF" in names[0]):
        names.append(f"output order {int(round(o_out))}")
    return " = ".join(names) or None


#: peak-position tolerance in bins (1 / record length) of a Hann spectrum: the maximum of the 8x
#: zero-padded spectrum locates an isolated line to a small fraction of a bin; leakage from a neighbour
#: line moves it by up to about a quarter bin
PEAK_TOL_BINS = 0.5


def classify_peaks(runs: list[RunData], peaks: list[list[tuple[float, float]]]) -> list[dict]:
    """Group peaks across runs: fixed_frequency, order_tracking or undetermined (see module docstring).

    A peak at ``f`` in run a predicts ``f`` in run b if it is a fixed frequency and ``f f_b / f_a``
    if it tracks the input speed (``f_a``, ``f_b``: the runs' measured input speeds). The
    tolerance of each prediction is :data:`PEAK_TOL_BINS` bins of both records (the tracking
    prediction carries run a's position error scaled by ``f_b / f_a``). Run b tells the two apart
    when the predictions lie more than two tolerances apart; a run at a speed too close to run a's
    does not count.
    """
    out = []
    used = [set() for _ in runs]
    for a, (ra, pa) in enumerate(zip(runs, peaks)):
        fa_in = ra.rpm_in / 60
        bin_a = 1.0 / ra.duration_s
        for i, (f, amp) in enumerate(pa):
            if i in used[a]:
                continue
            used[a].add(i)
            fixed, track, amps = [], [], [amp]
            diverse = False
            for b, (rb, pb) in enumerate(zip(runs, peaks)):
                if b == a:
                    continue
                scale = (rb.rpm_in / 60) / fa_in
                tol_fix = PEAK_TOL_BINS * (bin_a + 1.0 / rb.duration_s)
                tol_trk = PEAK_TOL_BINS * (scale * bin_a + 1.0 / rb.duration_s)
                f_trk = f * scale
                if abs(f_trk - f) <= tol_fix + tol_trk:
                    continue  # speeds too close for this line
                diverse = True
                free = [(j, g, amp_b) for j, (g, amp_b) in enumerate(pb) if j not in used[b]]
                near_fix = [(abs(g - f), j, g, amp_b) for j, g, amp_b in free if abs(g - f) <= tol_fix]
                near_trk = [(abs(g - f_trk), j, g, amp_b) for j, g, amp_b in free if abs(g - f_trk) <= tol_trk]
                if near_trk:
                    track.append((b,) + min(near_trk)[1:])
                if near_fix:
                    fixed.append((b,) + min(near_fix)[1:])
            o_in = f / fa_in
            if track and len(track) >= len(fixed):
                kind, members = "order_tracking", track
            elif fixed:
                kind, members = "fixed_frequency", fixed
            else:
                kind, members = ("undetermined" if not diverse else "single_run_only"), []
            for b, j, _, amp_b in members:
                used[b].add(j)
                amps.append(amp_b)
            tol_o = PEAK_TOL_BINS / (ra.duration_s * fa_in)  # one bin in input orders
            if kind == "order_tracking":  # the order from all runs' measured speeds, weighted by record length
                w = [ra.duration_s] + [runs[b].duration_s for b, *_ in members]
                o = [o_in] + [g / (runs[b].rpm_in / 60) for b, _, g, _ in members]
                o_in = float(np.average(o, weights=w))
                tol_o = min([tol_o] + [PEAK_TOL_BINS / (runs[b].duration_s * runs[b].rpm_in / 60) for b, *_ in members])
            item = {"frequency_hz": f, "order": o_in if kind == "order_tracking" else None,
                    "order_out": o_in / ra.mesh.ratio if kind == "order_tracking" else None,
                    "kind": kind, "amplitude_um": max(amps) / UM, "run": ra.name,
                    "order_at_this_run": f / fa_in, "runs_seen": 1 + len(members),
                    "frequencies_hz": [f] + [g for _, _, g, _ in members],
                    "integer_order": nearest_integer_order(ra, o_in * fa_in, tol_o)}
            if kind == "undetermined":
                item["note"] = "seen at one speed only: a run at another speed tells fixed frequency from order"
            out.append(item)
    return out


def _revolutions(theta: np.ndarray, x: np.ndarray, n: int, start: float) -> np.ndarray:
    """``x`` resampled on ``n`` equal angle steps per revolution of a shaft at angles ``theta`` (rad), from
    angle ``start`` over the whole revolutions recorded after it: shape (revolutions, n)."""
    n_rev = max(int((theta[-1] - start) // (2 * math.pi)), 0)
    grid = start + np.arange(n * n_rev) * 2 * math.pi / n
    return np.interp(grid, theta, x).reshape(n_rev, n)


def impulsiveness(run: RunData, te: np.ndarray) -> dict:
    """Crest factor of the per-revolution synchronous average of ``te`` for each shaft (None if < 1 rev)."""
    out = {}
    for shaft, th in (("input", run.theta_in_rad), ("output", run.theta_out_rad)):
        revs = _revolutions(th, te, 256, th[0])
        if revs.shape[0] < 1:
            out[shaft] = None
            continue
        avg = revs.mean(axis=0)
        avg = avg - avg.mean()
        r = float(np.sqrt(np.mean(avg**2)))
        out[shaft] = float(np.max(np.abs(avg)) / r) if r > 0 else None
    return out


def dependence(runs: list[RunData], tables: list[list[dict]], labels=("1x f_in", "1x f_out", "1xGMF")) -> list[dict]:
    """Amplitude of key residual lines against speed and load across runs."""
    out = []
    for lab in labels:
        vals = [(r.rpm_in, r.torque_out_Nm, next(x["before_um"] for x in t if lab in x["names"]))
                for r, t in zip(runs, tables)]
        a = [v[2] for v in vals]
        trend = "constant"
        if len(vals) > 1 and max(a) > 1.5 * max(min(a), 1e-12):
            k = int(np.argmax(a))
            trend = f"varies (largest at {vals[k][0]:.0f} rpm, {vals[k][1]:.0f} N m)"
        out.append({"line": lab, "runs": [{"rpm_in": v[0], "torque_out_Nm": v[1], "amplitude_um": v[2]} for v in vals],
                    "trend": trend})
    return out


#: bins of the synchronous average per tooth pitch (:func:`tooth_local_pulses`)
PULSE_BINS_PER_PITCH = 16
#: a tooth-local pulse: the window of ``ceil(eps_gamma) + 1`` pitches around it holds at least this share of the
#: synchronous average's energy (white noise puts ``(ceil(eps_gamma) + 1) / z`` of it there) ...
PULSE_CONCENTRATION = 0.5
#: ... and its rms over the window is at least this many times the standard error of the average
PULSE_SNR = 4.0


def _shaft_average(theta: np.ndarray, x: np.ndarray, z: int) -> tuple[np.ndarray, float] | None:
    """Synchronous average of ``x`` over the whole revolutions of a shaft at angles ``theta`` (rad, from the
    record's angle zero), on :data:`PULSE_BINS_PER_PITCH` bins per pitch of its ``z`` teeth, with its
    tooth-periodic part (the mesh orders) and mean removed; and the standard error of one bin (m, from the
    scatter across revolutions). None with fewer than 3 revolutions."""
    revs = _revolutions(theta, x, PULSE_BINS_PER_PITCH * z, 2 * math.pi * math.ceil(theta[0] / (2 * math.pi)))
    n_rev = revs.shape[0]
    if n_rev < 3:
        return None
    avg = revs.mean(axis=0)
    avg = avg - np.tile(avg.reshape(z, PULSE_BINS_PER_PITCH).mean(axis=0), z)
    se = float(np.sqrt(np.mean(revs.var(axis=0, ddof=1)) / n_rev))
    return avg - avg.mean(), se


def tooth_local_pulses(runs: list[RunData], residuals: list[np.ndarray], eps_gamma: float) -> list[dict]:
    """Pulses at one tooth of either gear in the residuals of ``runs`` (one array per run, m).

    For each shaft and run: the synchronous average over the shaft's revolutions without its
    tooth-periodic part; the window of ``ceil(eps_gamma) + 1`` pitches with the most energy (a tooth is in
    mesh over ``eps_gamma`` pitches); a pulse when the window holds :data:`PULSE_CONCENTRATION` of the
    energy and its rms exceeds :data:`PULSE_SNR` standard errors. ``tooth_index`` counts teeth from the
    shaft's angle zero and names the tooth that enters mesh ``eps_gamma / 2`` pitches before the window's
    centre (the convention of the ``pitch_error`` effect); ``orders`` are the three largest shaft orders
    of the average (amplitude, um). One item per shaft seen in at least one run.
    """
    out = []
    width = math.ceil(eps_gamma) + 1
    for shaft, z_of, th_of in (("input", lambda r: r.mesh.z1, lambda r: r.theta_in_rad),
                               ("output", lambda r: r.mesh.z2, lambda r: r.theta_out_rad)):
        seen = []
        for run, x in zip(runs, residuals):
            z = z_of(run)
            sa = None if z <= width else _shaft_average(th_of(run), x, z)
            if sa is None:
                continue
            avg, se = sa
            w = width * PULSE_BINS_PER_PITCH
            e2 = np.concatenate([avg, avg[:w]]) ** 2
            win = np.convolve(e2, np.ones(w), "valid")[:avg.size]
            k = int(np.argmax(win))
            share = float(win[k] / max(np.sum(avg ** 2), 1e-300))
            rms_win = math.sqrt(win[k] / w)
            if share < PULSE_CONCENTRATION or rms_win < PULSE_SNR * se:
                continue
            i = k + np.arange(w)                                       # the window's bins, energy centroid
            centre = float(np.sum(i * e2[i]) / np.sum(e2[i])) / PULSE_BINS_PER_PITCH   # pitches from the angle zero
            spec = 2 * np.abs(np.fft.rfft(avg)) / avg.size
            top = np.argsort(spec[1:])[::-1][:3] + 1
            seen.append({"run": run.name, "tooth_index": int(round(centre - eps_gamma / 2)) % z,
                         "centre_deg": float(centre * 360.0 / z % 360.0), "rms_um": rms_win / UM,
                         "peak_to_peak_um": float(np.ptp(avg)) / UM, "energy_share": share,
                         "standard_error_um": se / UM,
                         "orders": [{"order": int(q), "amplitude_um": float(spec[q]) / UM} for q in top]})
        if seen:
            best = max(seen, key=lambda s: s["rms_um"])
            out.append({"kind": "tooth_local_pulse", "shaft": shaft, "gear": f"{shaft}_gear", "z": z_of(runs[0]),
                        "tooth_index": best["tooth_index"], "amplitude_um": best["peak_to_peak_um"],
                        "frequency_hz": None, "order": None, "order_out": None,
                        "integer_order": f"{shaft} order 1 pulse train", "runs_seen": len(seen), "per_run": seen})
    return out
