//! Spatial spectra of road slope and studies over many random roads (Myklebust & Eriksson
//! (2012), §4; docs/models/road.md).
//!
//! **One road** ([`slope_spectrum`]): the Welch PSD of the slope on its distance grid
//! (`scipy.signal.welch` conventions, see [`crate::signal::welch`]: periodic Hann segments of
//! `segment_length_m`, 50 % overlap, mean removed per segment, one-sided density) in (tan α)²/(1/m)
//! over spatial frequency in 1/m, its chi-square confidence band (equivalent degrees of freedom of
//! overlapped Hann segments), the cumulative power and the "knees" — the frequencies below which 90
//! % and 99 % of the power lies ([`crate::signal::knee_frequency`]; Myklebust & Eriksson (2012),
//! §4: "most of the power is in spatial frequencies below 3·10⁻⁴ 1/m" for highways, 10⁻³ 1/m for
//! city roads), plus the half-power frequency (50 %), which for a first-order spectrum is its
//! corner, the knee seen on a log–log plot. Alongside, the magnitude response of the road-slope
//! filter ([`crate::road::slope_filter`]: 3rd-order Butterworth, f_co = 4·10⁻³ 1/m, −30 dB required
//! at 2·10⁻² 1/m) on the same frequencies: the off-line zero-phase filter's |H|² and the on-line
//! causal filter's |H|, in dB.
//!
//! **A study** ([`run_study`]): `n_roads` roads drawn from one rule set with the seeds
//! `seed, seed+1, …, seed+n_roads−1`, each analysed as above, in parallel on the current rayon
//! pool. Per frequency bin it reports the 5th, 50th and 95th percentile and the mean of the PSD
//! across roads; it reports the knees of every road, their percentiles, and the knees of the
//! mean PSD. Determinism: each road is a pure function of its seed; the per-road results are
//! collected in seed order and only then reduced (sums in seed order, percentiles from sorted
//! copies), so the output does not depend on the number of threads.
//!
//! Percentiles are numpy's default ("linear"): the value at rank p·(n−1) of the sorted sample,
//! interpolated between neighbouring ranks.

use super::rules::RoadRules;
use super::slope_filter::SlopeFilterConfig;
use super::synth::{generate, SynthError};
use crate::signal::{
    butter, cumulative_power, knee_frequency, share_below, try_lowest_order_meeting, welch,
    BandType, SignalError, WelchConfig, WelchPsd,
};
use rayon::prelude::*;
use thiserror::Error;

/// Most roads in one study (each keeps its PSD until the reduction).
pub const MAX_ROADS: usize = 10_000;

/// Welch settings for road spectra.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SpectrumSettings {
    /// Welch segment length, m (rounded to whole grid steps). The frequency resolution is its
    /// inverse: the default 16 384 m gives 6.1·10⁻⁵ 1/m, five bins below the highway knee of
    /// Myklebust & Eriksson (2012), §4.
    pub segment_length_m: f64,
    /// Two-sided confidence level of the PSD band.
    pub confidence: f64,
}

impl Default for SpectrumSettings {
    fn default() -> Self {
        Self {
            segment_length_m: 16_384.0,
            confidence: 0.95,
        }
    }
}

impl SpectrumSettings {
    /// Checks the confidence level (strictly between 0 and 1); the segment length is checked
    /// against the road's grid where the spectrum is computed.
    pub fn validate(&self) -> Result<(), crate::settings::InvalidSetting> {
        let c = self.confidence;
        crate::settings::require(
            c > 0.0 && c < 1.0,
            "confidence",
            c,
            "must lie strictly between 0 and 1",
        )
    }
}

