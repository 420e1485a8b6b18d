//! Step 2 of the diagnosis, locate, in frequency (docs/diagnosis/method.md): the residual of a
//! signal against its noise floor by band, and its coherence and cross-correlation with the
//! recorded inputs, over the rows that count.
//!
//! # In frequency
//! - residual power by band ([`BandPower`]): quasi-static (below 0.5 Hz), the driveline
//!   shuffle band around the vehicle's resonances
//!   ([`shuffle_band_hz`](super::locate_config::shuffle_band_hz)), the bands between, and the
//!   axle-hop band (8–15 Hz) where the signal's native rate resolves it; each against the
//!   floor's null power in the same band (F test with Welch degrees of freedom);
//! - input → residual magnitude-squared coherence ([`InputCoherence`], Welch with 10 s
//!   segments over the stretches where both exist), with the null threshold
//!   `1 − (α/m)^{1/(n_d−1)}` for `n_d` equivalent independent segments and `m` bins per band;
//! - input–residual cross-correlation ([`InputLag`]) of the first differences (differencing
//!   whitens the slowly varying drive signals so the peak is sharp) within ±2 s; the peak lag
//!   is where the residual *follows* the input (positive: the residual lags). Threshold:
//!   Bartlett's variance `Σ_j ρ_xx(j)ρ_rr(j) / N`, Bonferroni over the lags.
//!
//! The bands are cut at the signal's native Nyquist frequency (the grid's when unknown); a band
//! above it is not observable. Powers in the signal's unit², frequencies in Hz, lags in s.

use super::locate_config::{LocateConfig, NamedSeries};
use super::location::{BandCoherence, BandPower, InputCoherence, InputLag};
use super::noise::{segment_mean_square, NoiseFloor};
use crate::signal::stats::runs;
use crate::signal::stats::{f_sf, xcorr_sums, z_quantile};
use crate::signal::{csd_pieces, WelchConfig};

/// A frequency band of the analysis.
#[derive(Debug, Clone)]
pub(super) struct Band {
    pub(super) name: &'static str,
    pub(super) lo: f64,
    pub(super) hi: f64,
}

pub(super) fn bands(cfg: &LocateConfig, nyquist: f64) -> Vec<Band> {
    let qs = cfg.quasi_static_hz;
    let [hop_lo, hop_hi] = cfg.hop_band_hz;
    let mut b = vec![Band {
        name: "quasi_static",
        lo: 0.0,
        hi: qs,
    }];
    match cfg.shuffle_band_hz {
        Some([lo, hi]) => {
            let lo = lo.max(qs);
            if lo > qs {
                b.push(Band {
                    name: "transition",
                    lo: qs,
                    hi: lo,
                });
            }
            if hi > lo {
                b.push(Band {
                    name: "shuffle",
                    lo,
                    hi,
                });
            }
            if hop_lo > hi {
                b.push(Band {
                    name: "high",
                    lo: hi,
                    hi: hop_lo,
                });
            }
        }
        None => {
            if hop_lo > qs {
                b.push(Band {
                    name: "dynamic",
                    lo: qs,
                    hi: hop_lo,
                });
            }
        }
    }
    b.push(Band {
        name: "axle_hop",
        lo: hop_lo,
        hi: hop_hi,
    });
    b.into_iter()
        .filter(|x| x.lo < nyquist)
        .map(|mut x| {
            x.hi = x.hi.min(nyquist);
            x
        })
        .collect()
}

/// Band power by summing PSD bins with `lo ≤ f < hi` (bin 0, the mean, left out), and bins.
pub(super) fn band_power(freq: &[f64], psd: &[f64], lo: f64, hi: f64) -> (f64, usize) {
    let df = if freq.len() > 1 {
        freq[1] - freq[0]
    } else {
        0.0
    };
    let mut s = 0.0;
    let mut k = 0;
    for (f, p) in freq.iter().zip(psd).skip(1) {
        if *f >= lo && *f < hi {
            s += p * df;
            k += 1;
        }
    }
    (s, k)
}

