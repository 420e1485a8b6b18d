//! Model-vs-recording mismatch diagnosis (issue 7, `diagnosis.md`): compare, locate, explain,
//! show.

pub mod catalogue;
pub mod compare;
pub mod explain;
pub mod extended;
pub mod fit;
pub mod problem;
