//! Welch power spectral density with chi-square confidence intervals.
//!
//! [`welch`] equals `scipy.signal.welch(x, fs, nperseg=..., noverlap=...)`
//! with scipy's defaults: periodic Hann window (`get_window('hann', n)`),
//! constant (mean) detrend per segment, `nfft = nperseg`, one-sided density
//! scaling, mean over segments. The interval uses the equivalent degrees of
//! freedom of overlapped windowed segments (Percival & Walden 1993,
//! eq. (292b)).

use num_complex::Complex64;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use statrs::function::gamma::{gamma_lr, gamma_ur, ln_gamma};
use std::borrow::Cow;

use super::error::{check_finite, SignalError};

/// Settings for [`welch`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WelchConfig {
    /// Sampling rate: Hz for time series, samples per metre for
    /// distance-sampled series (frequencies are then in 1/m).
    pub fs_hz: f64,
    /// Samples per segment; `None` = 256 as in scipy. Values larger than the
    /// input are reduced to the input length (scipy does the same).
    pub nperseg: Option<usize>,
    /// Overlap between segments; `None` = `nperseg / 2` (floor).
    pub noverlap: Option<usize>,
    /// Two-sided confidence level of `lower`/`upper`, e.g. 0.95.
    pub confidence: f64,
}

impl Default for WelchConfig {
    /// fs = 1, nperseg 256 (scipy), noverlap nperseg/2, 95 % interval.
    fn default() -> Self {
        WelchConfig {
            fs_hz: 1.0,
            nperseg: None,
            noverlap: None,
            confidence: 0.95,
        }
    }
}

/// One-sided Welch PSD estimate with its confidence interval.
#[derive(Debug, Clone, PartialEq)]
pub struct WelchPsd {
    /// Bin frequencies `k·fs/nperseg`, k = 0..=nperseg/2 (unit of `fs_hz`).
    pub freq_hz: Vec<f64>,
    /// Power spectral density, unit²/Hz (unit²/(1/m) when `fs_hz` is in
    /// samples per metre); integrates (sum × Δf) to the variance.
    pub psd: Vec<f64>,
    /// Lower confidence bound `ν·P/χ²_ν((1+c)/2)`, same unit as `psd`.
    pub lower: Vec<f64>,
    /// Upper confidence bound `ν·P/χ²_ν((1−c)/2)`, same unit as `psd`.
    pub upper: Vec<f64>,
    /// Number of averaged segments.
    pub n_segments: usize,
    /// Equivalent degrees of freedom ν (P&W eq. (292b)); applied to every
    /// bin (at DC and Nyquist the true value is about half, as those bins
    /// are real-valued).
    pub dof: f64,
    /// Segment length actually used.
    pub nperseg: usize,
    /// Overlap actually used.
    pub noverlap: usize,
}

/// Periodic Hann window of length `n` (= `scipy.signal.get_window('hann',
/// n)`): `0.5 + 0.5·cos(φ_k)`, `φ_k = −π + k·2π/n`, k = 0..n−1 (scipy's
/// `general_cosine` on n+1 points, truncated). `n ≤ 1` gives ones.
pub fn hann_periodic(n: usize) -> Vec<f64> {
    if n <= 1 {
        return vec![1.0; n];
    }
    let m = n + 1;
    let step = (std::f64::consts::PI - (-std::f64::consts::PI)) / (m - 1) as f64;
    (0..n)
        .map(|k| {
            let fac = k as f64 * step + (-std::f64::consts::PI);
            0.5 + 0.5 * fac.cos()
        })
        .collect()
}

