"""Side-by-side benchmark of fleetdyn and the Python peers users would otherwise reach for,
in one run: the same inputs through the peer and through fleetdyn, outputs checked to
agree within stated tolerances, times as medians over repeats, and each stage's physical floor
(the time to only move the same bytes), timed by fleetdyn's side on the same data.

Run through benches/peers/run.sh, which makes the venv and builds fleetdyn's side. Options:
  --n N             samples of the 1-D kernels (default 10_000_000)
  --repeats R       repeats per measurement (default 5; the median is reported)
  --driveline-s T   simulated seconds of the driveline comparison (default 20)
  --only S,S        sections to run (kernels, driveline, ingest, parquet, nightly, diagnose)
  --markdown F      also write the table as Markdown to F

Sections, what is compared, and the tolerance of "outputs agree":
  kernels    scipy.signal.sosfiltfilt(butter(3, 0.004, output='sos'), x) with scipy's default
             edges vs fleetdyn EdgeMode::Scipy: max |Δ| ≤ 1e-9 · max |y| (the same recursions
             in double precision; measured ~1e-13). scipy.signal.welch(x, fs=1, nperseg=4096)
             vs fleetdyn welch: max relative |Δ| ≤ 1e-9 per bin above 1e-12 of the peak (FFT
             round-off differs between pocketfft and realfft). Floors: copy (16 B/sample) for
             the filter, read (8 B/sample) for the PSD.
  driveline  The locked-clutch driveline of docs/models/driveline.md (truck-40t, gear 12,
             prescribed engine torque and road slope sampled at 100 Hz, linear between samples;
             peer_side.rs documents the input) — scipy.integrate.solve_ivp (Radau, LSODA; the
             right-hand side written in plain Python floats, no Jacobian: what a user writes)
             against fleetdyn's accurate Dormand–Prince (rtol 1e-8) and exponential (dt 10 ms)
             integrators.
             Accuracy: max |Δv| and max |Δω_e| on the 100 Hz grid against a reference, solve_ivp
             Radau at rtol 1e-12 (cross-checked against fleetdyn's accurate integrator at 1e-12;
             their difference δ is the resolution of every error below). Matched accuracy: for
             each fleetdyn integrator and each peer method, the loosest rtol of the ladder
             1e-3 … 1e-11 whose errors in both v and ω_e are at most fleetdyn's (or δ, if larger);
             the peer is timed at that rtol; if none does, the peer at 1e-11 is timed and
             marked "not matched" (less accurate than fleetdyn: its speed-up a lower bound). "Outputs agree": fleetdyn's errors within 1e-6 m/s
             and 1e-4 rad/s (accurate) or 1e-3 m/s and 0.05 rad/s (exponential, inputs held
             over each step). Floor: moving the inputs and the trajectory once.
             Also one drive-hour of the same input through fleetdyn alone: the real-time factor.
  ingest     The bench drive-hour (benches/common/hour_drive.rs: 65 km, 6x2 truck, the 14
             multi-rate JSON topics of a J1939 logger as MCAP, dropouts) read with the Python
             `mcap` reader, messages decoded with json, one pandas frame per topic, units
             converted per the topic mapping (schemas/mappings/j1939-json-mcap.toml) and aligned
             by pandas onto fleetdyn's time base rule (src/ingest/align.rs: fastest median period
             rounded to 0.1 ms, span of the required channel, linear or hold per the schema, no
             bridging of gaps > 2.5 periods) — against `fleetdyn` ingest of the same file.
             Agreement: the same grid, the same missing cells, values within 1e-12 of each
             column's range. Floor: reading the file's bytes.
  parquet    The drive-hour's canonical Parquet (15 columns, 163 k rows): pyarrow.parquet
             read_table (use_threads=False: one thread each side) vs fleetdyn's reader (ingest of canonical Parquet: decode, unit and
             range checks), and pyarrow write_table (zstd level 3, to a temporary file, fsync, rename — the
             same durable write) vs fleetdyn's writer (zstd
             level 3, unit metadata, fsync + atomic rename); fleetdyn's decode alone (arrow-rs
             record batches, no checks) as a row of its own. Agreement: every value equal
             (missing cells alike) when both sides' outputs are read back. Floor: reading the
             file's bytes plus copying the decoded columns once (read); copying the columns once
             (write).
  nightly    pipelines/nightly.toml on the five bundled fixture drives, one worker — fleetdyn
             only (no peer does this stage); floor: reading the inputs and re-writing the same
             Parquet tables with the same writer settings (benches/common/pipeline_io.rs).
  diagnose   `fleetdyn diagnose` of the drive-hour on all cores — fleetdyn only; floor: the
             Parquet read of its input plus the write of one drive log.
"""
import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np
import scipy
from scipy import signal
from scipy.integrate import solve_ivp

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SECTIONS = ("kernels", "driveline", "ingest", "parquet", "nightly", "diagnose")


