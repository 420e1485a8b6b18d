//! Roads: the road-slope filter of seed 000 §5, and road profiles from real tracks (GNSS fixes
//! or VECTO driving cycles) whose slope spectra the seed's figures are compared with.

pub mod profile;
pub mod slope_filter;
pub mod vdri;