/// Welch PSD (= `scipy.signal.welch(x, fs=cfg.fs_hz, nperseg=...,
/// noverlap=...)`, defaults otherwise) plus chi-square confidence bounds.
///
/// Segments start at `k·(nperseg − noverlap)`; trailing samples that do
/// not fill a segment are dropped. Each segment has its mean removed, is
/// multiplied by the periodic Hann window `w`, and `|FFT|²/(fs·Σw²)` is
/// taken, doubled for all bins except DC and (even `nperseg`) Nyquist; the
/// result is the mean over segments. If `len < nperseg`, `nperseg = len`.
///
/// Errors: [`SignalError::NonFinite`] (first index),
/// [`SignalError::InvalidSegment`] (empty input, `nperseg = 0`,
/// `noverlap ≥ nperseg`), [`SignalError::InvalidSampleRate`],
/// [`SignalError::InvalidConfidence`].
pub fn welch(x: &[f64], cfg: &WelchConfig) -> Result<WelchPsd, SignalError> {
    check_finite(x)?;
    if !(cfg.fs_hz.is_finite() && cfg.fs_hz > 0.0) {
        return Err(SignalError::InvalidSampleRate { fs_hz: cfg.fs_hz });
    }
    if !(cfg.confidence > 0.0 && cfg.confidence < 1.0) {
        return Err(SignalError::InvalidConfidence {
            confidence: cfg.confidence,
        });
    }
    let len = x.len();
    let mut nperseg = cfg.nperseg.unwrap_or(256);
    if nperseg > len {
        nperseg = len;
    }
    let noverlap = cfg.noverlap.unwrap_or(nperseg / 2);
    if len == 0 || nperseg == 0 || noverlap >= nperseg {
        return Err(SignalError::InvalidSegment {
            nperseg,
            noverlap,
            len,
        });
    }
    let step = nperseg - noverlap;
    let n_segments = (len - noverlap) / step;
    let win = hann_periodic(nperseg);
    let win_ss: f64 = win.iter().map(|w| w * w).sum();
    let scale = 1.0 / (cfg.fs_hz * win_ss);
    let nfreq = nperseg / 2 + 1;

    let fft = super::fft_plans::forward(nperseg);
    let mut buf = fft.make_input_vec();
    let mut spec = fft.make_output_vec();
    let mut scratch = fft.make_scratch_vec();
    let mut acc = vec![0.0; nfreq];
    for s in 0..n_segments {
        let seg = &x[s * step..s * step + nperseg];
        let mean = seg.iter().sum::<f64>() / nperseg as f64;
        for ((b, &v), &w) in buf.iter_mut().zip(seg).zip(&win) {
            *b = w * (v - mean);
        }
        fft.process_with_scratch(&mut buf, &mut spec, &mut scratch)
            .expect("buffer sizes come from the plan");
        for (a, c) in acc.iter_mut().zip(&spec) {
            *a += power(c) * scale;
        }
    }
    let last_doubled = if nperseg % 2 == 1 { nfreq } else { nfreq - 1 };
    let nseg_f = n_segments as f64;
    let psd: Vec<f64> = acc
        .iter()
        .enumerate()
        .map(|(k, a)| {
            let d = if k >= 1 && k < last_doubled { 2.0 } else { 1.0 };
            a * d / nseg_f
        })
        .collect();

    // rfftfreq(n, d=1/fs)
    let val = 1.0 / (nperseg as f64 * (1.0 / cfg.fs_hz));
    let freq_hz: Vec<f64> = (0..nfreq).map(|k| k as f64 * val).collect();

    let dof = equivalent_dof(&win, step, n_segments);
    let c = cfg.confidence;
    let q_hi = chi2_ppf((1.0 + c) / 2.0, dof);
    let q_lo = chi2_ppf((1.0 - c) / 2.0, dof);
    let lower = psd.iter().map(|p| dof * p / q_hi).collect();
    let upper = psd.iter().map(|p| dof * p / q_lo).collect();

    Ok(WelchPsd {
        freq_hz,
        psd,
        lower,
        upper,
        n_segments,
        dof,
        nperseg,
        noverlap,
    })
}

/// Welch cross-spectral density of two series, with both auto-spectra (for coherence).
#[derive(Debug, Clone, PartialEq)]
pub struct WelchCsd {
    /// Bin frequencies `k·fs/nperseg`, k = 0..=nperseg/2 (unit of `fs_hz`).
    pub freq_hz: Vec<f64>,
    /// One-sided PSD of `x`, unit_x²/Hz.
    pub pxx: Vec<f64>,
    /// One-sided PSD of `y`, unit_y²/Hz.
    pub pyy: Vec<f64>,
    /// One-sided cross-spectral density `E[conj(X)·Y]` (scipy's `csd(x, y)` convention),
    /// unit_x·unit_y/Hz.
    pub pxy: Vec<Complex64>,
    /// Number of averaged segments (over all pieces).
    pub n_segments: usize,
    /// Equivalent degrees of freedom of the averaged auto-spectra (P&W eq. (292b) per piece,
    /// summed over pieces).
    pub dof: f64,
    /// Segment length used.
    pub nperseg: usize,
    /// Overlap used.
    pub noverlap: usize,
}

