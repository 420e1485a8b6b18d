//! The noise floor of one compared signal (docs/diagnosis/method.md, step 2): the statistics of
//! the null residuals `e_c = r_c − r` that [`super::noise`] draws from its Monte-Carlo copies,
//! as [`super::locate`] reads them to tell a mismatch from noise.
//!
//! # What the floor carries
//! [`NoiseFloor`]: the per-row null variance `mean_c e_c²` (unit²), the autocorrelation of the
//! normalised null (for the effective degrees of freedom of a sum of squared residuals over a
//! window, [`NoiseFloor::effective_dof`]), the copies themselves (for a window's own degrees of
//! freedom, [`NoiseFloor::window_dof`]), the null's Welch PSD (for band powers), and the split
//! into measurement and input parts (RMS). The scalar floor (diagnosis.json `noise_floor`) is the
//! RMS of the null over the rows that count.
//!
//! Units: every σ, floor and RMS is in the signal's SI unit; variances in unit²; times in s.

use super::noise_config::NoiseConfig;
use super::noise_error::NoiseError;
use crate::signal::sensor_noise::{stream, SensorNoise};
use crate::signal::stats::runs;
use crate::signal::{csd_piece_stream, WelchConfig};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::collections::BTreeMap;

/// The null PSD of a floor (mean over the copies).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NullPsd {
    /// Bin frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// One-sided PSD, unit²/Hz.
    pub psd: Vec<f64>,
    /// Equivalent degrees of freedom per bin (all copies' segments).
    pub dof: f64,
    /// Segment length, rows.
    pub nperseg: usize,
    /// Power of the segment means, which Welch's per-segment detrend removes: what lies below
    /// the first bin (slower than a segment), unit² ([`segment_mean_square`]).
    pub dc_power: f64,
}

/// Mean over Welch segments (`nperseg` rows, half overlap, as [`crate::signal::csd_pieces`]
/// cuts them) of the squared segment mean of each piece: the power slower than one segment,
/// which the Welch PSD leaves out (0 without a full segment).
pub fn segment_mean_square(pieces: &[&[f64]], nperseg: usize) -> f64 {
    segment_mean_square_stream(pieces.iter().map(|&x| Cow::Borrowed(x)), nperseg)
}

/// [`segment_mean_square`] of pieces made as they are read (one held at a time), bit for bit.
pub fn segment_mean_square_stream<'a>(
    pieces: impl Iterator<Item = Cow<'a, [f64]>>,
    nperseg: usize,
) -> f64 {
    let step = (nperseg - nperseg / 2).max(1);
    let (mut s, mut k) = (0.0, 0usize);
    for x in pieces {
        if nperseg == 0 || x.len() < nperseg {
            continue;
        }
        let m = (x.len() - nperseg / 2) / step;
        for j in 0..m {
            let seg = &x[j * step..j * step + nperseg];
            let mean = seg.iter().sum::<f64>() / nperseg as f64;
            s += mean * mean;
            k += 1;
        }
    }
    if k == 0 {
        0.0
    } else {
        s / k as f64
    }
}

/// The noise floor of one compared signal (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseFloor {
    /// Compared signal.
    pub signal: String,
    /// SI unit.
    pub unit: String,
    /// RMS of the null residual over the rows that count, unit (diagnosis.json `noise_floor`).
    pub floor: f64,
    /// RMS of the part from the output's own measurement error, unit (`None` when the copies
    /// were given whole).
    pub measurement_rms: Option<f64>,
    /// RMS of the part propagated from the inputs, unit (`None` when given whole).
    pub input_rms: Option<f64>,
    /// Number of copies behind the estimate.
    pub copies: usize,
    /// Grid step, s.
    pub dt_s: f64,
    /// Squared-correlation time of the null, `dt·Σ_k ρ(k)²` over |k| ≤ the kept lags, s: a long
    /// window holds about `T / τ` degrees of freedom.
    pub correlation_time_s: f64,
    /// The output's own sensor estimate, when it is a recorded column (its figures, without
    /// the native samples: [`SensorNoise::without_samples`]).
    pub sensor: Option<SensorNoise>,
    /// Per-row null variance `mean_c e_c²`, unit² (NaN where the row does not count).
    #[serde(skip)]
    pub null_variance: Vec<f64>,
    /// Autocorrelation of the normalised null, lags 0.. (rows); `ρ(0) = 1`.
    #[serde(skip)]
    pub autocorrelation: Vec<f64>,
    /// The null copies themselves, per copy and row (NaN where the row does not count), kept
    /// in single precision for [`NoiseFloor::window_dof`].
    #[serde(skip)]
    pub null_copies: Vec<Vec<f32>>,
    /// Null PSD (`None` when no valid stretch is as long as a segment).
    #[serde(skip)]
    pub null_psd: Option<NullPsd>,
}

