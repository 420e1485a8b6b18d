//! The diagnosis proof: synthetic drives with one concealed effect each — every catalogue
//! effect the truth can hide, random magnitudes within realistic ranges, different roads and
//! driving — plus drives with no effect and drives with an effect outside the catalogue; the
//! diagnosis runs blind on each (it sees the drive and the nominal vehicle file, never the
//! answer) and is scored against the answers kept apart. This module sits above the diagnosis
//! and the generators; the diagnosis imports neither.
//!
//! # Truth
//! [`TruthSource::Independent`] (the default, the proof) draws the drives from the independent
//! truth plant ([`crate::truth`]), which shares no code with the models the diagnosis fits,
//! has more structure than they do, and draws the truck's parameters around the vehicle file
//! within its tolerances on every drive, the no-effect drives included.
//! [`TruthSource::Model`] draws them from the diagnosis's own extended model
//! ([`crate::synth::effects`]): an inversion check, labelled as such in every summary.
//!
//! # Plan
//! Case `i` of a proof with seed `S` has the drive seed `S + i`. Effects cycle through the
//! catalogue ([`ProofConfig::effects`]: the ten longitudinal effects on the independent truth,
//! all sixteen on the model) with extra slots per cycle: [`ProofConfig::clean_per_cycle`]
//! drives without effect (4) and [`ProofConfig::out_of_catalogue_per_cycle`] with an effect
//! outside the catalogue on one stretch ([`Outside`]: 3 on the independent truth, one of each
//! kind in turn; 2 on the model). The road rule set is drawn per case (highway-se, freeway-us,
//! city-se, urban-us with weights 3:3:2:2 — fleet trucks drive mostly on highways), the length
//! uniformly in [`ProofConfig::length_km`]; both truths drive the same roads and lengths case
//! for case. On the model truth the driving is drawn per case too ([`Driving::Drawn`],
//! [`drive_config`]): how briskly the driver accelerates and brakes, how tightly they hold the
//! speed, how much their foot varies the torque, how often they lift off, how long they stand
//! at a stop; the independent truth has its own driver. Every drive has the conditions of a
//! real log: multi-rate quantised CAN with noise, launches, stops and gear shifts,
//! standstills, CAN dropouts ([`ProofConfig::dropouts`]), and starts from an unknown state for
//! the diagnosis.
//!
//! # Scores
//! - *named*: the first finding's effect (`none` for a drive without finding; `unexplained`
//!   for that verdict); *correct* when it is the hidden effect; *ambiguous-correct* when the
//!   hidden effect is in the first finding's `ambiguous_with` (reported separately);
//! - false-positive rate: no-effect drives with any finding;
//! - parameter error: `|fitted − truth| / |truth − nominal|`, relative to the hidden change
//!   (stricter than relative to the value: a 30 % drag change fitted at 25 % is a 17 % error);
//! - held-out: the first finding's held-out RMSE after/before per signal of the effect's
//!   domain, the most improved (the quoted signal) and the least;
//! - noise-free held-out: the quoted signal's ratio again, scored against the generator's
//!   noise-free signal instead of the recording, with the fitted value and with the hidden
//!   truth ([`CaseScore::noise_free_heldout_ratio`], [`CaseScore::noise_free_truth_ratio`]):
//!   it tells a drive whose ratio the recording's noise holds up from one no fit of the effect
//!   could halve on the recorded inputs;
//! - out-of-catalogue drives pass when the verdict is `unexplained` or a mismatch overlaps the
//!   stretch without any catalogue effect being named.

pub mod fleet;
pub mod fleet_run;
pub mod generate;
pub mod plan;
pub mod run;
pub mod score;
pub mod summary;
pub mod workers;

pub use fleet::{FleetFault, FleetProofConfig};
pub use fleet_run::{rescore_fleet_proof, run_fleet_proof, FleetProofRun};
pub use generate::{drive_config, generate, GenerateError, GeneratedCase, ProofTruth, Stretch};
pub use plan::{drawn_driver, plan, Driving, Hidden, Outside, ProofCase, ProofConfig, TruthSource};
pub use run::{run_proof, ProofRun, ProveError, MAX_ATTEMPTS, RESEED_STRIDE};
pub use score::{noise_free_reference, score, CaseScore};
pub use summary::{cases_markdown, summarize, FailedCase, ProofSummary};