impl WelchCsd {
    /// Magnitude-squared coherence `|Pxy|² / (Pxx·Pyy)` per bin, in [0, 1] (0 where either
    /// auto-spectrum is 0).
    pub fn coherence(&self) -> Vec<f64> {
        self.pxy
            .iter()
            .zip(self.pxx.iter().zip(&self.pyy))
            .map(|(c, (a, b))| {
                let d = a * b;
                if d > 0.0 {
                    (power(c) / d).min(1.0)
                } else {
                    0.0
                }
            })
            .collect()
    }
}

/// Welch cross-spectral density (= `scipy.signal.csd(x, y, fs, nperseg=..., noverlap=...)`,
/// periodic Hann window, mean detrend per segment, one-sided density) together with both
/// auto-spectra. `x` and `y` must have the same length. If `len < nperseg`, `nperseg = len`.
///
/// Errors: as [`welch`], plus [`SignalError::InvalidSegment`] for unequal lengths.
pub fn csd(x: &[f64], y: &[f64], cfg: &WelchConfig) -> Result<WelchCsd, SignalError> {
    let nperseg = cfg.nperseg.unwrap_or(256).min(x.len());
    let cfg = WelchConfig {
        nperseg: Some(nperseg),
        ..*cfg
    };
    csd_pieces(&[(x, y)], &cfg)
}

/// [`csd`] averaged over the segments of several pieces of one recording (e.g. the stretches
/// between gaps): every piece is cut into segments of `nperseg` samples with the configured
/// overlap, pieces shorter than a segment are skipped, and all segments are averaged alike.
/// Unlike [`csd`], `nperseg` is not shortened to a piece (segments keep one frequency grid).
///
/// Errors: [`SignalError::NonFinite`] (index within its piece),
/// [`SignalError::InvalidSegment`] (no piece as long as a segment, unequal piece lengths,
/// `nperseg = 0`, `noverlap ≥ nperseg`), [`SignalError::InvalidSampleRate`].
pub fn csd_pieces(pieces: &[(&[f64], &[f64])], cfg: &WelchConfig) -> Result<WelchCsd, SignalError> {
    csd_piece_stream(
        || {
            pieces
                .iter()
                .map(|&(x, y)| (Cow::Borrowed(x), Cow::Borrowed(y)))
        },
        cfg,
    )
}