/// Moving average of the finite entries of `x` over ±`hw` rows (NaN where none).
fn moving_mean(x: &[f64], hw: usize) -> Vec<f64> {
    let n = x.len();
    let mut cs = vec![0.0; n + 1];
    let mut cn = vec![0usize; n + 1];
    for i in 0..n {
        let f = x[i].is_finite();
        cs[i + 1] = cs[i] + if f { x[i] } else { 0.0 };
        cn[i + 1] = cn[i] + usize::from(f);
    }
    (0..n)
        .map(|i| {
            let a = i.saturating_sub(hw);
            let b = (i + hw + 1).min(n);
            let c = cn[b] - cn[a];
            if c == 0 {
                f64::NAN
            } else {
                (cs[b] - cs[a]) / c as f64
            }
        })
        .collect()
}

/// `Σ_c Σ_t x_c(t)·x_c(t+k)` for k = 0..=max_lag, summed over the series `xs` (each of
/// length `n`), by FFT: the power spectra summed, one inverse transform. The transform length
/// is the next power of two from `n + max_lag + 1`, enough zero padding that no lag up to
/// `max_lag` wraps around.
fn autocov_sums<X: AsRef<[f64]>>(
    xs: impl IntoIterator<Item = X>,
    n: usize,
    max_lag: usize,
) -> Vec<f64> {
    if n == 0 {
        return vec![0.0; max_lag + 1];
    }
    let m = (n + max_lag + 1).next_power_of_two();
    let fwd = crate::signal::fft_plans::forward(m);
    let inv = crate::signal::fft_plans::inverse(m);
    let mut power = fwd.make_output_vec();
    let mut buf = fwd.make_input_vec();
    let mut spec = fwd.make_output_vec();
    for x in xs {
        buf[..n].copy_from_slice(&x.as_ref()[..n]);
        buf[n..].iter_mut().for_each(|v| *v = 0.0);
        fwd.process(&mut buf, &mut spec).expect("plan sizes");
        for (p, c) in power.iter_mut().zip(&spec) {
            p.re += c.norm_sqr();
        }
    }
    let mut out = inv.make_output_vec();
    inv.process(&mut power, &mut out).expect("plan sizes");
    (0..=max_lag)
        .map(|k| if k < n { out[k] / m as f64 } else { 0.0 })
        .collect()
}

