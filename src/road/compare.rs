//! Road spectra side by side (Myklebust & Eriksson (2012), §4–§5 and fig. 9): synthetic rule
//! sets, measured road profiles and a driveline's per-gear resonances on one spatial-frequency
//! grid, with the slope filter's margins against each.
//!
//! Conventions:
//! - every spectrum is the Welch PSD of the slope (tan α) over spatial frequency, 1/m, on the same
//!   grid step and segment length ([`super::study::SpectrumSettings`]), so the bins are the same for every item;
//! - knees are the frequencies below which 50, 90 and 99 % of the slope power lies
//!   ([`crate::signal::knee_frequency`]);
//! - a rule set's knee is the median over its roads, its range the 5th–95th percentile across the
//!   roads (how far one road of that length strays); its plotted PSD is the mean over the roads;
//! - a measured profile's knee is that of its Welch PSD, its range a 90 % bootstrap interval
//!   ([`knee_intervals`]): the Welch segments are drawn with replacement, the knee of each drawn
//!   average taken, and the 5th and 95th percentiles of those knees reported;
//! - a resonance is the peak of the open-loop `F_dr → v` response of one gear (the road slope
//!   enters the driveline as the force `m·g·sin α`), at the gear's top speed in 1/m
//!   ([`crate::model::resonance`]); the filter's attenuation there is the zero-phase gain
//!   `20·log10|H|²` and the causal gain `20·log10|H|` of the filter's analog Butterworth design
//!   ([`gear_resonances`]);
//! - the filter's margin against an item is `f_co / knee_99`: how far the cut-off lies above the
//!   frequency below which 99 % of the item's slope power lies (the paper places f_co a decade
//!   above the city roads' knee).

use super::rules::RoadRules;
use super::study::{
    filter_response, percentile_sorted, power_removed, run_study, slope_spectrum, FilterResponse,
    RoadSpectrum, StudyError, StudyRoads,
};
use crate::model::driveline::DrivelineParams;
use crate::model::resonance::{resonance, Path};
use crate::rng::Xoshiro256StarStar;
use crate::signal::{knee_frequency, welch, WelchConfig};

/// Bootstrap draws behind a measured profile's knee interval.
pub const BOOTSTRAP_DRAWS: usize = 2000;

/// Seed of the bootstrap's generator (fixed: the same profile gives the same interval).
pub const BOOTSTRAP_SEED: u64 = 20_120_905;

/// The power fractions the knees are taken at.
pub const KNEE_FRACTIONS: [f64; 3] = [0.5, 0.9, 0.99];

/// A knee and its range, 1/m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knee {
    /// The knee: median over a rule set's roads, or the measured profile's own.
    pub value: f64,
    /// Lower end of the range (5th percentile across roads, or of the bootstrap).
    pub lo: f64,
    /// Upper end (95th percentile).
    pub hi: f64,
}

/// Whether an item is drawn from rules or measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A synthetic rule set's study.
    Rules,
    /// A measured road profile.
    Profile,
}

impl Kind {
    /// `rules` or `profile`.
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Rules => "rules",
            Kind::Profile => "profile",
        }
    }
}

/// One spectrum of the comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// Rule-set name, or the profile's label.
    pub name: String,
    /// Rules or profile.
    pub kind: Kind,
    /// Road class as given (`highway`, `city`, …; empty when not given).
    pub class: String,
    /// Where it came from: the rule set's `source`, or the profile's file.
    pub origin: String,
    /// Road length analysed, m (per road for a rule set).
    pub length_m: f64,
    /// Roads behind it (1 for a profile).
    pub roads: usize,
    /// Welch segments per road.
    pub segments: usize,
    /// PSD on the comparison's bins: the mean over roads, or the profile's Welch PSD,
    /// (tan α)²/(1/m).
    pub psd: Vec<f64>,
    /// 50, 90 and 99 % knees.
    pub knees: [Knee; 3],
    /// Share of the PSD's power below 3·10⁻⁴ and 10⁻³ 1/m.
    pub share_below_paper: [f64; 2],
    /// Share of the PSD's power the zero-phase slope filter removes.
    pub removed_zero_phase: f64,
    /// Share the causal slope filter removes.
    pub removed_causal: f64,
    /// Root mean square of the slope, tan α (mean over roads for a rule set).
    pub slope_rms: f64,
}