/// [`csd_pieces`] with the pieces made as they are read: `pieces()` yields the same pieces in
/// the same order each time it is called (twice: once to check them, once to transform them),
/// so pieces converted on the fly (a single-precision series read in double precision, say)
/// are held one at a time, never all together. The result is [`csd_pieces`]'s on the same
/// pieces, bit for bit (the segments are summed in the same order).
///
/// Errors: as [`csd_pieces`].
pub fn csd_piece_stream<'a, I, F>(pieces: F, cfg: &WelchConfig) -> Result<WelchCsd, SignalError>
where
    F: Fn() -> I,
    I: Iterator<Item = (Cow<'a, [f64]>, Cow<'a, [f64]>)>,
{
    if !(cfg.fs_hz.is_finite() && cfg.fs_hz > 0.0) {
        return Err(SignalError::InvalidSampleRate { fs_hz: cfg.fs_hz });
    }
    let nperseg = cfg.nperseg.unwrap_or(256);
    let noverlap = cfg.noverlap.unwrap_or(nperseg / 2);
    let bad = |len| SignalError::InvalidSegment {
        nperseg,
        noverlap,
        len,
    };
    // one pass for the checks: the longest piece, and the first piece's fault
    let mut longest = 0;
    let mut fault = None;
    for (x, y) in pieces() {
        longest = longest.max(x.len());
        if fault.is_none() {
            fault = if x.len() != y.len() {
                Some(bad(y.len()))
            } else {
                check_finite(&x).and_then(|()| check_finite(&y)).err()
            };
        }
    }
    if nperseg == 0 || noverlap >= nperseg || longest < nperseg {
        return Err(bad(longest));
    }
    if let Some(e) = fault {
        return Err(e);
    }
    let step = nperseg - noverlap;
    let win = hann_periodic(nperseg);
    let win_ss: f64 = win.iter().map(|w| w * w).sum();
    let scale = 1.0 / (cfg.fs_hz * win_ss);
    let nfreq = nperseg / 2 + 1;
    let fft = super::fft_plans::forward(nperseg);
    let mut buf = fft.make_input_vec();
    let mut sx = fft.make_output_vec();
    let mut sy = fft.make_output_vec();
    let mut scratch = fft.make_scratch_vec();
    let mut axx = vec![0.0; nfreq];
    let mut ayy = vec![0.0; nfreq];
    let mut axy = vec![Complex64::new(0.0, 0.0); nfreq];
    let (mut n_segments, mut dof) = (0usize, 0.0);
    let mut transform = |seg: &[f64], out: &mut Vec<Complex64>| {
        let mean = seg.iter().sum::<f64>() / nperseg as f64;
        for ((b, &v), &w) in buf.iter_mut().zip(seg).zip(&win) {
            *b = w * (v - mean);
        }
        fft.process_with_scratch(&mut buf, out, &mut scratch)
            .expect("buffer sizes come from the plan");
    };
    for (x, y) in pieces() {
        if x.len() < nperseg {
            continue;
        }
        let k = (x.len() - noverlap) / step;
        for s in 0..k {
            transform(&x[s * step..s * step + nperseg], &mut sx);
            transform(&y[s * step..s * step + nperseg], &mut sy);
            for f in 0..nfreq {
                axx[f] += power(&sx[f]) * scale;
                ayy[f] += power(&sy[f]) * scale;
                axy[f] += sx[f].conj() * sy[f] * scale;
            }
        }
        n_segments += k;
        dof += equivalent_dof(&win, step, k);
    }
    let last_doubled = if nperseg % 2 == 1 { nfreq } else { nfreq - 1 };
    let nseg_f = n_segments as f64;
    let factor = |k: usize| {
        if k >= 1 && k < last_doubled {
            2.0 / nseg_f
        } else {
            1.0 / nseg_f
        }
    };
    let val = cfg.fs_hz / nperseg as f64;
    Ok(WelchCsd {
        freq_hz: (0..nfreq).map(|k| k as f64 * val).collect(),
        pxx: axx.iter().enumerate().map(|(k, a)| a * factor(k)).collect(),
        pyy: ayy.iter().enumerate().map(|(k, a)| a * factor(k)).collect(),
        pxy: axy.iter().enumerate().map(|(k, a)| a * factor(k)).collect(),
        n_segments,
        dof,
        nperseg,
        noverlap,
    })
}

fn power(c: &Complex64) -> f64 {
    c.re * c.re + c.im * c.im
}

