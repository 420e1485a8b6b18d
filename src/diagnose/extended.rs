//! The nominal models extended by every catalogue effect (docs/diagnosis/method.md, step 3): one
//! parameter vector [`Theta`] whose component per [`Effect`] is that effect's parameter, in the
//! same SI quantity the catalogue names (`c_w_a_f_m2`, `mass_kg`, `slope_offset_rad`, …;
//! [`Effect::parameter`]). At the nominal values ([`Theta::nominal`]) the extended models are the
//! nominal ones.
//!
//! # What each component does to the model
//! - plant parameters (drag area, rolling resistance, mass, shaft stiffness, clutch capacity,
//!   CG height and position, tyre stiffness) and structural extensions (drive-shaft lash,
//!   torque reaction, bellow progression, grade-force height) are set on a
//!   [`ExtendedVehicle`] built from the vehicle file ([`ExtendedVehicle::set`]), the model
//!   layer's one definition of what each catalogue parameter means;
//! - sensor effects correct the *recorded inputs* before the model sees them, and the held slope
//!   is read half its native period ahead ([`corrected_log`], [`super::model_inputs`]);
//! - `slope_quantization`'s parameter is the slope sensor's resolution: a value above the
//!   nominal one replaces the recorded slope by its consistent reconstruction
//!   ([`SlopeGrid::cured`], [`super::slope_grid`]).
//!
//! # The parts
//! - [`super::effect_parameters`]: [`Theta`], one parameter per effect;
//! - [`super::extended_error`]: [`ExtendedError`], why a model cannot be built or run;
//! - [`super::model_inputs`]: the recording as the models read it;
//! - [`super::slope_grid`]: the recorded slope on the distance grid and its cure;
//! - [`super::simulation_windows`]: where the longitudinal model's windows start and where it
//!   integrates at the fine step;
//! - [`super::longitudinal_model`]: [`LongitudinalModel`], vehicle and engine speed;
//! - [`super::axle_model`]: [`AxleModel`], the three bellow pressures.
//!
//! This module re-exports them.
//!
//! [`Effect`]: crate::model::catalogue::Effect
//! [`Effect::parameter`]: crate::model::catalogue::Effect::parameter
//! [`ExtendedVehicle`]: crate::model::extended_vehicle::ExtendedVehicle
//! [`ExtendedVehicle::set`]: crate::model::extended_vehicle::ExtendedVehicle::set

pub use super::axle_model::AxleModel;
pub use super::effect_parameters::{index, Theta};
pub use super::extended_error::ExtendedError;
pub use super::longitudinal_model::{
    LongitudinalConfig, LongitudinalModel, LongitudinalOutputs, SLIP_START_MIN_RAD_S,
};
pub use super::model_inputs::corrected_log;
pub(crate) use super::model_inputs::shifted;
pub use super::simulation_windows::{fine_spans, window_starts, FINE_STEP_S, STEP_CLEAR_S};
pub use super::slope_grid::SlopeGrid;