impl Item {
    /// The filter's margin: cut-off over the 99 % knee.
    pub fn cutoff_margin(&self, filter: &FilterResponse) -> f64 {
        filter.config.cutoff_per_m / self.knees[2].value
    }
}

/// One gear's driveline resonance against the slope filter.
#[derive(Debug, Clone, PartialEq)]
pub struct GearResonance {
    /// Gear.
    pub gear: usize,
    /// Top speed of the gear, m/s.
    pub v_top_mps: f64,
    /// Peak of the open-loop `F_dr → v` response, Hz (`None`: no peak).
    pub peak_hz: Option<f64>,
    /// The peak at the gear's top speed, 1/m.
    pub peak_per_m: Option<f64>,
    /// Zero-phase filter gain there, dB.
    pub zero_phase_db: Option<f64>,
    /// Causal filter gain there, dB.
    pub causal_db: Option<f64>,
}

/// A profile handed to the comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileInput {
    /// Label.
    pub name: String,
    /// Road class.
    pub class: String,
    /// Its file, for the record.
    pub origin: String,
    /// Slope (tan α) on a uniform grid of the comparison's step.
    pub slope: Vec<f64>,
}

/// A rule set handed to the comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct RulesInput {
    /// Road class.
    pub class: String,
    /// The rules.
    pub rules: RoadRules,
}

/// Settings of a comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareConfig {
    /// Rule sets.
    pub rules: Vec<RulesInput>,
    /// Measured profiles.
    pub profiles: Vec<ProfileInput>,
    /// Roads per rule set, their grid (also the profiles') and the Welch settings shared by
    /// every item.
    pub roads: StudyRoads,
}

/// A comparison's results.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Its settings (profiles' slopes dropped).
    pub config: CompareConfig,
    /// Bin frequencies, 1/m.
    pub freq_per_m: Vec<f64>,
    /// Welch segment length, samples.
    pub nperseg: usize,
    /// The slope filter's response on the bins.
    pub filter: FilterResponse,
    /// Rule sets first (in the order given), then profiles.
    pub items: Vec<Item>,
    /// Per-gear resonances (empty without a driveline).
    pub resonances: Vec<GearResonance>,
}