impl NoiseFloor {
    /// The floor of `signal` from null copies `e_c` (each as long as `valid`; rows that do not
    /// count, or where a copy is not finite, are left out). The copies come and are kept in
    /// single precision (a relative rounding of 6·10⁻⁸, far below the spread of twelve copies,
    /// whose variance estimate is uncertain by about 40 %): on a 10-hour drive each is 7 MB
    /// instead of 14 MB; the figures are summed in double precision.
    ///
    /// # Errors
    /// [`NoiseError::BadConfig`] for fewer than 2 copies or a bad step or setting;
    /// [`NoiseError::Length`] for copies of the wrong length.
    pub fn from_null_copies(
        signal: &str,
        unit: &str,
        dt_s: f64,
        mut copies: Vec<Vec<f32>>,
        valid: &[bool],
        cfg: &NoiseConfig,
    ) -> Result<NoiseFloor, NoiseError> {
        cfg.validate()?;
        if copies.len() < 2 {
            return Err(NoiseError::BadConfig {
                parameter: "copies",
                value: copies.len() as f64,
                requirement: "at least 2",
            });
        }
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(NoiseError::BadConfig {
                parameter: "dt_s",
                value: dt_s,
                requirement: "finite and > 0",
            });
        }
        let n = valid.len();
        for c in &copies {
            if c.len() != n {
                return Err(NoiseError::Length {
                    what: format!("null copy of {signal}"),
                    expected: n,
                    got: c.len(),
                });
            }
        }
        let k = copies.len() as f64;
        let usable: Vec<bool> = (0..n)
            .map(|i| valid[i] && copies.iter().all(|c| c[i].is_finite()))
            .collect();
        let null_variance: Vec<f64> = (0..n)
            .map(|i| {
                if usable[i] {
                    copies
                        .iter()
                        .map(|c| f64::from(c[i]) * f64::from(c[i]))
                        .sum::<f64>()
                        / k
                } else {
                    f64::NAN
                }
            })
            .collect();
        let n_use = usable.iter().filter(|u| **u).count();
        let floor = if n_use == 0 {
            f64::NAN
        } else {
            (null_variance.iter().filter(|v| v.is_finite()).sum::<f64>() / n_use as f64).sqrt()
        };
        // autocorrelation of the normalised null, pooled over copies
        let hw = ((cfg.smoothing_s / dt_s).round() as usize).max(1);
        let smooth = moving_mean(&null_variance, hw);
        let max_lag = ((cfg.max_lag_s / dt_s).round() as usize).min(n.saturating_sub(1));
        let mask: Vec<f64> = (0..n)
            .map(|i| {
                if usable[i] && smooth[i] > 0.0 {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let pairs = autocov_sums([mask.as_slice()], n, max_lag);
        // each copy normalised as the sums reach it (one row vector at a time)
        let normalised = copies.iter().map(|c| {
            (0..n)
                .map(|i| {
                    if mask[i] > 0.0 {
                        f64::from(c[i]) / smooth[i].sqrt()
                    } else {
                        0.0
                    }
                })
                .collect::<Vec<f64>>()
        });
        let acc = autocov_sums(normalised, n, max_lag);
        let mut autocorrelation = Vec::with_capacity(max_lag + 1);
        if pairs.first().copied().unwrap_or(0.0) > 0.5 {
            let r0 = acc[0] / pairs[0];
            for lag in 0..=max_lag {
                // keep lags with at least 10 % of the rows paired (the rest is too noisy)
                if pairs[lag] < 0.1 * pairs[0] || r0 <= 0.0 {
                    break;
                }
                autocorrelation.push((acc[lag] / pairs[lag] / r0).clamp(-1.0, 1.0));
            }
        }
        if autocorrelation.is_empty() {
            autocorrelation.push(1.0);
        }
        let correlation_time_s =
            dt_s * (1.0 + 2.0 * autocorrelation[1..].iter().map(|r| r * r).sum::<f64>());
        // null PSD over every copy's usable stretches, each read in double precision as the
        // spectrum reaches it (all copies' stretches at once would be 8 bytes per copy and
        // usable row: 0.17 GB on a 10-hour drive)
        let nperseg = ((cfg.psd_segment_s / dt_s).round() as usize).max(8);
        let usable_runs = runs(&usable);
        let stretches = || {
            copies.iter().flat_map(|c| {
                usable_runs
                    .iter()
                    .map(move |&(a, b)| c[a..b].iter().map(|x| f64::from(*x)).collect::<Vec<f64>>())
            })
        };
        let null_psd = csd_piece_stream(
            || {
                stretches().map(|p| {
                    let q = p.clone();
                    (Cow::Owned(p), Cow::Owned(q))
                })
            },
            &WelchConfig {
                fs_hz: 1.0 / dt_s,
                nperseg: Some(nperseg),
                noverlap: None,
                confidence: 0.95,
            },
        )
        .ok()
        .map(|c| NullPsd {
            freq_hz: c.freq_hz,
            psd: c.pxx,
            dof: c.dof,
            nperseg,
            dc_power: segment_mean_square_stream(stretches().map(Cow::Owned), nperseg),
        });
        for c in copies.iter_mut() {
            for (x, u) in c.iter_mut().zip(&usable) {
                if !u {
                    *x = f32::NAN;
                }
            }
        }
        Ok(NoiseFloor {
            signal: signal.into(),
            unit: unit.into(),
            floor,
            measurement_rms: None,
            input_rms: None,
            copies: copies.len(),
            dt_s,
            correlation_time_s,
            sensor: None,
            null_variance,
            autocorrelation,
            null_copies: copies,
            null_psd,
        })
    }

    /// A floor made of the output's measurement error alone (no model, no inputs): `copies`
    /// draws of `sensor` on the rows of `valid`. For residuals whose model is exact, e.g.
    /// synthetic tests, or signals no input feeds.
    ///
    /// # Errors
    /// As [`NoiseFloor::from_null_copies`].
    pub fn measurement_only(
        signal: &str,
        sensor: &SensorNoise,
        valid: &[bool],
        cfg: &NoiseConfig,
    ) -> Result<NoiseFloor, NoiseError> {
        cfg.validate()?;
        let copies: Vec<Vec<f32>> = (0..cfg.copies as u64)
            .map(|c| {
                let d = sensor.draw(valid.len(), &mut stream(cfg.seed, c, &sensor.column));
                d.into_iter().map(|x| x as f32).collect()
            })
            .collect();
        let mut f = NoiseFloor::from_null_copies(
            signal,
            &sensor.unit,
            sensor.grid_dt_s,
            copies,
            valid,
            cfg,
        )?;
        f.measurement_rms = Some(f.floor);
        f.input_rms = Some(0.0);
        f.sensor = Some(sensor.without_samples());
        Ok(f)
    }

    /// `Σ_{|k|<N} (1 − |k|/N)·ρ(k)²` for a contiguous stretch of `n` rows (lags beyond those kept
    /// count 0).
    pub fn squared_correlation_sum(&self, n: usize) -> f64 {
        let nf = n as f64;
        let mut s = 1.0;
        for (k, r) in self.autocorrelation.iter().enumerate().skip(1) {
            if k >= n {
                break;
            }
            s += 2.0 * (1.0 - k as f64 / nf) * r * r;
        }
        s
    }

    /// Effective degrees of freedom of `Σ r²` over `rows` (sorted row indices where the floor
    /// counts): for each contiguous run, Satterthwaite's `ν = (Σσ²)² / (Σσ⁴ · S_N)` with the
    /// null's per-row variance σ² and the squared-correlation sum `S_N`; runs add up (they are
    /// treated as independent). At least 1 when any row counts, 0 otherwise.
    pub fn effective_dof(&self, rows: &[usize]) -> f64 {
        let mut total = 0.0;
        let mut i = 0;
        while i < rows.len() {
            let mut j = i;
            while j + 1 < rows.len() && rows[j + 1] == rows[j] + 1 {
                j += 1;
            }
            let (mut s1, mut s2) = (0.0, 0.0);
            for &r in &rows[i..=j] {
                let v = self.null_variance.get(r).copied().unwrap_or(f64::NAN);
                if v.is_finite() {
                    s1 += v;
                    s2 += v * v;
                }
            }
            if s2 > 0.0 {
                total += s1 * s1 / (s2 * self.squared_correlation_sum(j - i + 1));
            }
            i = j + 1;
        }
        if rows.is_empty() || total == 0.0 {
            total
        } else {
            total.max(1.0)
        }
    }

    /// Degrees of freedom of a window's `Σ r²` over `rows` for the window test of
    /// [`super::locate`]: the smaller of [`NoiseFloor::effective_dof`] (from the drive-wide
    /// autocorrelation) and Satterthwaite's `ν = (tr Σ)² / tr Σ²` of the window's own null
    /// covariance `Σ` (over `rows`), estimated from the copies (at least 1).
    ///
    /// Why both: the drive-wide autocorrelation is stationary, but the null is not — the
    /// longitudinal null restarts at every re-initialisation window, the input noise it
    /// integrates differs between a steady cruise and a shift sequence — so the pooled
    /// autocorrelation can give a window more degrees of freedom than its own null has. The
    /// copies show the window's own null: on `fleetdyn prove --seed 1001`, a clean drive's
    /// engine-speed window (20–30 s, a climb through gears 5–8; 2.3 × its floor) has ν = 23
    /// from the autocorrelation but 2.0 from its copies; at ν = 23 it tests at p = 4·10⁻¹² as
    /// a mismatch, at ν = 2.0 its p is 0.013, not one after Holm.
    ///
    /// The estimate from the copies uses pairs of distinct copies `c ≠ d` only: for independent
    /// zero-mean copies `E[|e_c|² |e_d|²] = (tr Σ)²` and `E[(e_c·e_d)²] = tr Σ²`, so
    /// `ν̂ = Σ_{c<d} |e_c|² |e_d|² / Σ_{c<d} (e_c·e_d)²` has an unbiased numerator and
    /// denominator, and is exactly 1 for a null that is one shape with a random amplitude (an
    /// offset, a start-state error) whatever the amplitudes drawn. The alternative
    /// `2 E[Q]² / Var[Q]` of the copies' sums `Q_c = |e_c|²` has the same target for Gaussian
    /// copies but reads it off the spread of `K` draws of a skewed χ², which is usually below
    /// its expectation: simulated with 12 copies (400 trials), a Brownian drift over the second
    /// half of a 20 s window (ν = 1.23) reads median 1.68 (10–90 %: 0.91–2.97) that way and
    /// 1.28 (1.14–1.56) from the pairs; a pure offset 1.39 (0.73–2.47) against exactly 1.
    pub fn window_dof(&self, rows: &[usize]) -> f64 {
        let nu_acf = self.effective_dof(rows);
        if self.null_copies.len() < 2 || rows.is_empty() {
            return nu_acf;
        }
        // the copies on the window's rows; a row a copy lacks adds nothing
        let e: Vec<Vec<f64>> = self
            .null_copies
            .iter()
            .map(|c| {
                rows.iter()
                    .map(|&r| f64::from(c.get(r).copied().unwrap_or(f32::NAN)))
                    .map(|x| if x.is_finite() { x } else { 0.0 })
                    .collect()
            })
            .collect();
        let sq: Vec<f64> = e.iter().map(|x| x.iter().map(|v| v * v).sum()).collect();
        let (mut num, mut den) = (0.0, 0.0);
        for c in 0..e.len() {
            for d in c + 1..e.len() {
                let dot: f64 = e[c].iter().zip(&e[d]).map(|(a, b)| a * b).sum();
                num += sq[c] * sq[d];
                den += dot * dot;
            }
        }
        if !(num > 0.0 && den > 0.0) {
            return nu_acf;
        }
        nu_acf.min(num / den).max(1.0)
    }
}

/// The floors of every compared signal, with the sensor estimates behind them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseFloors {
    /// One per compared signal.
    pub floors: Vec<NoiseFloor>,
    /// Sensor estimates of every perturbed column.
    pub sensors: Vec<SensorNoise>,
    /// Copies.
    pub copies: usize,
    /// Seed.
    pub seed: u64,
}

impl NoiseFloors {
    /// The floor of `signal`.
    pub fn get(&self, signal: &str) -> Option<&NoiseFloor> {
        self.floors.iter().find(|f| f.signal == signal)
    }

