//! Model-vs-recording mismatch diagnosis (docs/diagnosis/method.md): compare, locate, explain,
//! show.

pub mod compare;
pub mod contract;
pub mod events;
pub mod explain;
pub mod extended;
pub mod fit;
pub mod locate;
pub mod modal;
pub mod modal_channel;
pub mod noise;
pub mod problem;
pub mod reversal_channel;
pub mod rows;
pub mod run;
pub mod setup;
pub mod tyre_slip;
