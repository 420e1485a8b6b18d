"""Side-by-side benchmark of fleetdyn and the Python peers users would otherwise reach for
(issue 8), in one run: the same inputs through scipy and through fleetdyn, outputs checked to
agree within stated tolerances, times as medians over repeats, and each stage's physical floor
(the time to only move the same bytes).

Run through benches/peers/run.sh, which makes the venv and builds fleetdyn's side. Options:
  --n N          samples of the 1-D kernels (default 10_000_000)
  --repeats R    repeats per measurement (default 5; the median is reported)
  --markdown F   also write the table as Markdown to F

Kernels so far (the rest of issue 8's list follows in later sessions):
  sosfiltfilt  scipy.signal.sosfiltfilt(butter(3, 0.004, output='sos'), x), scipy's default
               edges; fleetdyn EdgeMode::Scipy. Tolerance: max |Δ| ≤ 1e-9 · max |y| (both
               run the same recursions in double precision; measured differences are ~1e-15).
  welch        scipy.signal.welch(x, fs=1, nperseg=4096) (Hann, 50 % overlap, density,
               constant detrend); fleetdyn welch (also computes the χ² interval). Tolerance:
               max relative |Δ| ≤ 1e-9 per bin with PSD above 1e-12 of the peak (FFT
               round-off differs between pocketfft and realfft).
Floors: floor_copy (read every sample, write it once: 16 bytes per sample) for sosfiltfilt,
floor_sum (read every sample once: 8 bytes per sample) for welch — both timed by fleetdyn's
side on the same buffer.

The input: a slope-like trace on a 1 m grid (two slow hills, whole-percent quantisation) with
seeded Gaussian noise, so the filter and the PSD see realistic content.
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy
from scipy import signal


def trace(n):
    x = np.arange(n, dtype=float)
    s = 0.03 * np.sin(x / 900.0) + 0.015 * np.sin(x / 230.0 + 1.0)
    s = np.round(s * 100.0) / 100.0
    rng = np.random.default_rng(8)
    return s + 0.002 * rng.standard_normal(n)


def median_time(fn, repeats):
    runs = []
    out = None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        runs.append(time.perf_counter() - t)
    return sorted(runs)[len(runs) // 2], runs, out


def fleetdyn(exe, op, inp, out, repeats):
    r = subprocess.run([exe, op, inp, out, str(repeats)], check=True, capture_output=True, text=True)
    return json.loads(r.stdout.strip().splitlines()[-1])


def read_f64(path):
    return np.fromfile(path, dtype="<f8")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--fleetdyn", required=True, help="path of the peer_side binary")
    ap.add_argument("--n", type=int, default=10_000_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--markdown")
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        x = trace(a.n)
        inp = os.path.join(d, "x.f64")
        x.astype("<f8").tofile(inp)
        out = os.path.join(d, "y.f64")
        floors = {
            op: fleetdyn(a.fleetdyn, op, inp, out, a.repeats)["median_s"]
            for op in ("floor_copy", "floor_sum")
        }

        # sosfiltfilt
        sos = signal.butter(3, 4e-3, output="sos", fs=1.0)
        t_py, _, y_py = median_time(lambda: signal.sosfiltfilt(sos, x), a.repeats)
        r = fleetdyn(a.fleetdyn, "sosfiltfilt", inp, out, a.repeats)
        y_fd = read_f64(out)
        diff = float(np.max(np.abs(y_fd - y_py)))
        scale = float(np.max(np.abs(y_py)))
        rows.append(
            dict(
                stage=f"sosfiltfilt, {a.n:.0e} samples",
                peer="scipy.signal.sosfiltfilt",
                peer_s=t_py,
                fleetdyn_s=r["median_s"],
                floor="copy (16 B/sample)",
                floor_s=floors["floor_copy"],
                agreement=f"max abs Δ = {diff:.1e} ({diff / scale:.1e} of max abs y)",
                ok=diff <= 1e-9 * scale,
            )
        )

        # welch
        t_py, _, (f_py, p_py) = median_time(
            lambda: signal.welch(x, fs=1.0, nperseg=4096), a.repeats
        )
        r = fleetdyn(a.fleetdyn, "welch", inp, out, a.repeats)
        p_fd = read_f64(out)
        mask = p_py > 1e-12 * p_py.max()
        rel = float(np.max(np.abs(p_fd[mask] - p_py[mask]) / p_py[mask])) if len(p_fd) == len(p_py) else float("inf")
        rows.append(
            dict(
                stage=f"welch, nperseg 4096, {a.n:.0e} samples",
                peer="scipy.signal.welch",
                peer_s=t_py,
                fleetdyn_s=r["median_s"],
                floor="read (8 B/sample)",
                floor_s=floors["floor_sum"],
                agreement=f"max relative Δ = {rel:.1e} over {int(mask.sum())} bins",
                ok=rel <= 1e-9,
            )
        )

    head = (
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}; "
        f"medians of {a.repeats} runs, one thread each side"
    )
    lines = [
        head,
        "",
        "| stage | peer | peer [s] | fleetdyn [s] | speed-up | floor | floor [s] | fleetdyn / floor | outputs agree |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['stage']} | {r['peer']} | {r['peer_s']:.3f} | {r['fleetdyn_s']:.3f} | "
            f"{r['peer_s'] / r['fleetdyn_s']:.1f}× | {r['floor']} | {r['floor_s']:.4f} | "
            f"{r['fleetdyn_s'] / r['floor_s']:.0f}× | {'yes' if r['ok'] else 'NO'}: {r['agreement']} |"
        )
    text = "\n".join(lines)
    print(text)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(text + "\n")
    if not all(r["ok"] for r in rows):
        print("outputs disagree beyond the stated tolerance", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