/// Native Nyquist frequency of a floor's signal (grid Nyquist when unknown), Hz.
pub(super) fn native_nyquist(floor: &NoiseFloor, dt: f64) -> f64 {
    let grid = 0.5 / dt;
    floor
        .sensor
        .as_ref()
        .map_or(grid, |s| (0.5 * s.native_rate_hz).min(grid))
}

/// Welch PSD of `x` over its `usable` runs with `nperseg`-row segments: (freq, psd, dof, power
/// of the segment means).
pub(super) fn psd_over(
    x: &[f64],
    usable: &[bool],
    nperseg: usize,
    dt: f64,
) -> Option<(Vec<f64>, Vec<f64>, f64, f64)> {
    let pieces: Vec<(&[f64], &[f64])> = runs(usable)
        .into_iter()
        .map(|(a, b)| (&x[a..b], &x[a..b]))
        .collect();
    let c = csd_pieces(
        &pieces,
        &WelchConfig {
            fs_hz: 1.0 / dt,
            nperseg: Some(nperseg),
            noverlap: None,
            confidence: 0.95,
        },
    )
    .ok()?;
    let dc = segment_mean_square(&pieces.iter().map(|p| p.0).collect::<Vec<_>>(), nperseg);
    Some((c.freq_hz, c.pxx, c.dof, dc))
}

pub(super) fn band_powers(
    r: &[f64],
    usable: &[bool],
    floor: &NoiseFloor,
    cfg: &LocateConfig,
    dt: f64,
) -> Vec<BandPower> {
    if !(dt.is_finite() && dt > 0.0) {
        return Vec::new();
    }
    let Some(null) = &floor.null_psd else {
        return Vec::new();
    };
    let res = psd_over(r, usable, null.nperseg, dt);
    let nyq = native_nyquist(floor, dt);
    bands(cfg, 0.5 / dt)
        .into_iter()
        .map(|b| {
            let observable = b.lo < nyq;
            let hi = b.hi.min(nyq);
            let mut out = BandPower {
                band: b.name.into(),
                lo_hz: b.lo,
                hi_hz: b.hi,
                observable,
                residual_power: None,
                null_power: None,
                ratio: None,
                p_value: None,
            };
            if let (true, Some((f, p, dof, dc))) = (observable, &res) {
                // the lowest band also holds what is slower than a segment (a constant offset)
                let (dc_r, dc_n) = if b.lo == 0.0 {
                    (*dc, null.dc_power)
                } else {
                    (0.0, 0.0)
                };
                let (pr, k) = band_power(f, p, b.lo, hi);
                let (pn, _) = band_power(&null.freq_hz, &null.psd, b.lo, hi);
                let (pr, pn) = (pr + dc_r, pn + dc_n);
                if k > 0 {
                    out.residual_power = Some(pr);
                    out.null_power = Some(pn);
                    if pn > 0.0 {
                        let ratio = pr / pn;
                        // Hann-windowed neighbouring bins overlap: ~1.5 bins per independent one
                        let kb = (k as f64 / 1.5).max(1.0);
                        out.ratio = Some(ratio);
                        out.p_value = Some(f_sf(ratio, dof * kb, null.dof * kb));
                    }
                }
            }
            out
        })
        .collect()
}

