//! The diagnosis proof: synthetic drives with one concealed effect
//! each — every catalogue effect, random magnitudes within the generator's realistic ranges,
//! different roads and driving — plus drives with no effect and drives with an effect outside
//! the catalogue; the diagnosis runs blind on each (it sees the drive and the nominal vehicle
//! file, never the answer) and is scored against the answers kept apart.
//!
//! # Plan
//! Case `i` of a proof with seed `S` has the drive seed `S + i`. Effects cycle through the
//! catalogue with extra slots per cycle: [`ProofConfig::clean_per_cycle`] drives without effect
//! (4 by default, so that the false-positive rate is measured on more than a handful) and
//! [`ProofConfig::out_of_catalogue_per_cycle`] with the out-of-catalogue stretch of extra
//! rolling resistance (2), so `22 k` drives hold every effect `k` times. The road rule set is drawn per case (highway-se, freeway-us, city-se, urban-us
//! with weights 3:3:2:2 — fleet trucks drive mostly on highways), the length uniformly in
//! [`ProofConfig::length_km`]. The driving is drawn per case too ([`Driving::Drawn`],
//! [`drive_config`]): how briskly the driver accelerates and brakes, how tightly they hold the
//! speed, how much their foot varies the torque, how often they lift off while driving on, and
//! how long they stand at a stop. Every drive has the real-log conditions of issue 7 point 7:
//! multi-rate quantised CAN with noise, launches, stops and AMT shifts, standstills, CAN
//! dropouts ([`ProofConfig::dropouts`]), and starts from an unknown state for the diagnosis.
//! The slope sensor is fine (0.1 %) unless the case hides `slope_quantization`, which is then
//! the sensor's coarser step.
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

pub mod generate;
pub mod plan;
pub mod run;
pub mod score;
pub mod summary;

pub use generate::{drive_config, generate, GenerateError, GeneratedCase, ProofTruth, Stretch};
pub use plan::{drawn_driver, plan, Driving, Hidden, Outside, ProofCase, ProofConfig, TruthSource};
pub use run::{run_proof, ProofRun, ProveError, MAX_ATTEMPTS, RESEED_STRIDE};
pub use score::{noise_free_reference, score, CaseScore};
pub use summary::{cases_markdown, summarize, FailedCase, ProofSummary};
