//! Calibrating a rule set's segment lengths to measured roads (docs/models/road.md, "Rule sets
//! fitted to measured roads").
//!
//! Road regulations fix the maximum grade and the minimum vertical-curve radius; they do not fix
//! how long a constant grade lasts, which sets where the slope spectrum bends (its knees). The
//! fit keeps every regulation value and the shape of the length distribution, and scales the
//! length range by one factor `k`:
//!
//! `L_min = k·L_min,0`, `L_flat = k·L_flat,0` (the e-folding grade and the radii unchanged).
//!
//! For each `k` of a grid a study of synthetic roads is run ([`crate::road::study`]) and scored
//! against the measured targets by
//!
//! `J(k) = Σ_targets [ln(k̃₅₀(k)/K₅₀)]² + [ln(k̃₉₀(k)/K₉₀)]²`,
//!
//! where k̃ are the median knees over the study's roads and K the target's knees (same grid step
//! and Welch segment). The `k` with the smallest `J` wins (the first on ties). A grid search, not
//! a continuous optimiser: the median knees of a finite study move in small steps with `k`, and
//! the grid is what is reported.

use super::compare::ProfileInput;
use super::rules::RoadRules;
use super::study::{run_study, slope_spectrum, StudyError, StudyRoads};

/// Settings of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitConfig {
    /// The rule set whose lengths are scaled.
    pub base: RoadRules,
    /// Measured targets (their slope on the fit's grid).
    pub targets: Vec<ProfileInput>,
    /// Scale factors tried, in order.
    pub scales: Vec<f64>,
    /// Roads per study, their grid (also the targets') and the Welch settings.
    pub roads: StudyRoads,
}

/// One grid point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitPoint {
    /// Scale factor k.
    pub scale: f64,
    /// Median 50 % knee of the study's roads, 1/m.
    pub knee_50: f64,
    /// Median 90 % knee, 1/m.
    pub knee_90: f64,
    /// Objective J(k).
    pub objective: f64,
    /// Grade segments drawn in the study.
    pub segments: usize,
    /// Of those, lengthened to hold their vertical curves.
    pub lengthened: usize,
}

/// A target's knees.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetKnees {
    /// Its label.
    pub name: String,
    /// 50 % knee, 1/m.
    pub knee_50: f64,
    /// 90 % knee, 1/m.
    pub knee_90: f64,
}

/// A fit's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// The targets' knees.
    pub targets: Vec<TargetKnees>,
    /// Every grid point, in the order tried.
    pub points: Vec<FitPoint>,
    /// Index of the best point.
    pub best: usize,
    /// The fitted rule set (named `name`, its `source` extended by what was fitted to what).
    pub rules: RoadRules,
}

/// `rules` with the segment-length range scaled by `k`.
pub fn scaled(rules: &RoadRules, k: f64) -> RoadRules {
    RoadRules {
        min_length_m: rules.min_length_m * k,
        max_length_flat_m: rules.max_length_flat_m * k,
        ..rules.clone()
    }
}

/// Why a fit could not run.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// No target, no scale, or a scale not finite and positive.
    #[error("a fit needs at least one target profile and scale factors > 0 (got {targets} target(s), scales {scales:?})")]
    Setup {
        /// Targets given.
        targets: usize,
        /// Scales given.
        scales: Vec<f64>,
    },
    /// A target whose slope has no power (a flat road): it has no knees to fit to.
    #[error("target {target} has no slope power (a flat road): nothing to fit its knees to")]
    FlatTarget {
        /// Its label.
        target: String,
    },
    /// A study or a target's spectrum.
    #[error(transparent)]
    Study(#[from] StudyError),
}

/// Runs the fit (module doc) on the current rayon pool; `name` names the fitted rule set.
///
/// # Errors
/// [`FitError`].
pub fn fit(cfg: &FitConfig, name: &str) -> Result<Fit, FitError> {
    if cfg.targets.is_empty()
        || cfg.scales.is_empty()
        || cfg.scales.iter().any(|k| !(k.is_finite() && *k > 0.0))
    {
        return Err(FitError::Setup {
            targets: cfg.targets.len(),
            scales: cfg.scales.clone(),
        });
    }
    let targets = cfg
        .targets
        .iter()
        .map(|t| {
            let sp = slope_spectrum(&t.slope, cfg.roads.step_m, &cfg.roads.spectrum)?;
            Ok(TargetKnees {
                name: t.name.clone(),
                knee_50: sp.knee_50,
                knee_90: sp.knee_90,
            })
        })
        .collect::<Result<Vec<_>, StudyError>>()?;
    if let Some(t) = targets
        .iter()
        .find(|t| !(t.knee_50.is_finite() && t.knee_90.is_finite()))
    {
        return Err(FitError::FlatTarget {
            target: t.name.clone(),
        });
    }
    let mut points = Vec::with_capacity(cfg.scales.len());
    for &k in &cfg.scales {
        let study = run_study(&cfg.roads.with_rules(scaled(&cfg.base, k)))?;
        let (k50, k90) = (study.knee_50.p50, study.knee_90.p50);
        let objective = targets
            .iter()
            .map(|t| (k50 / t.knee_50).ln().powi(2) + (k90 / t.knee_90).ln().powi(2))
            .sum();
        points.push(FitPoint {
            scale: k,
            knee_50: k50,
            knee_90: k90,
            objective,
            segments: study.roads.iter().map(|r| r.grade_segments).sum(),
            lengthened: study.roads.iter().map(|r| r.lengthened_segments).sum(),
        });
    }
    let best = (0..points.len())
        .min_by(|&a, &b| points[a].objective.total_cmp(&points[b].objective))
        .unwrap_or(0);
    let k = points[best].scale;
    let names: Vec<&str> = targets.iter().map(|t| t.name.as_str()).collect();
    let mut rules = scaled(&cfg.base, k);
    rules.name = name.into();
    rules.source = format!(
        "{}; segment lengths fitted: {} scaled by k = {k} (grid {:?}) so that the median 50 % and 90 % knees of {} roads x {} m (seed {}, Welch segments of {} m) match {}",
        cfg.base.source,
        cfg.base.name,
        cfg.scales,
        cfg.roads.n_roads,
        cfg.roads.length_m,
        cfg.roads.seed,
        cfg.roads.spectrum.segment_length_m,
        names.join(", ")
    );
    Ok(Fit {
        targets,
        points,
        best,
        rules,
    })
}