pub(super) fn coherence(
    x: &NamedSeries,
    r: &[f64],
    usable: &[bool],
    floor: &NoiseFloor,
    cfg: &LocateConfig,
    dt: f64,
) -> Option<InputCoherence> {
    if !(dt.is_finite() && dt > 0.0) {
        return None;
    }
    let ok: Vec<bool> = (0..r.len())
        .map(|i| usable[i] && x.values[i].is_finite())
        .collect();
    let nperseg = floor
        .null_psd
        .as_ref()
        .map_or(((10.0 / dt).round() as usize).max(8), |p| p.nperseg);
    let pieces: Vec<(&[f64], &[f64])> = runs(&ok)
        .into_iter()
        .map(|(a, b)| (&x.values[a..b], &r[a..b]))
        .collect();
    let c = csd_pieces(
        &pieces,
        &WelchConfig {
            fs_hz: 1.0 / dt,
            nperseg: Some(nperseg),
            noverlap: None,
            confidence: 0.95,
        },
    )
    .ok()?;
    let coh = c.coherence();
    let nd = 0.5 * c.dof;
    let nyq = native_nyquist(floor, dt);
    let bands = bands(cfg, 0.5 / dt)
        .into_iter()
        .filter(|b| b.lo < nyq)
        .filter_map(|b| {
            let hi = b.hi.min(nyq);
            let bins: Vec<usize> = (1..coh.len())
                .filter(|&k| c.freq_hz[k] >= b.lo && c.freq_hz[k] < hi)
                .collect();
            if bins.is_empty() {
                return None;
            }
            let mean = bins.iter().map(|&k| coh[k]).sum::<f64>() / bins.len() as f64;
            let &kp = bins.iter().max_by(|&&a, &&b| coh[a].total_cmp(&coh[b]))?;
            let threshold = if nd > 1.0 {
                1.0 - (cfg.alpha / bins.len() as f64).powf(1.0 / (nd - 1.0))
            } else {
                1.0
            };
            Some(BandCoherence {
                band: b.name.into(),
                lo_hz: b.lo,
                hi_hz: hi,
                mean,
                peak: coh[kp],
                peak_hz: c.freq_hz[kp],
                threshold,
                significant: coh[kp] > threshold,
            })
        })
        .collect();
    Some(InputCoherence {
        input: x.name.clone(),
        segments: c.n_segments,
        bands,
    })
}

pub(super) fn lag(
    x: &NamedSeries,
    r: &[f64],
    usable: &[bool],
    cfg: &LocateConfig,
    dt: f64,
) -> Option<InputLag> {
    if !(dt.is_finite() && dt > 0.0) {
        return None;
    }
    let n = r.len();
    let ok: Vec<bool> = (0..n)
        .map(|i| {
            i > 0
                && usable[i]
                && usable[i - 1]
                && x.values[i].is_finite()
                && x.values[i - 1].is_finite()
        })
        .collect();
    let cnt = ok.iter().filter(|o| **o).count();
    let l = ((cfg.max_lag_s / dt).round() as usize).min(n / 4);
    if cnt < 4 * l.max(1) {
        return None;
    }
    let mut dx: Vec<f64> = (0..n)
        .map(|i| {
            if ok[i] {
                x.values[i] - x.values[i - 1]
            } else {
                0.0
            }
        })
        .collect();
    let mut dr: Vec<f64> = (0..n)
        .map(|i| if ok[i] { r[i] - r[i - 1] } else { 0.0 })
        .collect();
    for v in [&mut dx, &mut dr] {
        let m = v
            .iter()
            .zip(&ok)
            .filter(|(_, o)| **o)
            .map(|(x, _)| x)
            .sum::<f64>()
            / cnt as f64;
        for (x, o) in v.iter_mut().zip(&ok) {
            if *o {
                *x -= m;
            }
        }
    }
    let ex: f64 = dx.iter().map(|v| v * v).sum();
    let er: f64 = dr.iter().map(|v| v * v).sum();
    if !(ex > 0.0 && er > 0.0) {
        return None;
    }
    let norm = (ex * er).sqrt();
    let xc: Vec<f64> = xcorr_sums(&dx, &dr, l).iter().map(|v| v / norm).collect();
    let axx = xcorr_sums(&dx, &dx, l);
    let arr = xcorr_sums(&dr, &dr, l);
    // Bartlett: Var ρ̂_xr(k) ≈ Σ_j ρ_xx(j)·ρ_rr(j) / N for independent series
    let bartlett: f64 = axx
        .iter()
        .zip(&arr)
        .map(|(a, b)| (a / ex) * (b / er))
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    let sd = (bartlett / cnt as f64).sqrt();
    let z = z_quantile(1.0 - cfg.alpha / (2.0 * (2 * l + 1) as f64));
    let threshold = z * sd;
    let (kp, &vp) = xc
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))?;
    Some(InputLag {
        input: x.name.clone(),
        lag_s: (kp as f64 - l as f64) * dt,
        value: vp,
        zero_lag_value: xc[l],
        threshold,
        significant: vp.abs() > threshold,
    })
}
