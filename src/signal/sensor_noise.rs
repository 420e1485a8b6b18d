//! Blind estimate of a recorded channel's sensor error on the log's grid: the native samples
//! recovered from the grid (knots of linearly interpolated columns, changes of held ones), the
//! native period, the noise σ from a robust spread of the native second differences, and the
//! quantisation step; and the Monte-Carlo copies of that error ([`SensorNoise::draw`]). The
//! method and its measured accuracy are described in docs/diagnosis/method.md (noise floor,
//! part 1).
//!
//! Units: σ and steps in the channel's SI unit, periods in rows and s. Deterministic: every
//! random stream is seeded from a run seed, the copy and the column name ([`stream`]).

use super::quantization::estimate_quantization;
use super::stats::median;
use crate::rng::{splitmix64, Xoshiro256StarStar};
use crate::schema::{drive_log, Interpolation};
use crate::table::DriveLog;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use thiserror::Error;

/// Why a sensor's noise cannot be estimated.
#[derive(Debug, Error)]
pub enum SensorNoiseError {
    /// A series without any finite value, or no rows at all.
    #[error("{what}: no finite value")]
    Empty {
        /// The series.
        what: String,
    },
    /// A setting outside its domain.
    #[error("{parameter} = {value} must be {requirement}")]
    BadConfig {
        /// Setting, with unit.
        parameter: &'static str,
        /// Value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
}

/// How a channel was put on the log's grid (the schema's interpolation kind).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SampleKind {
    /// Linear between native samples.
    Linear,
    /// Each native sample held until the next (zero-order hold).
    Hold,
}

impl SampleKind {
    /// The kind of a canonical column (`Linear` for unknown columns).
    pub fn of_column(name: &str) -> SampleKind {
        match drive_log().column(name).map(|c| c.interpolation) {
            Some(Interpolation::Hold) => SampleKind::Hold,
            _ => SampleKind::Linear,
        }
    }
}

/// The blind estimate of one channel's sensor error (see the module documentation, part 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorNoise {
    /// Column.
    pub column: String,
    /// SI unit of the column.
    pub unit: String,
    /// How the channel sits on the grid.
    pub kind: SampleKind,
    /// Grid step of the log, s.
    pub grid_dt_s: f64,
    /// Estimated native rate, Hz.
    pub native_rate_hz: f64,
    /// Native samples recovered (knots plus filled-in ones).
    pub n_native: usize,
    /// Robust spread of the native second differences / √6 (includes dithered quantisation),
    /// unit.
    pub sigma_raw: f64,
    /// Quantisation step found on the native values, unit (`None`: not quantised).
    pub quantization_step: Option<f64>,
    /// White part of the error, `√max(0, σ_raw² − q²/12)`, unit.
    pub sigma_white: f64,
    /// Half-width of the persistent quantisation error, unit.
    pub persistent_half_width: f64,
    /// Native sample positions, rows (fractional).
    #[serde(skip)]
    positions: Vec<f64>,
    /// Run index (persistent error) of every native sample.
    #[serde(skip)]
    run: Vec<usize>,
    /// Recorded level of every run.
    #[serde(skip)]
    run_level: Vec<f64>,
    /// Recorded value of every native sample.
    #[serde(skip)]
    native_values: Vec<f64>,
}

/// Minimum knots needed to estimate a native period.
const MIN_KNOTS: usize = 8;