/// The fitted rule file: a comment block recording the fit (`command` as it was given, the
/// targets' knees, every grid point with the chosen one marked), then the rules as TOML.
pub fn rule_file(cfg: &FitConfig, f: &Fit, command: &str) -> String {
    let r = &cfg.roads;
    let mut s = format!(
        "# {}: {} with its segment lengths scaled by k = {}, fitted by `fleetdyn road fit`\n# (docs/models/road.md). Regulation values, radius band and e-folding grade unchanged.\n#\n# Command: fleetdyn {command}\n#\n# Targets (Welch segments of {} m on a {} m grid):\n",
        f.rules.name,
        cfg.base.name,
        f.points[f.best].scale,
        r.spectrum.segment_length_m,
        r.step_m
    );
    for (t, p) in f.targets.iter().zip(&cfg.targets) {
        s += &format!(
            "#   {} ({}): 50 % knee {:.3e} 1/m, 90 % knee {:.3e} 1/m\n",
            t.name, p.origin, t.knee_50, t.knee_90
        );
    }
    s += &format!(
        "#\n# Grid ({} roads x {} m per k, seeds {}..{}): k, median 50 % knee, median 90 % knee, J\n",
        r.n_roads,
        r.length_m,
        r.seed,
        r.seed + r.n_roads as u64 - 1
    );
    for (i, p) in f.points.iter().enumerate() {
        s += &format!(
            "#   {:<6} {:.3e} {:.3e} {:.4}{}\n",
            p.scale,
            p.knee_50,
            p.knee_90,
            p.objective,
            if i == f.best { "  <- fitted" } else { "" }
        );
    }
    s + &f.rules.canonical_toml()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::road::study::SpectrumSettings;
    use crate::road::synth::generate;

    #[test]
    fn the_fit_finds_the_scale_a_synthetic_target_was_drawn_with() {
        // A target drawn from the base rules with lengths scaled by 2: the grid's 2 must win.
        let base = RoadRules::bundled("city-se").unwrap();
        let target = generate(&scaled(&base, 2.0), 40_000.0, 1.0, 999).unwrap();
        let cfg = FitConfig {
            base: base.clone(),
            targets: vec![ProfileInput {
                name: "city-se x2, seed 999".into(),
                class: "city".into(),
                origin: "synthetic".into(),
                slope: target.profile.slope,
            }],
            scales: vec![0.5, 1.0, 2.0, 4.0],
            roads: StudyRoads {
                n_roads: 16,
                length_m: 40_000.0,
                seed: 1,
                step_m: 1.0,
                spectrum: SpectrumSettings {
                    segment_length_m: 4096.0,
                    ..Default::default()
                },
            },
        };
        let f = fit(&cfg, "city-se-test").unwrap();
        assert_eq!(f.points[f.best].scale, 2.0, "{:?}", f.points);
        assert_eq!(f.rules.min_length_m, 2.0 * base.min_length_m);
        assert_eq!(f.rules.max_grade, base.max_grade);
        assert_eq!(f.rules.name, "city-se-test");
    }

    #[test]
    fn a_fit_without_targets_or_with_a_bad_scale_is_refused() {
        let base = RoadRules::bundled("city-se").unwrap();
        let mut cfg = FitConfig {
            base,
            targets: vec![],
            scales: vec![1.0],
            roads: StudyRoads {
                n_roads: 2,
                length_m: 10_000.0,
                seed: 1,
                step_m: 1.0,
                spectrum: SpectrumSettings::default(),
            },
        };
        assert!(matches!(fit(&cfg, "x"), Err(FitError::Setup { .. })));
        cfg.targets.push(ProfileInput {
            name: "t".into(),
            class: String::new(),
            origin: String::new(),
            slope: vec![0.0; 20_000],
        });
        cfg.scales = vec![1.0, -1.0];
        assert!(matches!(fit(&cfg, "x"), Err(FitError::Setup { .. })));
        // a flat target has no knees
        cfg.scales = vec![1.0];
        assert!(matches!(fit(&cfg, "x"), Err(FitError::FlatTarget { .. })));
    }
}
