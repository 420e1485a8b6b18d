//! Roads: the road-slope filter of seed 000 §5 (synthetic roads and their spectra follow).

pub mod slope_filter;
