//! Roads: the road-slope filter of seed 000 §5, synthetic roads from road-design rules and
//! their spatial spectra (seed 000 §4, physics.md §2).
//!
//! - [`slope_filter`]: the 3rd-order zero-phase / causal Butterworth slope filter.
//! - [`rules`]: road-design rule sets (`schemas/roads/*.toml` or a user file).
//! - [`rng`]: the documented, self-contained PRNG the generator draws from.
//! - [`synth`]: the generator — constant grades joined by parabolic vertical curves.
//! - [`road_table`]: road profiles as Parquet, and reading a slope column on a distance grid.
//! - [`study`]: Welch spectra of slope, knees, and studies over many random roads.
//! - [`profile`], [`vdri`]: road profiles from real tracks (GNSS fixes, VECTO driving cycles).

pub mod profile;
pub mod rng;
pub mod road_table;
pub mod rules;
pub mod slope_filter;
pub mod study;
pub mod synth;
pub mod vdri;