/// 90 % bootstrap intervals of a profile's 50, 90 and 99 % knees (module doc): the Welch
/// segments' periodograms are resampled with replacement [`BOOTSTRAP_DRAWS`] times.
///
/// The segments overlap by half, so neighbours are correlated and the interval is a little
/// narrower than one from independent segments would be. With a single segment the interval is
/// the knee itself.
///
/// `whole` is the spectrum [`slope_spectrum`] gives for `slope`; its segments are taken again
/// one by one.
///
/// # Errors
/// [`StudyError::Signal`] when a segment's periodogram cannot be computed.
pub fn knee_intervals(slope: &[f64], whole: &RoadSpectrum) -> Result<[Knee; 3], StudyError> {
    let (n, step) = (whole.psd.nperseg, whole.psd.nperseg - whole.psd.noverlap);
    let one = WelchConfig {
        fs_hz: 1.0 / whole.step_m,
        nperseg: Some(n),
        noverlap: None,
        // only the PSD of a segment is used, not its confidence band
        confidence: 0.95,
    };
    let segments: Vec<Vec<f64>> = (0..whole.psd.n_segments)
        .map(|k| {
            welch(&slope[k * step..k * step + n], &one)
                .map(|p| p.psd)
                .map_err(|source| StudyError::Signal {
                    context: format!("periodogram of Welch segment {k}"),
                    source,
                })
        })
        .collect::<Result<_, _>>()?;
    let freq = &whole.psd.freq_hz;
    let values = [whole.knee_50, whole.knee_90, whole.knee_99];
    let k = segments.len();
    if k < 2 {
        return Ok(values.map(|v| Knee {
            value: v,
            lo: v,
            hi: v,
        }));
    }
    let mut rng = Xoshiro256StarStar::seed_from_u64(BOOTSTRAP_SEED);
    let mut draws: [Vec<f64>; 3] = std::array::from_fn(|_| Vec::with_capacity(BOOTSTRAP_DRAWS));
    let mut avg = vec![0.0; freq.len()];
    for _ in 0..BOOTSTRAP_DRAWS {
        avg.iter_mut().for_each(|a| *a = 0.0);
        for _ in 0..k {
            let j = ((rng.next_f64() * k as f64) as usize).min(k - 1);
            for (a, p) in avg.iter_mut().zip(&segments[j]) {
                *a += p;
            }
        }
        for (d, f) in draws.iter_mut().zip(KNEE_FRACTIONS) {
            d.push(knee_frequency(freq, &avg, f));
        }
    }
    let mut out = [Knee {
        value: 0.0,
        lo: 0.0,
        hi: 0.0,
    }; 3];
    for ((o, d), v) in out.iter_mut().zip(draws.iter_mut()).zip(values) {
        d.sort_by(f64::total_cmp);
        *o = Knee {
            value: v,
            lo: percentile_sorted(d, 5.0),
            hi: percentile_sorted(d, 95.0),
        };
    }
    Ok(out)
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Gain of an order-`n` analog Butterworth low-pass with cut-off `fc` at `f`, dB:
/// `20·log10|H| = −10·log10(1 + (f/fc)^(2n))`.
pub fn butterworth_design_gain_db(f: f64, fc: f64, n: usize) -> f64 {
    -10.0 * (1.0 + (f / fc).powi(2 * n as i32)).log10()
}

/// The per-gear resonances of a driveline against the slope filter (module doc). The gains are
/// those of the filter's analog design (Butterworth of the zero-phase order, applied twice, and
/// of the causal order), not of its digital form on the grid: a resonance often lies above the
/// grid's Nyquist frequency `1/(2·step_m)`, where the gridded slope holds no content and the
/// digital response is that of an alias.
///
/// # Errors
/// [`StudyError::Signal`] when the filter cannot be designed on the grid.
pub fn gear_resonances(
    p: &DrivelineParams,
    ratios: &[f64],
    step_m: f64,
) -> Result<Vec<GearResonance>, StudyError> {
    let h = filter_response(&[], step_m)?;
    let fc = h.config.cutoff_per_m;
    Ok((1..=ratios.len())
        .map(|g| {
            let r = resonance(p, ratios, g, Path::ResistanceOpen);
            GearResonance {
                gear: g,
                v_top_mps: r.v_top_mps,
                peak_hz: r.peak_hz,
                peak_per_m: r.peak_per_m,
                zero_phase_db: r
                    .peak_per_m
                    .map(|f| 2.0 * butterworth_design_gain_db(f, fc, h.config.order)),
                causal_db: r
                    .peak_per_m
                    .map(|f| butterworth_design_gain_db(f, fc, h.causal_order)),
            }
        })
        .collect())
}

/// Runs the comparison on the current rayon pool (the result is the same for any thread count):
/// a study per rule set, the spectrum and bootstrap knees of each profile, and the resonances of
/// `driveline` (gear ratios beside it) when given.
///
/// # Errors
/// [`StudyError`]: bad settings, a profile too short for the Welch segment, a failing road.
pub fn compare(
    cfg: &CompareConfig,
    driveline: Option<(&DrivelineParams, &[f64])>,
) -> Result<Comparison, StudyError> {
    let mut items = Vec::with_capacity(cfg.rules.len() + cfg.profiles.len());
    let mut grid: Option<(Vec<f64>, usize, FilterResponse)> = None;
    for r in &cfg.rules {
        let study = run_study(&cfg.roads.with_rules(r.rules.clone()))?;
        let rms_mean =
            study.roads.iter().map(|k| k.slope_rms).sum::<f64>() / study.roads.len() as f64;
        let knee = |p: &super::study::Percentiles| Knee {
            value: p.p50,
            lo: p.p05,
            hi: p.p95,
        };
        items.push(Item {
            name: r.rules.name.clone(),
            kind: Kind::Rules,
            class: r.class.clone(),
            origin: r.rules.source.clone(),
            length_m: cfg.roads.length_m,
            roads: cfg.roads.n_roads,
            segments: study.n_segments,
            knees: [
                knee(&study.knee_50),
                knee(&study.knee_90),
                knee(&study.knee_99),
            ],
            share_below_paper: study.share_below_paper,
            removed_zero_phase: study.removed_by_zero_phase,
            removed_causal: study.removed_by_causal,
            slope_rms: rms_mean,
            psd: study.psd_mean,
        });
        grid.get_or_insert((study.freq_per_m, study.nperseg, study.filter));
    }
    for p in &cfg.profiles {
        let sp = slope_spectrum(&p.slope, cfg.roads.step_m, &cfg.roads.spectrum)?;
        let knees = knee_intervals(&p.slope, &sp)?;
        let freq = &sp.psd.freq_hz;
        items.push(Item {
            name: p.name.clone(),
            kind: Kind::Profile,
            class: p.class.clone(),
            origin: p.origin.clone(),
            length_m: (p.slope.len().saturating_sub(1)) as f64 * cfg.roads.step_m,
            roads: 1,
            segments: sp.psd.n_segments,
            knees,
            share_below_paper: sp.share_below_paper,
            removed_zero_phase: power_removed(freq, &sp.psd.psd, &sp.filter.zero_phase_db),
            removed_causal: power_removed(freq, &sp.psd.psd, &sp.filter.causal_db),
            slope_rms: rms(&p.slope),
            psd: sp.psd.psd.clone(),
        });
        grid.get_or_insert((sp.psd.freq_hz, sp.psd.nperseg, sp.filter));
    }
    let Some((freq_per_m, nperseg, filter)) = grid else {
        return Err(StudyError::NothingToCompare);
    };
    let resonances = match driveline {
        Some((p, ratios)) => gear_resonances(p, ratios, cfg.roads.step_m)?,
        None => Vec::new(),
    };
    let mut config = cfg.clone();
    config
        .profiles
        .iter_mut()
        .for_each(|p| p.slope = Vec::new());
    Ok(Comparison {
        config,
        freq_per_m,
        nperseg,
        filter,
        items,
        resonances,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::road::study::SpectrumSettings;

    fn lcg_noise(n: usize, seed: u64) -> Vec<f64> {
        let mut r = Xoshiro256StarStar::seed_from_u64(seed);
        // AR(1) in distance: a first-order spectrum with a corner well inside the band.
        let mut x = 0.0;
        (0..n)
            .map(|_| {
                x = 0.995 * x + 0.01 * r.standard_normal();
                x
            })
            .collect()
    }

    #[test]
    fn segment_periodograms_average_to_the_welch_psd_and_bracket_the_knee() {
        let slope = lcg_noise(40_000, 3);
        let s = SpectrumSettings {
            segment_length_m: 4096.0,
            ..Default::default()
        };
        let whole = slope_spectrum(&slope, 1.0, &s).unwrap();
        let k = knee_intervals(&slope, &whole).unwrap();
        assert_eq!(k[0].value, whole.knee_50);
        for q in k {
            assert!(q.lo <= q.value && q.value <= q.hi, "{q:?}");
            assert!(
                q.hi > q.lo,
                "a {}-segment bootstrap has spread",
                whole.psd.n_segments
            );
        }
        // Same input, same interval.
        assert_eq!(knee_intervals(&slope, &whole).unwrap(), k);
    }

    #[test]
    fn the_design_gain_is_the_butterworth_magnitude() {
        // -3.01 dB at the cut-off, 20·n dB per decade far above it.
        assert!((butterworth_design_gain_db(4e-3, 4e-3, 3) + 10.0 * 2f64.log10()).abs() < 1e-12);
        let g = butterworth_design_gain_db(4e-1, 4e-3, 3);
        assert!((g + 120.0).abs() < 1e-6, "{g}");
    }

    #[test]
    fn a_single_segment_gives_the_knee_as_its_own_interval() {
        let slope = lcg_noise(4096, 5);
        let s = SpectrumSettings {
            segment_length_m: 4096.0,
            ..Default::default()
        };
        let k = knee_intervals(&slope, &slope_spectrum(&slope, 1.0, &s).unwrap()).unwrap();
        assert!(k.iter().all(|q| q.lo == q.value && q.hi == q.value));
    }
}
