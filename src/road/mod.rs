//! Roads: the road-slope filter, synthetic roads from road-design rules and their spatial
//! spectra (docs/models/road.md).
//!
//! # Reference
//!
//! A. Myklebust, L. Eriksson, "Road Slope Analysis and Filtering for Driveline Shuffle
//! Simulation", IFAC E-COSM'12 (2012): §4 road frequency (road-design rules, synthetic roads,
//! their spectra), §5 filter design. Cited in this crate as "Myklebust & Eriksson (2012)".
//!
//! - [`slope_filter`]: the 3rd-order zero-phase / causal Butterworth slope filter.
//! - [`rules`]: road-design rule sets (`schemas/roads/*.toml` or a user file).
//! - [`crate::rng`]: the documented, self-contained PRNG the generator draws from.
//! - [`synth`]: the generator — constant grades joined by parabolic vertical curves.
//! - [`road_table`]: road profiles as Parquet, and reading a slope column on a distance grid.
//! - [`study`]: Welch spectra of slope, knees, and studies over many random roads.
//! - [`compare`]: rule sets, measured profiles and a driveline's resonances on one grid.
//! - [`fit`]: a rule set's segment lengths calibrated to measured roads; [`profile_input`]: the
//!   measured profiles they read.
//! - [`profile`], [`gnss_profile`], [`vdri`]: road profiles from real tracks (GNSS fixes, VECTO
//!   driving cycles); [`wgs84`]: the distance between GNSS fixes; [`profile_table`]: those
//!   profiles as Parquet.

pub mod compare;
pub mod fit;
pub mod gnss_profile;
pub mod profile;
pub mod profile_input;
pub mod profile_table;
pub mod road_table;
pub mod rules;
pub mod slope_filter;
pub mod study;
pub mod synth;
pub mod vdri;
pub mod wgs84;
