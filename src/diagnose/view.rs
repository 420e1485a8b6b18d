//! The views of step 3 of the diagnosis, explain (docs/diagnosis/method.md): the groups of one
//! model's compared channels that are fitted and scored together ([`View`], [`ViewKind`]).
//!
//! # Views
//! The explain step scores channels in groups, [`View`]s: the longitudinal model's speeds,
//! its shuffle modes, its torque reversals, and the axle model's bellow pressures. An effect is
//! fitted and scored on the views it changes materially ([`super::explain`]), so a view that
//! only a few effects can move (the reversals: the lash, the stiffness, the torque signal's
//! delay) never dilutes the figures of the others.
//! The speeds and the pressures are pooled in the deviance as largely redundant; the modes,
//! the reversals and the clutch actuation are terms of their own ([`ViewKind::own_term`]).
//! The shuffle-modes view is fitted and scored for `driveline_compliance` alone
//! ([`ViewKind::only_for`], which says why), the clutch-actuation view for `clutch_slip` and
//! `signal_delay` alone: it is the worn clutch's catalogue fingerprint and where a
//! delayed torque signal's ramps meet every shift, on rows the nominal model reproduces only
//! to the 10 Hz clutch's timing, and every other longitudinal effect moves them a little
//! without carrying its evidence there.

use crate::model::catalogue::{Domain, Effect};
use serde::Serialize;

/// A group of one model's channels that the explain step scores together: the longitudinal
/// model's speeds, its shuffle modes, its torque reversals, the axle model's bellow pressures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct View {
    /// Model whose outputs they are.
    pub domain: Domain,
    /// Which outputs.
    pub kind: ViewKind,
    /// Channels ([`Problem::channels`](super::problem::Problem::channels) indices).
    pub chans: Vec<usize>,
}

/// The views of [`View`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ViewKind {
    /// `vehicle_speed`, `engine_speed`.
    Speeds,
    /// `shuffle_frequency` ([`super::modal_channel`]).
    ShuffleModes,
    /// `reversal_relative_speed` ([`super::reversal_channel`]).
    Reversals,
    /// The three bellow pressures.
    Pressures,
    /// The engine speed while the clutch is actuated
    /// ([`Problem::with_actuation`](super::problem::Problem::with_actuation)), scored
    /// for `clutch_slip` and `signal_delay` alone ([`ViewKind::only_for`]).
    ClutchActuation,
}

impl ViewKind {
    /// Whether the view is its own term of the deviance ([`super::fit::Evaluator::deviance`]):
    /// the modes, the reversals and the clutch-actuated engine speed are other quantities (or
    /// other rows) than the speeds and the pressures, which are pooled as largely redundant.
    pub fn own_term(self) -> bool {
        matches!(
            self,
            ViewKind::ShuffleModes | ViewKind::Reversals | ViewKind::ClutchActuation
        )
    }

    /// The effects a view is fitted and scored for, when it is not every effect that changes it:
    /// the clutch-actuation view serves `clutch_slip`, whose catalogue fingerprint it is
    /// (docs/diagnosis/catalogue.md), and `signal_delay`, whose delayed torque ramps land against
    /// the clutch at every shift — rows the nominal model reproduces only to the 10 Hz clutch's
    /// timing, which every other longitudinal effect moves a little without carrying its evidence
    /// there; scored for all of them it would dilute their held-out figures.
    ///
    /// The shuffle-modes view serves `driveline_compliance`, whose fingerprint it is. The mass
    /// moves the modes too, through the vehicle's inertia and the driven tyres' friction limit
    /// `F_max = μ·0.29·m·g` (docs/diagnosis/method.md, rule 4), but the tyres' share of the
    /// flexibility is fitted on each drive at the file's mass, so a mass change read there is
    /// the share's error more than the truck's weight; the mass's fingerprint is in the speeds
    /// (a force in proportion to `a + g·sin α`). Scored for the mass, the modes pull its fit
    /// back toward the file's value and dilute its held-out gain: on an independent-truth drive
    /// of a 30.7 t truck against a 40 t file, a fit to 31.8 t takes the speeds' held-out weighted
    /// mean square from 6.6 to 1.9 and the modes' from 4.5 to 20.5.
    pub fn only_for(self) -> Option<&'static [Effect]> {
        match self {
            ViewKind::ClutchActuation => Some(&[Effect::ClutchSlip, Effect::SignalDelay]),
            ViewKind::ShuffleModes => Some(&[Effect::DrivelineCompliance]),
            _ => None,
        }
    }
}