def median_time(fn, repeats):
    runs = []
    out = None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        runs.append(time.perf_counter() - t)
    return sorted(runs)[len(runs) // 2], out


def fleetdyn(exe, op, repeats, *args):
    r = subprocess.run(
        [exe, op, str(repeats), *map(str, args)], check=True, capture_output=True, text=True
    )
    return json.loads(r.stdout.strip().splitlines()[-1])


def read_f64(path):
    return np.fromfile(path, dtype="<f8")


def row(stage, peer, peer_s, fd_s, floor, floor_s, agreement, ok):
    return dict(stage=stage, peer=peer, peer_s=peer_s, fleetdyn_s=fd_s, floor=floor,
                floor_s=floor_s, agreement=agreement, ok=ok)


# ---------------------------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------------------------
def trace(n):
    """A slope-like trace on a 1 m grid: two slow hills, whole-percent steps, seeded noise."""
    x = np.arange(n, dtype=float)
    s = 0.03 * np.sin(x / 900.0) + 0.015 * np.sin(x / 230.0 + 1.0)
    s = np.round(s * 100.0) / 100.0
    rng = np.random.default_rng(8)
    return s + 0.002 * rng.standard_normal(n)


def kernels(a, d):
    rows = []
    x = trace(a.n)
    inp = os.path.join(d, "x.f64")
    x.astype("<f8").tofile(inp)
    out = os.path.join(d, "y.f64")
    floors = {op: fleetdyn(a.fleetdyn, op, a.repeats, inp, out)["median_s"]
              for op in ("floor_copy", "floor_sum")}

    sos = signal.butter(3, 4e-3, output="sos", fs=1.0)
    t_py, y_py = median_time(lambda: signal.sosfiltfilt(sos, x), a.repeats)
    r = fleetdyn(a.fleetdyn, "sosfiltfilt", a.repeats, inp, out)
    y_fd = read_f64(out)
    diff = float(np.max(np.abs(y_fd - y_py)))
    scale = float(np.max(np.abs(y_py)))
    rows.append(row(f"sosfiltfilt, {a.n:.0e} samples", "scipy.signal.sosfiltfilt", t_py,
                    r["median_s"], "copy (16 B/sample)", floors["floor_copy"],
                    f"max abs Δ = {diff:.1e} ({diff / scale:.1e} of max abs y)",
                    diff <= 1e-9 * scale))

    t_py, (_, p_py) = median_time(lambda: signal.welch(x, fs=1.0, nperseg=4096), a.repeats)
    r = fleetdyn(a.fleetdyn, "welch", a.repeats, inp, out)
    p_fd = read_f64(out)
    mask = p_py > 1e-12 * p_py.max()
    rel = (float(np.max(np.abs(p_fd[mask] - p_py[mask]) / p_py[mask]))
           if len(p_fd) == len(p_py) else float("inf"))
    rows.append(row(f"welch, nperseg 4096, {a.n:.0e} samples", "scipy.signal.welch", t_py,
                    r["median_s"], "read (8 B/sample)", floors["floor_sum"],
                    f"max relative Δ = {rel:.1e} over {int(mask.sum())} bins", rel <= 1e-9))
    return rows, []


# ---------------------------------------------------------------------------------------------
# driveline
# ---------------------------------------------------------------------------------------------
FS_HZ, GEAR, V0_MPS = 100.0, 12, 22.0
# Characteristic size of each locked state (w_e, phi_c, w_p, phi_p, w_d, phi_d, w_w), as
# fleetdyn's STATE_SCALE: atol_i = rtol * scale_i on both sides.
LOCKED_SCALE = np.array([100.0, 0.01, 10.0, 0.01, 10.0, 0.01, 10.0])
# The ladder stops one decade short of the reference's rtol (1e-12): a peer at the reference's
# own setting would match it trivially.
RTOL_LADDER = [10.0 ** -k for k in range(3, 12)]


def driveline_input(t_end_s):
    """Engine-torque variation about the steady torque (a 20 s swell, 7 s load changes with
    0.1 s edges, 12.5 N·m quantisation noise) and a ±1 % road, sampled at 100 Hz."""
    n = int(round(t_end_s * FS_HZ))
    t = np.arange(n + 1) / FS_HZ
    rng = np.random.default_rng(3)
    dm = (300.0 * np.sin(2 * np.pi * t / 20.0)
          + 250.0 * np.tanh(5.0 * np.sin(2 * np.pi * t / 7.0))
          + np.round(rng.standard_normal(n + 1) * 3.0 / 12.5) * 12.5)
    slope = 0.01 * np.sin(2 * np.pi * t / 45.0 + 0.3)
    return n, np.concatenate([[FS_HZ, GEAR, V0_MPS, n], dm, slope]).astype("<f8")


class LockedDriveline:
    """The driveline of docs/models/driveline.md with the clutch locked and a prescribed engine
    torque, as a user would write it for solve_ivp (plain floats; inputs linear between the 100 Hz
    samples)."""

    def __init__(self, m_e, slope):
        with open(os.path.join(ROOT, "fixtures/vehicles/truck-40t.toml"), "rb") as f:
            doc = tomllib.load(f)
        d = doc["driveline"]
        self.it = doc["gearbox"]["ratios"][GEAR - 1]
        self.i_f, self.r_w = d["final_drive_ratio"], d["wheel_radius_m"]
        self.J1 = d["j_e_kg_m2"] + d["j_c_kg_m2"]
        self.J2 = d["j_t_kg_m2"][GEAR - 1] + d["j_p_kg_m2"]
        self.J3 = d["j_f_kg_m2"] + d["j_d_kg_m2"]
        self.m = d["mass_kg"]
        self.J4 = self.m * self.r_w ** 2 + d["j_w_kg_m2"]
        (self.c_c, self.k_c, self.b_t, self.c_p, self.k_p, self.b_f, self.c_d, self.k_d) = (
            d[k] for k in ("c_c_nm_s_per_rad", "k_c_nm_per_rad", "b_t_nm_s_per_rad",
                           "c_p_nm_s_per_rad", "k_p_nm_per_rad", "b_f_nm_s_per_rad",
                           "c_d_nm_s_per_rad", "k_d_nm_per_rad"))
        (self.rho, self.cwA, self.cr1, self.cr2, self.csr, self.g) = (
            d[k] for k in ("rho_air_kg_per_m3", "c_w_a_f_m2", "c_r1", "c_r2_s_per_m",
                           "c_sr_s2_per_m2", "gravity_m_per_s2"))
        self.m_e, self.slope = list(m_e), list(slope)
        self.n = len(m_e) - 1

    def rhs(self, t, y):
        k = min(int(t * FS_HZ), self.n - 1)
        fr = t * FS_HZ - k
        me, sl = self.m_e, self.slope
        M_e = me[k] + (me[k + 1] - me[k]) * fr
        s = sl[k] + (sl[k + 1] - sl[k]) * fr
        w_e, p_c, w_p, p_p, w_d, p_d, w_w = y
        M_c = self.c_c * (w_e - self.it * w_p) + self.k_c * p_c
        M_p = self.c_p * (w_p - self.i_f * w_d) + self.k_p * p_p
        M_d = self.c_d * (w_d - w_w) + self.k_d * p_d
        v = self.r_w * w_w
        f = 1.0 - math.exp(-self.csr * v * v)
        F = f * (self.cr1 + self.cr2 * abs(v)) * self.m * self.g + 0.5 * self.rho * self.cwA * v * v
        sgn = 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)
        F = sgn * F + self.m * self.g * math.sin(math.atan(s))
        return [
            (M_e - M_c) / self.J1,
            w_e - self.it * w_p,
            (self.it * M_c - self.b_t * w_p - M_p) / self.J2,
            w_p - self.i_f * w_d,
            (self.i_f * M_p - self.b_f * w_d - M_d) / self.J3,
            w_d - w_w,
            (M_d - self.r_w * F) / self.J4,
        ]