/// The median of the absolute deviations `dev` of values recorded on a lattice of step `q`,
/// read as grouped data: a deviation `k·q` stands for the interval `[(k − ½)q, (k + ½)q]`
/// (`[0, q/2]` for `k = 0`) it was rounded from, and the median is interpolated linearly
/// inside its interval (the textbook median of grouped data). The plain median of such
/// values is itself a multiple of `q` and so jumps with the noise level: for white noise of
/// σ = 2q rounded to `q`, the plain MAD of the second differences is `3q` where the
/// continuous one is `3.3q`, which puts σ 10 % low on every drive with the 0.1 % slope
/// sensor of `fleetdyn prove` (σ 0.2 %). Measured on rounded Gaussian noise around a value
/// moving across the steps (30 000 samples, second differences, `σ_w² = σ_MAD² − q²/12`):
/// σ_w within 5 % of σ for σ/q from 0.5 to 5, where the plain median is 34 % low to 31 %
/// high; on a constant value at σ/q = 0.5 it is 10 % low, but there `σ_MAD < q` and the
/// coarse-step estimate is used instead. `NaN` when `dev` is empty.
fn grouped_median_abs(dev: &[f64], q: f64) -> f64 {
    if dev.is_empty() || !(q.is_finite() && q > 0.0) {
        return median(&mut dev.to_vec());
    }
    let mut counts: BTreeMap<u64, usize> = BTreeMap::new();
    for d in dev {
        *counts.entry((d / q).round().max(0.0) as u64).or_default() += 1;
    }
    let half = dev.len() as f64 / 2.0;
    let mut below = 0.0;
    for (&k, &c) in &counts {
        let c = c as f64;
        if below + c >= half {
            let lo = if k == 0 { 0.0 } else { (k as f64 - 0.5) * q };
            let hi = (k as f64 + 0.5) * q;
            return lo + (half - below) / c * (hi - lo);
        }
        below += c;
    }
    f64::NAN
}

/// Runs `[a, b)` of consecutive finite values.
fn finite_runs(x: &[f64]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < x.len() {
        if !x[i].is_finite() {
            i += 1;
            continue;
        }
        let a = i;
        while i < x.len() && x[i].is_finite() {
            i += 1;
        }
        out.push((a, i));
    }
    out
}

/// A knot found on the grid: position (rows, fractional) and value.
#[derive(Debug, Clone, Copy)]
struct Knot {
    pos: f64,
    val: f64,
    piece: usize,
    /// Event rows behind the knot (1 or 2 for a knot; 3 or more: a channel as fast as the grid).
    rows: usize,
    /// The value is the recorded one (false: a knot between rows whose lines do not
    /// intersect inside, given the mean of its rows).
    exact: bool,
}

/// The knots of one finite piece `[a, b)` of `x`.
fn piece_knots(x: &[f64], a: usize, b: usize, kind: SampleKind, piece: usize) -> Vec<Knot> {
    let scale = x[a..b].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = 1e-9 * scale.max(f64::MIN_POSITIVE);
    let mut ev: Vec<usize> = Vec::new();
    match kind {
        SampleKind::Linear => {
            for i in a + 1..b.saturating_sub(1) {
                if (x[i + 1] - 2.0 * x[i] + x[i - 1]).abs() > tol {
                    ev.push(i);
                }
            }
        }
        SampleKind::Hold => {
            for i in a + 1..b {
                if (x[i] - x[i - 1]).abs() > tol {
                    ev.push(i);
                }
            }
        }
    }
    // clusters of adjacent event rows
    let mut knots = Vec::new();
    let mut k = 0;
    while k < ev.len() {
        let mut e = k;
        while e + 1 < ev.len() && ev[e + 1] == ev[e] + 1 {
            e += 1;
        }
        let i = ev[k];
        let size = e - k + 1;
        let knot = match (kind, size) {
            (SampleKind::Linear, 2) if i > a && i + 2 < b => {
                let sl = x[i] - x[i - 1];
                let sr = x[i + 2] - x[i + 1];
                let tau = if sl != sr {
                    (x[i + 1] - x[i] - sr) / (sl - sr)
                } else {
                    f64::NAN
                };
                if (0.0..=1.0).contains(&tau) {
                    Knot {
                        pos: i as f64 + tau,
                        val: x[i] + sl * tau,
                        piece,
                        rows: 2,
                        // nearly parallel lines amplify rounding: such a value may sit just
                        // off the quantisation lattice
                        exact: (sl - sr).abs() >= 0.25 * sl.abs().max(sr.abs()),
                    }
                } else {
                    Knot {
                        pos: i as f64 + 0.5,
                        val: 0.5 * (x[i] + x[i + 1]),
                        piece,
                        rows: 2,
                        exact: false,
                    }
                }
            }
            _ => Knot {
                pos: i as f64,
                val: x[i],
                piece,
                rows: size,
                exact: true,
            },
        };
        knots.push(knot);
        k = e + 1;
    }
    knots
}