    /// Drops what only the floors' making and the location's tests read: every floor's null
    /// copies (a long drive's largest part of the floors: one f32 row per copy and row), which
    /// only [`NoiseFloor::window_dof`] reads, after which a window's degrees of freedom come
    /// from the autocorrelation alone, and its per-row null variance (empty afterwards: the
    /// floors serve figures only, no window test); and the sensor estimates' native-sample
    /// records, which only a copy's draw reads ([`SensorNoise::without_samples`]). The
    /// diagnosis releases the sensors' records as soon as the floors are made
    /// ([`NoiseFloors::release_sensor_samples`]) and the rest once the mismatch is located.
    pub fn release_samples(&mut self) {
        for f in &mut self.floors {
            f.null_copies = Vec::new();
            f.null_variance = Vec::new();
        }
        self.release_sensor_samples();
    }

    /// Drops the sensor estimates' native-sample records alone (the part of
    /// [`NoiseFloors::release_samples`] that only the floors' making reads): the diagnosis
    /// releases them as soon as the floors are made.
    pub fn release_sensor_samples(&mut self) {
        for s in &mut self.sensors {
            *s = s.without_samples();
        }
    }

    /// `{"<signal>": floor}` of diagnosis.json, unit of each signal.
    pub fn summary(&self) -> BTreeMap<String, f64> {
        self.floors
            .iter()
            .map(|f| (f.signal.clone(), f.floor))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn too_few_or_ragged_null_copies_are_errors() {
        let v = vec![true; 10];
        assert!(NoiseFloor::from_null_copies(
            "x",
            "1",
            0.02,
            vec![vec![0.0; 10]],
            &v,
            &NoiseConfig::default()
        )
        .is_err());
        assert!(NoiseFloor::from_null_copies(
            "x",
            "1",
            0.02,
            vec![vec![0.0; 10], vec![0.0; 9]],
            &v,
            &NoiseConfig::default()
        )
        .is_err());
    }

    #[test]
    fn white_null_has_about_one_dof_per_row() {
        let cfg = NoiseConfig::default();
        let n = 5000;
        let copies: Vec<Vec<f32>> = (0..12)
            .map(|c| {
                let mut r = stream(3, c, "w");
                (0..n).map(|_| r.standard_normal() as f32).collect()
            })
            .collect();
        let f = NoiseFloor::from_null_copies("w", "1", 0.02, copies, &vec![true; n], &cfg).unwrap();
        assert!((f.floor - 1.0).abs() < 0.02, "{}", f.floor);
        let rows: Vec<usize> = (0..500).collect();
        let nu = f.effective_dof(&rows);
        assert!(nu > 400.0 && nu <= 500.0, "{nu}");
        // the copies agree: white rows keep their degrees of freedom (the pairs' estimate from
        // 12 copies has a relative error of about 0.17 here, √(2/66))
        assert!(f.window_dof(&rows) > 300.0, "{}", f.window_dof(&rows));
    }

    #[test]
    fn a_window_whose_null_is_one_offset_has_about_one_dof_whatever_the_pooled_correlation() {
        // first half white, second half one constant offset per 200-row block (a start-state
        // error held through a re-initialisation window): the pooled autocorrelation is a mix
        // of the two, the copies inside one block are not
        let cfg = NoiseConfig::default();
        let n = 4000;
        let copies: Vec<Vec<f32>> = (0..12)
            .map(|c| {
                let mut r = stream(5, c, "w");
                let mut offset = 0.0;
                (0..n)
                    .map(|i| {
                        if i < n / 2 {
                            r.standard_normal() as f32
                        } else {
                            if (i - n / 2) % 200 == 0 {
                                offset = r.standard_normal() as f32;
                            }
                            offset
                        }
                    })
                    .collect()
            })
            .collect();
        let f = NoiseFloor::from_null_copies("w", "1", 0.02, copies, &vec![true; n], &cfg).unwrap();
        let block: Vec<usize> = (2200..2400).collect();
        let (acf, own) = (f.effective_dof(&block), f.window_dof(&block));
        // one shape with a random amplitude: exactly 1 (f32 copies)
        assert!((own - 1.0).abs() < 1e-5, "window_dof {own}");
        assert!(own < acf, "window_dof {own} vs effective_dof {acf}");
    }

    #[test]
    fn a_drift_in_the_second_half_of_its_window_has_the_dof_of_a_brownian_motion() {
        // the longitudinal null's shape: a random walk restarting every 20 s (1000 rows); its
        // second half [10, 20] s has ν = (∫t dt)² / ∫∫ min(s,t)² ds dt = 22 500 / 18 333 = 1.23
        let cfg = NoiseConfig::default();
        let n = 10_000;
        let copies: Vec<Vec<f32>> = (0..12)
            .map(|c| {
                let mut r = stream(9, c, "b");
                let mut w = 0.0;
                (0..n)
                    .map(|i| {
                        if i % 1000 == 0 {
                            w = 0.0;
                        }
                        w += r.standard_normal();
                        w as f32
                    })
                    .collect()
            })
            .collect();
        let f = NoiseFloor::from_null_copies("b", "1", 0.02, copies, &vec![true; n], &cfg).unwrap();
        let half: Vec<usize> = (3500..4000).collect();
        let own = f.window_dof(&half);
        // 12 copies: the pairs' estimate lies within 1.14–1.56 in 80 % of simulated trials
        assert!(own > 1.0 && own < 1.8, "window_dof {own}");
    }
}