def driveline(a, d):
    rows, notes = [], []
    n, x = driveline_input(a.driveline_s)
    inp = os.path.join(d, "drv_in.f64")
    x.tofile(inp)

    def fd(op, tol=None):
        out = os.path.join(d, f"drv_{op}.f64")
        r = fleetdyn(a.fleetdyn, op, a.repeats, inp, out, *([tol] if tol else []))
        o = read_f64(out)
        y0, m_e = o[:9], o[9:10 + n]
        v, w_e = o[10 + n:11 + 2 * n], o[11 + 2 * n:]
        return r, y0, m_e, v, w_e

    acc, y0, m_e, v_acc, w_acc = fd("driveline_accurate", 1e-8)
    fast, _, _, v_fast, w_fast = fd("driveline_fast")
    _, _, _, v_12, w_12 = fd("driveline_accurate", 1e-12)
    model = LockedDriveline(m_e, x[4 + n + 1:])
    t_grid = np.arange(n + 1) / FS_HZ
    y_locked = [y0[0], y0[2], y0[3], y0[4], y0[5], y0[6], y0[7]]  # w_c = w_e, no PI state

    def peer(method, rtol):
        t = time.perf_counter()
        sol = solve_ivp(model.rhs, (0.0, t_grid[-1]), y_locked, method=method, rtol=rtol,
                        atol=rtol * LOCKED_SCALE, t_eval=t_grid)
        el = time.perf_counter() - t
        if not sol.success or sol.y.shape[1] != n + 1:
            raise RuntimeError(f"solve_ivp {method} rtol {rtol}: {sol.message}")
        nfev[(method, rtol)] = sol.nfev
        return el, model.r_w * sol.y[6], sol.y[0]

    nfev = {}
    t_ref, v_ref, w_ref = peer("Radau", 1e-12)
    err = lambda v, w: (float(np.max(np.abs(v - v_ref))), float(np.max(np.abs(w - w_ref))))
    delta = err(v_12, w_12)
    notes.append(
        f"driveline reference: solve_ivp Radau rtol 1e-12 ({t_ref:.1f} s for {a.driveline_s:g} s "
        f"simulated) and fleetdyn's accurate integrator at 1e-12 differ by δ = "
        f"{delta[0]:.1e} m/s, {delta[1]:.1e} rad/s")
    # fleetdyn's own error bounds ("outputs agree"): the accurate integrator within 1e-6 m/s
    # and 1e-4 rad/s of the reference; the exponential one (inputs held over each 10 ms step)
    # within 1e-3 m/s and 0.05 rad/s (0.5 rpm, half the CAN resolution of engine speed).
    for name, r, v, w, bound in (
            ("accurate Dormand–Prince rtol 1e-8", acc, v_acc, w_acc, (1e-6, 1e-4)),
            ("exponential dt 10 ms", fast, v_fast, w_fast, (1e-3, 0.05))):
        e_fd = err(v, w)
        target = (max(e_fd[0], delta[0]), max(e_fd[1], delta[1]))
        for method in ("Radau", "LSODA"):
            matched, first = None, None
            for rtol in RTOL_LADDER:
                el, pv, pw = peer(method, rtol)
                e_py = err(pv, pw)
                if e_py[0] <= target[0] and e_py[1] <= target[1]:
                    matched, first = rtol, (el, e_py)
                    break
            if matched is None:
                rtol, first = RTOL_LADDER[-1], (el, e_py)
            times = [first[0]] + [peer(method, rtol)[0] for _ in range(max(a.repeats, 1) - 1)]
            t_py = sorted(times)[len(times) // 2]
            e_py = first[1]
            if r["rhs_evals"]:
                notes.append(
                    f"profile, driveline {name} vs {method} rtol {rtol:.0e}: fleetdyn "
                    f"{r['rhs_evals']:,} right-hand-side evaluations in {r['steps']:,} steps, "
                    f"{1e9 * r['median_s'] / r['rhs_evals']:.0f} ns each; peer "
                    f"{nfev[(method, rtol)]:,} evaluations, "
                    f"{1e6 * t_py / nfev[(method, rtol)]:.1f} µs each (Jacobian and linear "
                    f"algebra included)")
            rows.append(row(
                f"driveline {name}, {a.driveline_s:g} s simulated",
                f"solve_ivp {method} rtol {rtol:.0e}" + ("" if matched else " (not matched)"),
                t_py, r["median_s"], "move inputs + trajectory", r["floor_median_s"],
                f"max error v / ω_e: fleetdyn {e_fd[0]:.1e} m/s / {e_fd[1]:.1e} rad/s, "
                f"peer {e_py[0]:.1e} / {e_py[1]:.1e}",
                e_fd[0] <= bound[0] and e_fd[1] <= bound[1]))
    # one drive-hour through fleetdyn alone: real-time factors
    n_h, x_h = driveline_input(3600.0)
    inp_h = os.path.join(d, "drv_hour.f64")
    x_h.tofile(inp_h)
    for op, label in (("driveline_fast", "exponential dt 10 ms"),
                      ("driveline_accurate", "accurate rtol 1e-8")):
        r = fleetdyn(a.fleetdyn, op, 3, inp_h, os.path.join(d, "drv_hour_out.f64"))
        notes.append(f"driveline {label}, one drive-hour (360 000 input samples): "
                     f"{r['median_s']:.3f} s = {3600.0 / r['median_s']:,.0f}× real time "
                     f"({r['steps']} steps)")
    return rows, notes


# ---------------------------------------------------------------------------------------------
# ingest: python mcap + pandas
# ---------------------------------------------------------------------------------------------
SI_FACTOR = {"km/h": 1.0 / 3.6, "rpm": math.pi / 30.0, "kPa": 1e3, "kN": 1e3, "1": 1.0,
             "deg": 1.0, "m": 1.0, "m/s": 1.0}


def mcap_pandas(path, mapping, schema):
    import pandas as pd
    from mcap.reader import make_reader

    by_topic = {}
    for sig, m in mapping["signals"].items():
        by_topic.setdefault(m["topic"], []).append((sig, m))
    records = {t: ([], []) for t in by_topic}
    with open(path, "rb") as f:
        for _, ch, msg in make_reader(f).iter_messages(topics=list(by_topic)):
            ts, vals = records[ch.topic]
            ts.append(msg.log_time)
            vals.append(json.loads(msg.data))
    series = {}
    for topic, (ts, vals) in records.items():
        df = pd.DataFrame(vals, index=pd.Index(ts, name="t_ns"))
        for sig, m in by_topic[topic]:
            if m["field"] not in df:
                continue
            unit = m["unit"]
            if unit == "%":
                f = m["reference_torque_nm"] / 100.0 if "reference_torque_nm" in m else 0.01
            else:
                f = SI_FACTOR[unit]
            series[sig] = df[m["field"]].astype(float) * f
    # alignment (src/ingest/align.rs)
    med = {k: int(np.sort(np.diff(s.index.values))[(len(s) - 1) // 2])
           for k, s in series.items() if len(s) > 1}
    fastest = min(p for p in med.values() if p > 0)
    period = max((fastest + 50_000) // 100_000, 1) * 100_000
    req = series["vehicle_speed"]
    start, end = int(req.index[0]), int(req.index[-1])
    grid = pd.Index(start + period * np.arange((end - start) // period + 1), name="t_ns")
    out = {}
    for k, s in series.items():
        t = pd.Series(s.index.values, index=s.index)
        prev, nxt = t.reindex(grid, method="ffill"), t.reindex(grid, method="bfill")
        if schema[k]["interpolation"] == "hold":
            v = s.reindex(grid, method="ffill")
        else:
            # relative times: ns since the epoch (~1.7e18) lose 256 ns in a float64 index
            rel = pd.Series(s.values, index=s.index - start)
            g = grid - start
            v = rel.reindex(rel.index.union(g)).interpolate(method="index", limit_area="inside")
            v = v.reindex(g)
            v.index = grid
        gap = ((nxt - prev) > int(med[k] * 2.5)).values & (grid.values != prev.values)
        v[(grid < s.index[0]) | (grid > s.index[-1]) | gap] = np.nan
        out[k] = v
    return pd.DataFrame(out, index=grid)


def hour_drive(a, d):
    if getattr(a, "_hour", None) is None:
        a._hour = fleetdyn(a.fleetdyn, "hour_drive", 1, os.path.join(d, "hour"))
    return a._hour


def compare_tables(ref, t_ns, cols):
    """Same grid, same missing cells, values within 1e-12 of each column's range."""
    import pyarrow as pa
    if not np.array_equal(ref.column("timestamp").cast(pa.int64()).to_numpy(), t_ns):
        return False, "time grids differ"
    worst, name = 0.0, ""
    for c, b in cols.items():
        a_ = ref.column(c).to_numpy(zero_copy_only=False).astype(float)
        if not np.array_equal(np.isnan(a_), np.isnan(b)):
            return False, f"{c}: missing cells differ"
        m = ~np.isnan(a_)
        if m.any():
            e = float(np.max(np.abs(a_[m] - b[m]))) / max(float(np.ptp(a_[m])), 1e-300)
            if e > worst:
                worst, name = e, c
    return worst <= 1e-12, f"{len(cols)} columns, same grid and gaps; worst {worst:.0e} of range ({name})"


def ingest(a, d):
    import pyarrow.parquet as pq
    h = hour_drive(a, d)
    with open(os.path.join(ROOT, "schemas/mappings/j1939-json-mcap.toml"), "rb") as f:
        mapping = tomllib.load(f)
    with open(os.path.join(ROOT, "schemas/drive-log.toml"), "rb") as f:
        schema = {c["name"]: c for c in tomllib.load(f)["columns"]}
    out = os.path.join(d, "fd_ingest.parquet")
    r = fleetdyn(a.fleetdyn, "ingest", a.repeats, h["mcap"], out)
    floor = fleetdyn(a.fleetdyn, "read_file", a.repeats, h["mcap"])["median_s"]
    t_py, df = median_time(lambda: mcap_pandas(h["mcap"], mapping, schema), a.repeats)
    ok, agree = compare_tables(pq.read_table(out), df.index.values,
                               {c: df[c].values for c in df.columns})
    mb = os.path.getsize(h["mcap"]) / 1e6
    return [row(f"MCAP ingest, drive-hour ({h['duration_s'] / 3600:.2f} h, {mb:.0f} MB, 14 topics)",
                "mcap reader + json + pandas", t_py, r["median_s"], "read the file", floor,
                agree, ok)], []


def parquet(a, d):
    import pyarrow as pa
    import pyarrow.parquet as pq
    h = hour_drive(a, d)
    src = h["parquet"]
    fd_out = os.path.join(d, "fd_rw.parquet")
    py_out = os.path.join(d, "py_rw.parquet")
    r_read = fleetdyn(a.fleetdyn, "ingest", a.repeats, src, fd_out)
    r_write = fleetdyn(a.fleetdyn, "parquet_write", a.repeats, src, fd_out)
    r_decode = fleetdyn(a.fleetdyn, "parquet_decode", a.repeats, src)
    f_read = fleetdyn(a.fleetdyn, "read_file", a.repeats, src)["median_s"]
    f_copy = fleetdyn(a.fleetdyn, "memcpy", a.repeats, src)["median_s"]
    t_read, table = median_time(lambda: pq.read_table(src, use_threads=False), a.repeats)
    def durable_write():
        # the same work as fleetdyn's writer: a temporary file, fsync, rename
        tmp = py_out + ".tmp"
        pq.write_table(table, tmp, compression="zstd", compression_level=3)
        fd_ = os.open(tmp, os.O_RDONLY)
        os.fsync(fd_)
        os.close(fd_)
        os.replace(tmp, py_out)

    t_write, _ = median_time(durable_write, a.repeats)
    back_fd, back_py = pq.read_table(fd_out), pq.read_table(py_out)
    t_ns = table.column("timestamp").cast(pa.int64()).to_numpy()
    cols = [c for c in table.column_names if c != "timestamp"]
    ok_r, agree_r = compare_tables(back_fd, t_ns, {
        c: table.column(c).to_numpy(zero_copy_only=False).astype(float) for c in cols})
    ok_w, agree_w = compare_tables(back_py, t_ns, {
        c: back_fd.column(c).to_numpy(zero_copy_only=False).astype(float) for c in cols})
    label = f"drive-hour, {table.num_rows} rows × {table.num_columns} columns"
    return [
        row(f"Parquet read, {label}", "pyarrow.parquet.read_table", t_read,
            r_read["median_s"], "read the file + copy the columns", f_read + f_copy, agree_r,
            ok_r),
        row(f"Parquet decode only (arrow-rs record batches), {label}",
            "pyarrow.parquet.read_table", t_read, r_decode["median_s"],
            "read the file + copy the columns", f_read + f_copy,
            f"{r_decode['n']} rows decoded (the rest of fleetdyn's read: unit, time-order, "
            f"range and gap checks, SI conversion)", r_decode["n"] == table.num_rows),
        row(f"Parquet write (zstd 3, fsync, rename), {label}",
            "pyarrow.parquet.write_table + fsync + rename", t_write,
            r_write["median_s"], "copy the columns", f_copy,
            "both files read back equal: " + agree_w, ok_w),
    ], []


def nightly(a, d):
    r = fleetdyn(a.fleetdyn, "nightly", a.repeats)
    h = r["drive_hours"]
    return [row(f"nightly pipeline, 5 fixture drives ({h:.2f} drive-hours), one worker",
                "— (no peer)", None, r["median_s"], "read inputs + re-write the same Parquet",
                r["floor_median_s"],
                f"{h / (r['median_s'] / 3600):,.0f} drive-hours per core-hour", True)], []


def diagnose(a, d):
    h = hour_drive(a, d)
    r = fleetdyn(a.fleetdyn, "diagnose", min(a.repeats, 3), h["parquet"], h["vehicle"],
                 os.path.join(d, "diag"))
    f_read = fleetdyn(a.fleetdyn, "ingest", a.repeats, h["parquet"],
                      os.path.join(d, "diag_floor.parquet"))["median_s"]
    f_write = fleetdyn(a.fleetdyn, "parquet_write", a.repeats, h["parquet"],
                       os.path.join(d, "diag_floor.parquet"))["median_s"]
    hours = r["drive_hours"]
    return [row(f"diagnosis, drive-hour ({hours:.2f} h), {r['threads']} threads",
                "— (no peer)", None, r["median_s"], "Parquet read + write of the drive",
                f_read + f_write,
                f"{r['median_s'] / hours:.1f} s per drive-hour; verdict {r['verdict']}",
                True)], []


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--fleetdyn", required=True, help="path of the peer_side binary")
    ap.add_argument("--n", type=int, default=10_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--driveline-s", type=float, default=20.0)
    ap.add_argument("--only", default=",".join(SECTIONS))
    ap.add_argument("--markdown")
    a = ap.parse_args()
    only = a.only.split(",")
    unknown = [s for s in only if s not in SECTIONS]
    if unknown:
        ap.error(f"unknown sections {unknown}; known: {', '.join(SECTIONS)}")
    rows, notes = [], []
    with tempfile.TemporaryDirectory() as d:
        for s in SECTIONS:
            if s in only:
                t = time.perf_counter()
                r, n = globals()[s](a, d)
                rows += r
                notes += n
                print(f"[{s}: {time.perf_counter() - t:.0f} s]", file=sys.stderr, flush=True)

    import pandas
    import pyarrow
    import mcap
    head = (
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"pandas {pandas.__version__}, pyarrow {pyarrow.__version__}, mcap {mcap.__version__}; "
        f"medians of {a.repeats} runs; one thread each side except the diagnosis"
    )
    lines = [
        head,
        "",
        "| stage | peer | peer [s] | fleetdyn [s] | speed-up | floor | floor [s] | fleetdyn / floor | outputs agree |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        peer_s = "—" if r["peer_s"] is None else f"{r['peer_s']:.4g}"
        speed = "—" if r["peer_s"] is None else f"{r['peer_s'] / r['fleetdyn_s']:,.1f}×"
        lines.append(
            f"| {r['stage']} | {r['peer']} | {peer_s} | {r['fleetdyn_s']:.4g} | {speed} | "
            f"{r['floor']} | {r['floor_s']:.3g} | {r['fleetdyn_s'] / r['floor_s']:,.1f}× | "
            f"{'yes' if r['ok'] else 'NO'}: {r['agreement']} |"
        )
    if notes:
        lines.append("")
        lines += [f"- {n}" for n in notes]
    text = "\n".join(lines)
    print(text)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(text + "\n")
    if not all(r["ok"] for r in rows):
        print("outputs disagree beyond the stated tolerance",
              file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