/// Value of `x` (finite piece `[a, b)`) at fractional row `p`, as the grid shows it.
fn grid_value(x: &[f64], a: usize, b: usize, p: f64, kind: SampleKind) -> f64 {
    let p = p.clamp(a as f64, (b - 1) as f64);
    match kind {
        SampleKind::Hold => x[(p.ceil() as usize).min(b - 1)],
        SampleKind::Linear => {
            let i = p.floor() as usize;
            if i + 1 >= b {
                return x[b - 1];
            }
            let w = p - i as f64;
            x[i] + w * (x[i + 1] - x[i])
        }
    }
}

/// Estimates the sensor error of one channel on the log's grid (see the module documentation,
/// part 1). `values` are on the grid with step `dt_s` (s), NaN in gaps.
///
/// # Errors
/// [`SensorNoiseError::Empty`] without a finite value; [`SensorNoiseError::BadConfig`] for a bad
/// `dt_s`.
pub fn estimate_sensor_noise(
    column: &str,
    unit: &str,
    values: &[f64],
    dt_s: f64,
    kind: SampleKind,
) -> Result<SensorNoise, SensorNoiseError> {
    estimate_sensor_noise_in(
        column,
        unit,
        values,
        dt_s,
        kind,
        (f64::NEG_INFINITY, f64::INFINITY),
    )
}