/// Why a spectrum or study could not be computed.
#[derive(Debug, Error)]
pub enum StudyError {
    /// Segment length not finite and positive, or shorter than 16 grid steps.
    #[error("Welch segment length {segment_length_m} m is {samples} grid steps of {step_m} m; it must be at least 16 steps")]
    SegmentTooShort {
        /// Segment length asked for, m.
        segment_length_m: f64,
        /// Grid step, m.
        step_m: f64,
        /// Samples it makes.
        samples: f64,
    },
    /// Segment longer than the road.
    #[error("Welch segment length {segment_length_m} m is longer than the road ({road_m} m); use a shorter --segment-length-m or a longer road")]
    SegmentTooLong {
        /// Segment length, m.
        segment_length_m: f64,
        /// Road length covered by the samples, m.
        road_m: f64,
    },
    /// Number of roads out of range, or seeds past `u64::MAX`.
    #[error("a study needs 1 to {max} roads with seeds seed..seed+roads below 2^64; got {roads} roads from seed {seed}")]
    Roads {
        /// Roads asked for.
        roads: usize,
        /// First seed.
        seed: u64,
        /// Limit ([`MAX_ROADS`]).
        max: usize,
    },
    /// A road could not be generated.
    #[error("road with seed {seed}: {source}")]
    Synth {
        /// Its seed.
        seed: u64,
        /// Cause.
        #[source]
        source: SynthError,
    },
    /// A comparison given neither a rule set nor a profile.
    #[error("nothing to compare: give at least one rule set or one profile")]
    NothingToCompare,
    /// Welch or the filter design failed (e.g. a grid too coarse for the filter's cut-off).
    #[error("{context}: {source}")]
    Signal {
        /// What was being computed.
        context: String,
        /// Cause.
        #[source]
        source: SignalError,
    },
}

/// Magnitude response of the road-slope filter ([`crate::road::slope_filter`]) on a set of
/// frequencies.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterResponse {
    /// The filter's settings (defaults of [`SlopeFilterConfig`]).
    pub config: SlopeFilterConfig,
    /// Order of the causal filter: the lowest meeting the attenuation requirement.
    pub causal_order: usize,
    /// Zero-phase (forward-backward) gain `20·log10|H|²`, dB, per frequency.
    pub zero_phase_db: Vec<f64>,
    /// Causal gain `20·log10|H|`, dB, per frequency.
    pub causal_db: Vec<f64>,
}

/// The filter response on `freq_per_m` for a grid of `step_m`.
///
/// # Errors
/// [`StudyError::Signal`] when the cut-off is not below the grid's Nyquist frequency.
pub fn filter_response(freq_per_m: &[f64], step_m: f64) -> Result<FilterResponse, StudyError> {
    let config = SlopeFilterConfig::default();
    let fs = 1.0 / step_m;
    let err = |source| StudyError::Signal {
        context: format!("slope filter on a {step_m} m grid"),
        source,
    };
    let zp = butter(config.order, config.cutoff_per_m, fs, BandType::Lowpass).map_err(err)?;
    let causal_order = try_lowest_order_meeting(
        config.cutoff_per_m,
        config.stop_per_m,
        config.required_attenuation_db,
        fs,
        false,
    )
    .map_err(err)?
    .unwrap_or(config.order);
    let causal = butter(causal_order, config.cutoff_per_m, fs, BandType::Lowpass).map_err(err)?;
    Ok(FilterResponse {
        config,
        causal_order,
        zero_phase_db: freq_per_m
            .iter()
            .map(|&f| 2.0 * zp.gain_db(f, fs))
            .collect(),
        causal_db: freq_per_m.iter().map(|&f| causal.gain_db(f, fs)).collect(),
    })
}