/// Equivalent degrees of freedom of a Welch average of `n_segments`
/// segments with window `win` and hop `step` (Percival & Walden 1993,
/// eq. (292b)):
/// `ν = 2·N_B / (1 + 2·Σ_{m=1}^{N_B−1} (1 − m/N_B)·ρ(m)²)`,
/// `ρ(m) = Σ_t w_t·w_{t+m·step} / Σ_t w_t²`. Non-overlapping segments give
/// `2·N_B`; 50 %-overlapped Hann segments about `1.89·N_B` for large `N_B`.
pub fn equivalent_dof(win: &[f64], step: usize, n_segments: usize) -> f64 {
    let nb = n_segments as f64;
    let ss: f64 = win.iter().map(|w| w * w).sum();
    let mut sum = 0.0;
    for m in 1..n_segments {
        let lag = m * step;
        if lag >= win.len() {
            break;
        }
        let rho: f64 = win[..win.len() - lag]
            .iter()
            .zip(&win[lag..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / ss;
        sum += (1.0 - m as f64 / nb) * rho * rho;
    }
    2.0 * nb / (1.0 + 2.0 * sum)
}

/// Chi-square quantile (= `scipy.stats.chi2.ppf(p, dof)`), `dof > 0`
/// (non-integer allowed), `0 < p < 1`.
///
/// Starts from statrs' `ChiSquared::inverse_cdf` and polishes it with
/// Newton steps on the regularised incomplete gamma function (on the upper
/// tail when `p > 0.5`, to avoid cancellation), because statrs' own
/// iteration stops early. Returns NaN for arguments out of range.
pub fn chi2_ppf(p: f64, dof: f64) -> f64 {
    if !(p > 0.0 && p < 1.0 && dof > 0.0 && dof.is_finite()) {
        return f64::NAN;
    }
    let Ok(dist) = ChiSquared::new(dof) else {
        return f64::NAN;
    };
    let mut x = dist.inverse_cdf(p);
    if !(x.is_finite() && x > 0.0) {
        x = dof.max(1e-3);
    }
    let k = dof / 2.0;
    let ln_norm = k * std::f64::consts::LN_2 + ln_gamma(k);
    let upper = p > 0.5;
    for _ in 0..50 {
        let (f, target) = if upper {
            (gamma_ur(k, x / 2.0), 1.0 - p)
        } else {
            (gamma_lr(k, x / 2.0), p)
        };
        let pdf = ((k - 1.0) * x.ln() - x / 2.0 - ln_norm).exp();
        if pdf <= 0.0 || !pdf.is_finite() {
            break;
        }
        let mut dx = (f - target) / pdf;
        if upper {
            dx = -dx;
        }
        let mut xn = x - dx;
        if xn <= 0.0 {
            xn = x / 2.0;
        }
        let done = (xn - x).abs() <= 4.0 * f64::EPSILON * x;
        x = xn;
        if done {
            break;
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pieces made on the fly (single-precision series read in double precision) give the
    /// spectrum of the same pieces given at once, bit for bit, and the same errors.
    #[test]
    fn a_stream_of_pieces_is_the_pieces_at_once() {
        let series: Vec<Vec<f32>> = (0..3)
            .map(|c| {
                (0..700 + 97 * c)
                    .map(|i| ((i as f32) * 0.37 + c as f32).sin() + 0.01 * (i % 7) as f32)
                    .collect()
            })
            .collect();
        let wide: Vec<Vec<f64>> = series
            .iter()
            .map(|s| s.iter().map(|x| f64::from(*x)).collect())
            .collect();
        let cfg = WelchConfig {
            fs_hz: 50.0,
            nperseg: Some(128),
            noverlap: None,
            confidence: 0.95,
        };
        let at_once: Vec<(&[f64], &[f64])> =
            wide.iter().map(|w| (w.as_slice(), w.as_slice())).collect();
        let a = csd_pieces(&at_once, &cfg).unwrap();
        let b = csd_piece_stream(
            || {
                series.iter().map(|s| {
                    let w: Vec<f64> = s.iter().map(|x| f64::from(*x)).collect();
                    (Cow::Owned(w.clone()), Cow::Owned(w))
                })
            },
            &cfg,
        )
        .unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
        assert_eq!(bits(&a.pxx), bits(&b.pxx));
        assert_eq!(bits(&a.pyy), bits(&b.pyy));
        assert_eq!(a.n_segments, b.n_segments);
        assert_eq!(a.dof.to_bits(), b.dof.to_bits());
        // a non-finite sample is the same error either way
        let mut bad = wide.clone();
        bad[1][5] = f64::NAN;
        let at_once: Vec<(&[f64], &[f64])> =
            bad.iter().map(|w| (w.as_slice(), w.as_slice())).collect();
        let e1 = csd_pieces(&at_once, &cfg).unwrap_err();
        let e2 = csd_piece_stream(
            || {
                bad.iter()
                    .map(|w| (Cow::Borrowed(&w[..]), Cow::Borrowed(&w[..])))
            },
            &cfg,
        )
        .unwrap_err();
        assert_eq!(format!("{e1:?}"), format!("{e2:?}"));
    }

    #[test]
    fn dof_limits() {
        let w = hann_periodic(256);
        // One segment: 2 dof; non-overlapping segments: 2 per segment.
        assert!((equivalent_dof(&w, 128, 1) - 2.0).abs() < 1e-12);
        assert!((equivalent_dof(&w, 256, 10) - 20.0).abs() < 1e-12);
        // 50 % overlapped Hann: rho(1) = 1/6 -> nu -> 2 N / (1 + 2/36) for large N.
        let nu = equivalent_dof(&w, 128, 1000);
        let want = 2000.0 / (1.0 + 2.0 * (1.0 - 1.0 / 1000.0) / 36.0);
        assert!((nu - want).abs() < 1e-6 * want, "{nu} vs {want}");
    }

    #[test]
    fn rejects_bad_configs() {
        let x = vec![0.0; 100];
        let c = |nperseg, noverlap| WelchConfig {
            nperseg,
            noverlap,
            ..WelchConfig::default()
        };
        assert!(matches!(
            welch(&[], &WelchConfig::default()),
            Err(SignalError::InvalidSegment { len: 0, .. })
        ));
        assert!(welch(&x, &c(Some(0), None)).is_err());
        assert!(welch(&x, &c(Some(50), Some(50))).is_err());
        let bad = WelchConfig {
            confidence: 1.0,
            ..WelchConfig::default()
        };
        assert!(welch(&x, &bad).is_err());
        let bad = WelchConfig {
            fs_hz: 0.0,
            ..WelchConfig::default()
        };
        assert!(welch(&x, &bad).is_err());
        let mut y = x.clone();
        y[3] = f64::NEG_INFINITY;
        assert!(matches!(
            welch(&y, &WelchConfig::default()),
            Err(SignalError::NonFinite { index: 3, .. })
        ));
        // len < nperseg -> nperseg = len, noverlap = len/2 (scipy).
        let r = welch(&x, &WelchConfig::default()).unwrap();
        assert_eq!((r.nperseg, r.noverlap, r.n_segments), (100, 50, 1));
    }

    #[test]
    fn csd_of_a_series_with_itself_is_its_welch_psd() {
        let x: Vec<f64> = (0..3000)
            .map(|i| ((i * 7919) % 1000) as f64 / 1000.0 + (i as f64 * 0.05).sin())
            .collect();
        let cfg = WelchConfig {
            fs_hz: 50.0,
            nperseg: Some(256),
            ..WelchConfig::default()
        };
        let w = welch(&x, &cfg).unwrap();
        let c = csd(&x, &x, &cfg).unwrap();
        assert_eq!(c.n_segments, w.n_segments);
        for k in 0..w.psd.len() {
            assert!((c.pxx[k] - w.psd[k]).abs() <= 1e-12 * w.psd[k].max(1e-300));
            assert!((c.pxy[k].re - w.psd[k]).abs() <= 1e-12 * w.psd[k].max(1e-300));
            assert!(c.pxy[k].im.abs() <= 1e-12 * w.psd[k].max(1e-300));
        }
        assert!(c
            .coherence()
            .iter()
            .all(|&g| (g - 1.0).abs() < 1e-9 || g == 0.0));
        // y = 2·x delayed by one sample: coherence 1, phase −2πf·dt (conj(X)·Y convention)
        let y: Vec<f64> = (0..3000)
            .map(|i| if i == 0 { 0.0 } else { 2.0 * x[i - 1] })
            .collect();
        let c = csd(&x, &y, &cfg).unwrap();
        let k = 40; // 40·50/256 = 7.8 Hz
        let phase = c.pxy[k].arg();
        let want = -std::f64::consts::TAU * c.freq_hz[k] / 50.0;
        assert!((phase - want).abs() < 0.05, "{phase} vs {want}");
        assert!(c.coherence()[k] > 0.95);
        // pieces: two halves give twice the segments of one half
        let h = csd_pieces(&[(&x[..1500], &y[..1500]), (&x[1500..], &y[1500..])], &cfg).unwrap();
        let one = csd_pieces(&[(&x[..1500], &y[..1500])], &cfg).unwrap();
        assert_eq!(h.n_segments, 2 * one.n_segments);
        assert!(csd_pieces(&[(&x[..100], &y[..100])], &cfg).is_err());
        assert!(csd_pieces(&[(&x[..1000], &y[..900])], &cfg).is_err());
    }

    #[test]
    fn interval_brackets_psd() {
        let x: Vec<f64> = (0..4096)
            .map(|i| ((i * 7919) % 1000) as f64 / 1000.0)
            .collect();
        let r = welch(&x, &WelchConfig::default()).unwrap();
        assert_eq!(r.n_segments, 31);
        for k in 0..r.psd.len() {
            assert!(r.lower[k] <= r.psd[k] && r.psd[k] <= r.upper[k]);
        }
        assert!(r.dof > 50.0 && r.dof < 62.0, "{}", r.dof);
    }
}