/// [`estimate_sensor_noise`] of a column whose physical range is `range` (min, max): native
/// samples at a bound (an actuator at rest, a sensor clamping its noise) are left out of the
/// noise statistics, which would otherwise see the clamped noise as smaller than it is.
///
/// # Errors
/// As [`estimate_sensor_noise`].
pub fn estimate_sensor_noise_in(
    column: &str,
    unit: &str,
    values: &[f64],
    dt_s: f64,
    kind: SampleKind,
    range: (f64, f64),
) -> Result<SensorNoise, SensorNoiseError> {
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(SensorNoiseError::BadConfig {
            parameter: "grid step dt_s",
            value: dt_s,
            requirement: "finite and > 0",
        });
    }
    let pieces = finite_runs(values);
    if pieces.is_empty() {
        return Err(SensorNoiseError::Empty {
            what: column.into(),
        });
    }
    let n_finite: usize = pieces.iter().map(|(a, b)| b - a).sum();
    let mut knots: Vec<Knot> = Vec::new();
    for (pi, &(a, b)) in pieces.iter().enumerate() {
        knots.extend(piece_knots(values, a, b, kind, pi));
    }
    // native period, rows
    let mut spacings: Vec<f64> = knots
        .windows(2)
        .filter(|w| w[0].piece == w[1].piece)
        .map(|w| w[1].pos - w[0].pos)
        .collect();
    let n_events: usize = knots.iter().map(|k| k.rows).sum();
    let wide = knots.iter().filter(|k| k.rows >= 3).count();
    let every_row = n_events * 2 > n_finite
        || wide * 10 > knots.len()
        || knots.len() < MIN_KNOTS
        || spacings.is_empty();
    let period = if every_row {
        1.0
    } else {
        spacings.sort_by(f64::total_cmp);
        let p10 = spacings[spacings.len() / 10];
        let near: Vec<f64> = spacings
            .iter()
            .copied()
            .filter(|s| *s <= 1.5 * p10)
            .collect();
        let p = near.iter().sum::<f64>() / near.len() as f64;
        if p < 1.5 {
            1.0
        } else {
            p
        }
    };
    // native samples: every row, or the knots with the missing ones filled in
    let mut native: Vec<Knot> = Vec::new();
    if period == 1.0 {
        for (pi, &(a, b)) in pieces.iter().enumerate() {
            for (i, &v) in values.iter().enumerate().take(b).skip(a) {
                native.push(Knot {
                    pos: i as f64,
                    val: v,
                    piece: pi,
                    rows: 1,
                    exact: true,
                });
            }
        }
    } else {
        for (pi, &(a, b)) in pieces.iter().enumerate() {
            let ks: Vec<Knot> = knots.iter().copied().filter(|k| k.piece == pi).collect();
            let push_fill = |native: &mut Vec<Knot>, from: f64, to: f64| {
                // evenly spaced samples strictly between `from` and `to`
                let gap = to - from;
                let m = (gap / period).round() as usize;
                for j in 1..m {
                    let p = from + gap * j as f64 / m as f64;
                    native.push(Knot {
                        pos: p,
                        val: grid_value(values, a, b, p, kind),
                        piece: pi,
                        rows: 0,
                        exact: false,
                    });
                }
            };
            if ks.is_empty() {
                let mut p = a as f64;
                while p <= (b - 1) as f64 {
                    native.push(Knot {
                        pos: p,
                        val: grid_value(values, a, b, p, kind),
                        piece: pi,
                        rows: 0,
                        exact: false,
                    });
                    p += period;
                }
                continue;
            }
            // before the first knot
            let mut head = Vec::new();
            let mut p = ks[0].pos - period;
            while p >= a as f64 {
                head.push(Knot {
                    pos: p,
                    val: grid_value(values, a, b, p, kind),
                    piece: pi,
                    rows: 0,
                    exact: false,
                });
                p -= period;
            }
            head.reverse();
            native.extend(head);
            for (j, k) in ks.iter().enumerate() {
                native.push(*k);
                if let Some(next) = ks.get(j + 1) {
                    if next.pos - k.pos > 1.5 * period {
                        push_fill(&mut native, k.pos, next.pos);
                    }
                }
            }
            let mut p = ks[ks.len() - 1].pos + period;
            while p <= (b - 1) as f64 {
                native.push(Knot {
                    pos: p,
                    val: grid_value(values, a, b, p, kind),
                    piece: pi,
                    rows: 0,
                    exact: false,
                });
                p += period;
            }
        }
    }
    let vals: Vec<f64> = native.iter().map(|k| k.val).collect();
    // the step from the recorded values: not a piece's first and last sample (an interpolated
    // value at a gap's edge), not filled-in or ill-conditioned knots — one value off the lattice
    // breaks the smallest-gap step; `robust_step` tolerates a few more
    let interior: Vec<f64> = (0..native.len())
        .filter(|&j| {
            j > 0
                && j + 1 < native.len()
                && native[j].exact
                && native[j - 1].piece == native[j].piece
                && native[j + 1].piece == native[j].piece
        })
        .map(|j| native[j].val)
        .collect();
    let q = estimate_quantization(&interior)
        .map(|q| q.step)
        .or_else(|| robust_step(&interior));
    // recorded level: running median of the native values over ±0.5 s (same piece)
    let native_rate_hz = 1.0 / (period * dt_s);
    let hw = ((0.5 * native_rate_hz).round() as usize).max(1);
    let level: Vec<f64> = (0..native.len())
        .map(|j| {
            let lo = j.saturating_sub(hw);
            let hi = (j + hw + 1).min(native.len());
            let mut w: Vec<f64> = native[lo..hi]
                .iter()
                .filter(|k| k.piece == native[j].piece)
                .map(|k| k.val)
                .collect();
            median(&mut w)
        })
        .collect();
    let inside = |v: f64| v > range.0 && v < range.1;
    let mut d2: Vec<f64> = native
        .windows(3)
        .filter(|w| w[0].piece == w[2].piece && w.iter().all(|k| inside(k.val)))
        .map(|w| w[2].val - 2.0 * w[1].val + w[0].val)
        .collect();
    let sigma_mad = if d2.is_empty() {
        0.0
    } else {
        let m = median(&mut d2.clone());
        let mut dev: Vec<f64> = d2.iter_mut().map(|d| (*d - m).abs()).collect();
        let mad = match q {
            Some(q) => grouped_median_abs(&dev, q),
            None => median(&mut dev),
        };
        1.4826 * mad / 6f64.sqrt()
    };
    let (sigma_raw, sigma_white) = match q {
        // coarse steps (noise below a step): the second differences take the discrete values
        // 0, ±q, ±2q of flicker and their MAD jumps between 0 and q. The flicker rate φ (share
        // of native samples off their recorded level) gives σ instead: for truth spread evenly
        // within a step, φ = 2σ/(q√(2π)), so σ = √(π/2)·q·φ (valid while φ is small; at
        // φ ≥ 0.25 the noise dithers and the RMS of the small second differences is used)
        Some(q) if sigma_mad < q => {
            let (mut off, mut cnt) = (0usize, 0usize);
            for (k, l) in native.iter().zip(&level) {
                if inside(k.val) {
                    cnt += 1;
                    if (k.val - l).abs() > 1e-6 * q {
                        off += 1;
                    }
                }
            }
            let phi = if cnt == 0 {
                0.0
            } else {
                off as f64 / cnt as f64
            };
            if phi < 0.25 {
                let s = (std::f64::consts::PI / 2.0).sqrt() * q * phi;
                (s, s)
            } else {
                let small: Vec<f64> = d2
                    .iter()
                    .copied()
                    .filter(|d| d.abs() <= 2.0 * q * (1.0 + 1e-6))
                    .collect();
                let raw = if small.is_empty() {
                    0.0
                } else {
                    (small.iter().map(|d| d * d).sum::<f64>() / small.len() as f64 / 6.0).sqrt()
                };
                (raw, (raw * raw - q * q / 12.0).max(0.0).sqrt())
            }
        }
        Some(q) => (
            sigma_mad,
            (sigma_mad.powi(2) - q * q / 12.0).max(0.0).sqrt(),
        ),
        None => (sigma_mad, sigma_mad),
    };
    let half = q.map_or(0.0, |q| {
        let damp = (-2.0 * std::f64::consts::PI.powi(2) * sigma_white.powi(2) / (q * q)).exp();
        0.5 * q * damp
    });
    // runs of equal recorded level
    let mut run = Vec::with_capacity(native.len());
    let mut run_level = Vec::new();
    let mut last: Option<(usize, f64)> = None;
    let mut id = 0usize;
    for (k, &l) in native.iter().zip(&level) {
        match last {
            Some((piece, lv)) if piece == k.piece && lv == l => {}
            Some(_) => {
                id += 1;
                run_level.push(l);
            }
            None => run_level.push(l),
        }
        last = Some((k.piece, l));
        run.push(id);
    }
    Ok(SensorNoise {
        column: column.into(),
        unit: unit.into(),
        kind,
        grid_dt_s: dt_s,
        native_rate_hz,
        n_native: native.len(),
        sigma_raw,
        quantization_step: q,
        sigma_white,
        persistent_half_width: half,
        positions: native.iter().map(|k| k.pos).collect(),
        run,
        run_level,
        native_values: vals,
    })
}

