//! How each catalogue effect's parameter is screened and fitted in step 3 of the diagnosis,
//! explain (docs/diagnosis/method.md): its finite-difference step, physical domain, start grid
//! and screen ladder ([`FitSpec`], [`fit_spec`]), and whether the effect can be explained on a
//! recording at all ([`applicable`]).
//!
//! Steps and domains are the catalogue's ([`crate::model::catalogue::FitRule`], the "fit step"
//! and "fit domain" columns of docs/diagnosis/catalogue.md; θ₀ the vehicle file's value), in the
//! parameter's SI unit; relative rules scale with θ₀.
//!
//! `slope_quantization` is not fitted continuously (a switch: the recorded slope, or its
//! consistent reconstruction from cells of the sensor's resolution,
//! [`crate::signal::dequantise`]). Its value, the slope sensor's resolution, is the measured
//! lattice step of the recorded slope ([`crate::signal::quantization`]), which is also the
//! cell width the cure reconstructs with; its interval is that estimate's lattice tolerance
//! (±1 %), and its likelihood-ratio test (reconstruction against raw slope) stands in for "the
//! interval excludes the nominal". It applies only when the recorded slope's step is above
//! [`COARSER_THAN_NOMINAL`] × the nominal resolution (the vehicle file's `[sensors]
//! road_slope_resolution`, [`crate::model::vehicle::Sensors`]).

use super::problem::Problem;
use crate::model::catalogue::{Effect, FitRule};
use serde::Serialize;

/// How an effect's parameter is screened and fitted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FitSpec {
    /// Finite-difference step of the screen (and first step of the fit), parameter unit.
    pub step: f64,
    /// Lower bound of the physical domain.
    pub lo: f64,
    /// Upper bound of the physical domain.
    pub hi: f64,
    /// A switch rather than a continuous parameter (`slope_quantization`).
    pub switch: bool,
    /// Start grid `[first, last, step]` (the parameter's unit; clipped to the domain), for a
    /// parameter whose cost has narrow side basins (`signal_delay`, `clutch_slip`): the fit
    /// starts from the grid's best point ([`fit_effect`](super::fit::fit_effect)).
    pub grid: Option<[f64; 3]>,
    /// Multiples of `step` the screen probes: the candidate test and the ranking take the
    /// largest share of train SSE any rung's sensitivity removes, its change kept within the
    /// domain ([`SCREEN_LADDER`](crate::model::catalogue::SCREEN_LADDER) for the effects whose
    /// outputs are not near-linear in the parameter over its realistic range; `[1]` for the
    /// others); the full fit starts from the step's own probe (or the start grid's best point,
    /// `grid`).
    pub ladder: &'static [f64],
}

/// Steps and domains of `e`'s fit from the nominal value `nom` (the catalogue row's
/// [`FitRule`]: relative rules scale with `nom`; the module documentation's table).
/// `slope_step` is the recorded slope's lattice step: `slope_quantization`'s switch moves the
/// resolution from `nom` to it (twice `nom` when the slope has no lattice).
pub fn fit_spec(e: Effect, nom: f64, slope_step: Option<f64>) -> FitSpec {
    let rule: FitRule = e.spec().fit;
    if rule.switch {
        let q = slope_step.unwrap_or(2.0 * nom);
        return FitSpec {
            step: q - nom,
            lo: q,
            hi: q,
            switch: true,
            grid: None,
            ladder: rule.ladder,
        };
    }
    let k = rule.factor(nom);
    FitSpec {
        step: rule.step * k,
        lo: rule.lo * k,
        hi: rule.hi * k,
        switch: false,
        grid: rule.grid.map(|g| [g[0] * k, g[1] * k, g[2] * k]),
        ladder: rule.ladder,
    }
}

/// How much coarser than the nominal resolution the recorded slope's lattice step must be for
/// `slope_quantization` to apply: 10 %, ten times the lattice estimate's tolerance (±1 %; a
/// slope sent on its bus's lattice gives its step to rounding), so a recording on the file's
/// own lattice never qualifies and any coarser encoding does.
pub const COARSER_THAN_NOMINAL: f64 = 1.1;

/// Whether `e` can be explained on `problem`: its model is in use; `slope_quantization` also
/// needs a recorded slope quantised more coarsely than the nominal resolution (its lattice step
/// above [`COARSER_THAN_NOMINAL`] × the nominal: "the sensor is coarser than the file says").
pub fn applicable(problem: &Problem<'_>, e: Effect) -> bool {
    if !problem.domains().contains(&e.domain()) {
        return false;
    }
    if e == Effect::SlopeQuantization {
        let nom = problem.nominal().get(e);
        return problem
            .slope_step()
            .is_some_and(|q| q > COARSER_THAN_NOMINAL * nom);
    }
    true
}