/// The spectrum of one road's slope.
#[derive(Debug, Clone, PartialEq)]
pub struct RoadSpectrum {
    /// Grid step, m.
    pub step_m: f64,
    /// Welch estimate (`freq_hz` holds spatial frequencies in 1/m).
    pub psd: WelchPsd,
    /// Cumulative fraction of power, 0 … 1.
    pub cumulative: Vec<f64>,
    /// Frequency below which half the power lies, 1/m. For a first-order (Lorentzian) spectrum
    /// `S ∝ 1/(1 + (f/f_c)²)` on an unbounded band this is exactly the corner f_c, where the PSD
    /// starts to fall — the "knee" one reads off a log–log plot such as Myklebust & Eriksson
    /// (2012), fig. 9.
    pub knee_50: f64,
    /// Frequency below which 90 % of the power lies, 1/m.
    pub knee_90: f64,
    /// Frequency below which 99 % of the power lies, 1/m.
    pub knee_99: f64,
    /// Share of the power below [`PAPER_FREQS_PER_M`] (3·10⁻⁴ and 10⁻³ 1/m).
    pub share_below_paper: [f64; 2],
    /// Slope filter response on the same frequencies.
    pub filter: FilterResponse,
}

/// The spatial frequencies Myklebust & Eriksson (2012), §5, name: highways carry most of their
/// slope power below 3·10⁻⁴ 1/m, city roads below 10⁻³ 1/m. Spectra report the share of their
/// power below each.
pub const PAPER_FREQS_PER_M: [f64; 2] = [3e-4, 1e-3];

/// Shares of the power below [`PAPER_FREQS_PER_M`], from a cumulative power over `freq`.
pub fn paper_shares(freq: &[f64], cumulative: &[f64]) -> [f64; 2] {
    PAPER_FREQS_PER_M.map(|f| share_below(freq, cumulative, f))
}

fn welch_config(n: usize, step_m: f64, s: &SpectrumSettings) -> Result<WelchConfig, StudyError> {
    let samples = (s.segment_length_m / step_m).round();
    if !(samples.is_finite() && samples >= 16.0) {
        return Err(StudyError::SegmentTooShort {
            segment_length_m: s.segment_length_m,
            step_m,
            samples,
        });
    }
    if samples > n as f64 {
        return Err(StudyError::SegmentTooLong {
            segment_length_m: s.segment_length_m,
            road_m: (n.saturating_sub(1)) as f64 * step_m,
        });
    }
    Ok(WelchConfig {
        fs_hz: 1.0 / step_m,
        nperseg: Some(samples as usize),
        noverlap: None,
        confidence: s.confidence,
    })
}

/// Welch PSD, band, cumulative power, knees and the filter response of a slope signal sampled
/// every `step_m` metres (see the module doc).
///
/// # Errors
/// [`StudyError::SegmentTooShort`], [`StudyError::SegmentTooLong`], [`StudyError::Signal`]
/// (non-finite samples, a bad confidence level, a grid too coarse for the filter).
pub fn slope_spectrum(
    slope: &[f64],
    step_m: f64,
    s: &SpectrumSettings,
) -> Result<RoadSpectrum, StudyError> {
    let cfg = welch_config(slope.len(), step_m, s)?;
    let psd = welch(slope, &cfg).map_err(|source| StudyError::Signal {
        context: "Welch PSD of the slope".into(),
        source,
    })?;
    let filter = filter_response(&psd.freq_hz, step_m)?;
    let cumulative = cumulative_power(&psd.freq_hz, &psd.psd);
    Ok(RoadSpectrum {
        step_m,
        share_below_paper: paper_shares(&psd.freq_hz, &cumulative),
        cumulative,
        knee_50: knee_frequency(&psd.freq_hz, &psd.psd, 0.5),
        knee_90: knee_frequency(&psd.freq_hz, &psd.psd, 0.9),
        knee_99: knee_frequency(&psd.freq_hz, &psd.psd, 0.99),
        psd,
        filter,
    })
}

/// A study's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyConfig {
    /// Rule set the roads are drawn from.
    pub rules: RoadRules,
    /// Number of roads.
    pub n_roads: usize,
    /// Length of each road, m.
    pub length_m: f64,
    /// Grid step, m.
    pub step_m: f64,
    /// Seed of the first road; road j has seed `seed + j`.
    pub seed: u64,
    /// Welch settings.
    pub spectrum: SpectrumSettings,
}