/// The quantisation step of `v` when a few values are off the lattice (reconstructed knots that
/// rounding moved): the smallest non-zero difference between consecutive values that makes up
/// at least 5 % of them, accepted when at least 95 % of the values lie within 2 % of a step of
/// the lattice through the median value and values repeat (as
/// [`estimate_quantization`]: at most one distinct value per 2 samples).
fn robust_step(v: &[f64]) -> Option<f64> {
    if v.len() < 8 {
        return None;
    }
    let scale = v
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()))
        .max(f64::MIN_POSITIVE);
    let tol = 1e-9 * scale;
    let mut d: Vec<f64> = v
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|x| *x > tol)
        .collect();
    if d.len() < 8 {
        return None;
    }
    d.sort_by(f64::total_cmp);
    let need = (d.len() / 20).max(2);
    let mut q = None;
    let mut i = 0;
    while i < d.len() {
        let mut j = i;
        while j + 1 < d.len() && d[j + 1] - d[i] <= 0.02 * d[i] {
            j += 1;
        }
        if j - i + 1 >= need {
            q = Some(d[i..=j].iter().sum::<f64>() / (j - i + 1) as f64);
            break;
        }
        i = j + 1;
    }
    let q = q?;
    let mut sorted = v.to_vec();
    let v0 = median(&mut sorted);
    let on = v
        .iter()
        .filter(|x| {
            let k = (*x - v0) / q;
            (k - k.round()).abs() <= 0.02
        })
        .count();
    let mut distinct = sorted.clone();
    distinct.dedup_by(|a, b| (*a - *b).abs() <= 0.02 * q);
    (on * 100 >= 95 * v.len() && distinct.len() * 2 <= v.len()).then_some(q)
}

/// FNV-1a hash of a name (seeds per column).
fn fnv1a64(name: &str) -> u64 {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for b in name.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    h
}

/// The random stream of `column` in copy `copy` of a run seeded with `seed`.
pub fn stream(seed: u64, copy: u64, column: &str) -> Xoshiro256StarStar {
    let mut s = seed ^ fnv1a64(column);
    let a = splitmix64(&mut s);
    let mut c = copy.wrapping_add(0x5EED);
    Xoshiro256StarStar::seed_from_u64(a ^ splitmix64(&mut c))
}

impl SensorNoise {
    /// A sensor error model given directly (white σ, quantisation step, native rate), e.g. for
    /// tests or a channel whose data sheet is known: native samples every `period_rows` rows of
    /// an `n_rows` grid, runs of the persistent error every `run_rows` rows.
    ///
    /// # Errors
    /// [`SensorNoiseError::BadConfig`] for non-finite or non-positive steps and negative σ.
    #[allow(clippy::too_many_arguments)]
    pub fn given(
        column: &str,
        unit: &str,
        kind: SampleKind,
        n_rows: usize,
        dt_s: f64,
        period_rows: usize,
        sigma_white: f64,
        quantization_step: Option<f64>,
    ) -> Result<SensorNoise, SensorNoiseError> {
        let bad = |parameter, value| SensorNoiseError::BadConfig {
            parameter,
            value,
            requirement: "finite and > 0 (σ ≥ 0)",
        };
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(bad("dt_s", dt_s));
        }
        if period_rows == 0 {
            return Err(bad("period_rows", 0.0));
        }
        if !(sigma_white.is_finite() && sigma_white >= 0.0) {
            return Err(bad("sigma_white", sigma_white));
        }
        if let Some(q) = quantization_step {
            if !(q.is_finite() && q > 0.0) {
                return Err(bad("quantization_step", q));
            }
        }
        let positions: Vec<f64> = (0..n_rows).step_by(period_rows).map(|i| i as f64).collect();
        let half = quantization_step.map_or(0.0, |q| {
            0.5 * q * (-2.0 * std::f64::consts::PI.powi(2) * sigma_white.powi(2) / (q * q)).exp()
        });
        let rate = 1.0 / (period_rows as f64 * dt_s);
        let hw = ((0.5 * rate).round() as usize).max(1);
        let run: Vec<usize> = (0..positions.len()).map(|j| j / (2 * hw + 1)).collect();
        let run_level = vec![f64::NAN; run.last().map_or(0, |r| r + 1)];
        Ok(SensorNoise {
            column: column.into(),
            unit: unit.into(),
            kind,
            grid_dt_s: dt_s,
            native_rate_hz: rate,
            n_native: positions.len(),
            sigma_raw: (sigma_white.powi(2) + quantization_step.map_or(0.0, |q| q * q / 12.0))
                .sqrt(),
            quantization_step,
            sigma_white,
            persistent_half_width: half,
            native_values: vec![f64::NAN; positions.len()],
            positions,
            run,
            run_level,
        })
    }

    /// One draw of the sensor error on an `n_rows` grid: `σ_w·N(0,1)` per native sample plus
    /// `U(−h, h)` per run of equal recorded level, interpolated or held onto the rows like the
    /// recording. Rows before the first native sample take its value, after the last the last's.
    /// Without native samples (a series never estimated) every row draws its own.
    pub fn draw(&self, n_rows: usize, rng: &mut Xoshiro256StarStar) -> Vec<f64> {
        self.draw_in(n_rows, rng, f64::NEG_INFINITY, f64::INFINITY)
            .0
    }

    /// [`SensorNoise::draw`] for a column whose physical range is `[lo, hi]`, with the rows at
    /// rest: a run whose recorded level lies at a bound (a brake, retarder or clutch that is off,
    /// a vehicle standing) gets no persistent error, and its rows are returned with that bound —
    /// `diagnose::noise::perturbed_log` sets them to it. The reading at rest is noise about the
    /// actuator's rest state, which a sensor clamping at the bound shows as a one-sided offset
    /// (the recorded brake force of a synthetic drive is |N(0, 200 N)| rounded to 0.1 kN while
    /// the brake is off, +85 N on average); a copy at the rest state differs from the recording
    /// by that offset, as the recording differs from the truth.
    pub fn draw_in(
        &self,
        n_rows: usize,
        rng: &mut Xoshiro256StarStar,
        lo: f64,
        hi: f64,
    ) -> (Vec<f64>, Vec<Option<f64>>) {
        if self.positions.is_empty() {
            return (
                (0..n_rows)
                    .map(|_| self.sigma_white * rng.standard_normal())
                    .collect(),
                vec![None; n_rows],
            );
        }
        let n_runs = self.run.last().map_or(0, |r| r + 1);
        let white: Vec<f64> = (0..self.positions.len())
            .map(|_| self.sigma_white * rng.standard_normal())
            .collect();
        let h = self.persistent_half_width;
        // a run is at a bound when its recorded level is within one step (or σ_w) of it: the
        // running median of clamped noise sits at the bound or one step off it
        let step = self.quantization_step.unwrap_or(0.0).max(self.sigma_white);
        let bound: Vec<Option<f64>> = (0..n_runs)
            .map(|r| {
                let level = self.run_level.get(r).copied().unwrap_or(f64::NAN);
                if level <= lo + step {
                    Some(lo)
                } else if level >= hi - step {
                    Some(hi)
                } else {
                    None
                }
            })
            .collect();
        let pers: Vec<f64> = (0..n_runs)
            .map(|r| {
                let u = if h > 0.0 { rng.uniform(-h, h) } else { 0.0 };
                if bound[r].is_some() {
                    0.0
                } else {
                    u
                }
            })
            .collect();
        let d: Vec<f64> = white
            .iter()
            .zip(&self.run)
            .map(|(w, r)| w + pers[*r])
            .collect();
        // at rest: in a run at a bound and itself within the noise of it (3σ_w + q), so that the
        // first samples of an actuation, whose running median is still the rest level, stay
        let near = 3.0 * self.sigma_white + self.quantization_step.unwrap_or(0.0);
        let rest: Vec<Option<f64>> = self
            .run
            .iter()
            .zip(&self.native_values)
            .map(|(r, v)| bound[*r].filter(|b| (v - b).abs() <= near))
            .collect();
        let p = &self.positions;
        let mut out = vec![0.0; n_rows];
        let mut at = vec![None; n_rows];
        let mut j = 0usize;
        for i in 0..n_rows {
            let x = i as f64;
            while j + 1 < p.len() && p[j + 1] <= x {
                j += 1;
            }
            (out[i], at[i]) = if x < p[0] {
                (d[0], rest[0])
            } else if j + 1 >= p.len() {
                (d[p.len() - 1], rest[p.len() - 1])
            } else {
                match self.kind {
                    SampleKind::Hold => (d[j], rest[j]),
                    SampleKind::Linear => {
                        let w = (x - p[j]) / (p[j + 1] - p[j]);
                        let r = if rest[j] == rest[j + 1] {
                            rest[j]
                        } else {
                            None
                        };
                        (d[j] + w * (d[j + 1] - d[j]), r)
                    }
                }
            };
        }
        (out, at)
    }
}

/// Grid step of a log, s (median of the row intervals).
///
/// # Errors
/// [`SensorNoiseError::Empty`] for fewer than 2 rows; [`SensorNoiseError::BadConfig`] for a
/// non-increasing time axis.
pub fn grid_step_s(log: &DriveLog) -> Result<f64, SensorNoiseError> {
    if log.len() < 2 {
        return Err(SensorNoiseError::Empty {
            what: "time axis (fewer than 2 rows)".into(),
        });
    }
    let mut d: Vec<f64> = log
        .timestamp_ns
        .windows(2)
        .map(|w| (w[1] - w[0]) as f64 * 1e-9)
        .collect();
    let dt = median(&mut d);
    if !(dt.is_finite() && dt > 0.0) {
        return Err(SensorNoiseError::BadConfig {
            parameter: "grid step, s",
            value: dt,
            requirement: "finite and > 0 (increasing timestamps)",
        });
    }
    Ok(dt)
}