/// The synthetic roads of a study and its Welch settings, without the rule set: what a
/// comparison ([`super::compare`]) or a fit ([`super::fit`]) shares across its rule sets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StudyRoads {
    /// Number of roads.
    pub n_roads: usize,
    /// Length of each road, m.
    pub length_m: f64,
    /// Grid step, m.
    pub step_m: f64,
    /// Seed of the first road; road j has seed `seed + j`.
    pub seed: u64,
    /// Welch settings.
    pub spectrum: SpectrumSettings,
}

impl StudyRoads {
    /// The study of these roads drawn from `rules`.
    pub fn with_rules(&self, rules: RoadRules) -> StudyConfig {
        StudyConfig {
            rules,
            n_roads: self.n_roads,
            length_m: self.length_m,
            step_m: self.step_m,
            seed: self.seed,
            spectrum: self.spectrum,
        }
    }
}

/// What one road of a study contributes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadKnees {
    /// Its seed.
    pub seed: u64,
    /// 50 % (half-power) knee, 1/m.
    pub knee_50: f64,
    /// 90 % knee, 1/m.
    pub knee_90: f64,
    /// 99 % knee, 1/m.
    pub knee_99: f64,
    /// Root mean square of the slope, tan α.
    pub slope_rms: f64,
    /// Largest |slope|, tan α.
    pub max_abs_slope: f64,
    /// Grade segments it has.
    pub grade_segments: usize,
    /// Segments lengthened to hold their curves.
    pub lengthened_segments: usize,
}

/// 5th, 50th and 95th percentile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Percentiles {
    /// 5th percentile.
    pub p05: f64,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
}

/// A study's results (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct Study {
    /// Its settings.
    pub config: StudyConfig,
    /// Bin frequencies, 1/m.
    pub freq_per_m: Vec<f64>,
    /// 5th percentile of the PSD across roads, per bin.
    pub psd_p05: Vec<f64>,
    /// Median PSD, per bin.
    pub psd_p50: Vec<f64>,
    /// 95th percentile of the PSD, per bin.
    pub psd_p95: Vec<f64>,
    /// Mean PSD, per bin.
    pub psd_mean: Vec<f64>,
    /// Cumulative power of the mean PSD.
    pub cumulative_mean: Vec<f64>,
    /// Per road, in seed order.
    pub roads: Vec<RoadKnees>,
    /// Percentiles of the 50 % (half-power) knees across roads, 1/m.
    pub knee_50: Percentiles,
    /// Percentiles of the 90 % knees across roads, 1/m.
    pub knee_90: Percentiles,
    /// Percentiles of the 99 % knees across roads, 1/m.
    pub knee_99: Percentiles,
    /// 50 % knee of the mean PSD, 1/m.
    pub knee_50_of_mean: f64,
    /// 90 % knee of the mean PSD, 1/m.
    pub knee_90_of_mean: f64,
    /// 99 % knee of the mean PSD, 1/m.
    pub knee_99_of_mean: f64,
    /// Welch segment length in samples.
    pub nperseg: usize,
    /// Segments averaged per road.
    pub n_segments: usize,
    /// Equivalent degrees of freedom per road.
    pub dof: f64,
    /// Slope filter response on `freq_per_m`.
    pub filter: FilterResponse,
    /// Share of the mean PSD's slope power the zero-phase filter removes:
    /// `1 − ∫P·|H|⁴ df / ∫P df` (trapezoid over the bins).
    pub removed_by_zero_phase: f64,
    /// Share the causal filter removes: `1 − ∫P·|H|² df / ∫P df`.
    pub removed_by_causal: f64,
    /// Share of the mean PSD's power below [`PAPER_FREQS_PER_M`].
    pub share_below_paper: [f64; 2],
}

/// Share of the power of `psd` (over `freq`) that a filter of power gain `10^(gain_db/10)`
/// removes, by the trapezoid rule; NaN when there is no power.
pub fn power_removed(freq: &[f64], psd: &[f64], gain_db: &[f64]) -> f64 {
    let trap = |g: &dyn Fn(usize) -> f64| {
        (1..freq.len())
            .map(|i| 0.5 * (g(i) + g(i - 1)) * (freq[i] - freq[i - 1]))
            .sum::<f64>()
    };
    let total = trap(&|i| psd[i]);
    let kept = trap(&|i| psd[i] * 10f64.powf(gain_db[i] / 10.0));
    if total > 0.0 {
        1.0 - kept / total
    } else {
        f64::NAN
    }
}

/// numpy's default ("linear") percentile `q` (0 … 100) of an ascending sample.
pub fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    match sorted.len() {
        0 => f64::NAN,
        1 => sorted[0],
        n => {
            let rank = q / 100.0 * (n - 1) as f64;
            let lo = rank.floor() as usize;
            let hi = (lo + 1).min(n - 1);
            let t = rank - lo as f64;
            sorted[lo] + t * (sorted[hi] - sorted[lo])
        }
    }
}

fn percentiles(values: &mut [f64]) -> Percentiles {
    values.sort_by(f64::total_cmp);
    Percentiles {
        p05: percentile_sorted(values, 5.0),
        p50: percentile_sorted(values, 50.0),
        p95: percentile_sorted(values, 95.0),
    }
}

fn one_road(cfg: &StudyConfig, seed: u64) -> Result<(RoadSpectrum, RoadKnees), StudyError> {
    let road = generate(&cfg.rules, cfg.length_m, cfg.step_m, seed)
        .map_err(|source| StudyError::Synth { seed, source })?;
    let s = &road.profile.slope;
    let sp = slope_spectrum(s, cfg.step_m, &cfg.spectrum)?;
    let knees = RoadKnees {
        seed,
        knee_50: sp.knee_50,
        knee_90: sp.knee_90,
        knee_99: sp.knee_99,
        slope_rms: (s.iter().map(|v| v * v).sum::<f64>() / s.len() as f64).sqrt(),
        max_abs_slope: s.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        grade_segments: road.alignment.grades.len(),
        lengthened_segments: road.lengthened_segments,
    };
    Ok((sp, knees))
}

/// Runs a study on the current rayon pool (install a pool to choose the thread count; the
/// result is the same for any count).
///
/// # Errors
/// [`StudyError`]: bad settings, or the first failing road in seed order.
pub fn run_study(cfg: &StudyConfig) -> Result<Study, StudyError> {
    let n = cfg.n_roads;
    if n == 0 || n > MAX_ROADS || cfg.seed.checked_add(n as u64 - 1).is_none() {
        return Err(StudyError::Roads {
            roads: n,
            seed: cfg.seed,
            max: MAX_ROADS,
        });
    }
    // Settings are checked once up front, so a bad segment length is one clear error.
    let first = one_road(cfg, cfg.seed)?;
    let rest: Vec<Result<(RoadSpectrum, RoadKnees), StudyError>> = (1..n as u64)
        .into_par_iter()
        .map(|j| one_road(cfg, cfg.seed + j))
        .collect();
    let mut spectra = Vec::with_capacity(n);
    let mut roads = Vec::with_capacity(n);
    let (sp0, k0) = first;
    let (nperseg, n_segments, dof, filter) = (
        sp0.psd.nperseg,
        sp0.psd.n_segments,
        sp0.psd.dof,
        sp0.filter.clone(),
    );
    let freq_per_m = sp0.psd.freq_hz.clone();
    spectra.push(sp0.psd.psd);
    roads.push(k0);
    for r in rest {
        let (sp, k) = r?;
        spectra.push(sp.psd.psd);
        roads.push(k);
    }
    let bins = freq_per_m.len();
    let (mut p05, mut p50, mut p95, mut mean) = (
        Vec::with_capacity(bins),
        Vec::with_capacity(bins),
        Vec::with_capacity(bins),
        Vec::with_capacity(bins),
    );
    let mut column = vec![0.0; n];
    for b in 0..bins {
        for (c, s) in column.iter_mut().zip(&spectra) {
            *c = s[b];
        }
        mean.push(column.iter().sum::<f64>() / n as f64);
        let p = percentiles(&mut column);
        p05.push(p.p05);
        p50.push(p.p50);
        p95.push(p.p95);
    }
    let mut k50: Vec<f64> = roads.iter().map(|r| r.knee_50).collect();
    let mut k90: Vec<f64> = roads.iter().map(|r| r.knee_90).collect();
    let mut k99: Vec<f64> = roads.iter().map(|r| r.knee_99).collect();
    Ok(Study {
        removed_by_zero_phase: power_removed(&freq_per_m, &mean, &filter.zero_phase_db),
        removed_by_causal: power_removed(&freq_per_m, &mean, &filter.causal_db),
        config: cfg.clone(),
        share_below_paper: paper_shares(&freq_per_m, &cumulative_power(&freq_per_m, &mean)),
        cumulative_mean: cumulative_power(&freq_per_m, &mean),
        knee_50_of_mean: knee_frequency(&freq_per_m, &mean, 0.5),
        knee_90_of_mean: knee_frequency(&freq_per_m, &mean, 0.9),
        knee_99_of_mean: knee_frequency(&freq_per_m, &mean, 0.99),
        knee_50: percentiles(&mut k50),
        knee_90: percentiles(&mut k90),
        knee_99: percentiles(&mut k99),
        freq_per_m,
        psd_p05: p05,
        psd_p50: p50,
        psd_p95: p95,
        psd_mean: mean,
        roads,
        nperseg,
        n_segments,
        dof,
        filter,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_match_numpy_linear() {
        // numpy.percentile([1, 2, 3, 4], [5, 50, 95]) = [1.15, 2.5, 3.85]
        let v = [1.0, 2.0, 3.0, 4.0];
        assert!((percentile_sorted(&v, 5.0) - 1.15).abs() < 1e-12);
        assert!((percentile_sorted(&v, 50.0) - 2.5).abs() < 1e-12);
        assert!((percentile_sorted(&v, 95.0) - 3.85).abs() < 1e-12);
        assert!(percentile_sorted(&[], 50.0).is_nan());
    }

    #[test]
    fn power_removed_weighs_the_psd_by_the_power_gain() {
        let f = [0.0, 1.0, 2.0, 3.0];
        let p = [1.0, 1.0, 1.0, 1.0];
        assert!(power_removed(&f, &p, &[0.0; 4]).abs() < 1e-15);
        // -10·log10(2) dB is half power everywhere
        let half = -10.0 * 2f64.log10();
        assert!((power_removed(&f, &p, &[half; 4]) - 0.5).abs() < 1e-12);
        assert!(power_removed(&f, &[0.0; 4], &[0.0; 4]).is_nan());
    }

    #[test]
    fn filter_response_is_the_seed_design() {
        let f = [0.0, 4e-3, 2e-2];
        let r = filter_response(&f, 1.0).unwrap();
        assert_eq!(r.causal_order, 3);
        // -3.01 dB per pass at the cut-off; about -42 dB per pass at 2e-2 1/m (the design of
        // Myklebust & Eriksson (2012), §5)
        assert!((r.causal_db[1] + 3.0103).abs() < 1e-3, "{}", r.causal_db[1]);
        assert!((r.zero_phase_db[1] - 2.0 * r.causal_db[1]).abs() < 1e-12);
        assert!(
            r.causal_db[2] < -41.0 && r.causal_db[2] > -43.0,
            "{}",
            r.causal_db[2]
        );
        assert!(r.zero_phase_db[0].abs() < 1e-9);
    }
}
