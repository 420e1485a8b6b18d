//! A measured road profile read for a comparison or a fit ([`super::compare`], [`super::fit`]):
//! the slope (tan α) of a VECTO cycle or of a road Parquet on the comparison's grid, optionally
//! cut to a window of distance.
//!
//! A VECTO cycle is turned into a profile as `fleetdyn road profile` does
//! ([`super::vdri::cycle_profile`]); a Parquet file needs a uniform `distance` grid (m) of the
//! comparison's step and a `slope` column (unit `1`), as `road profile` and `road synth` write.
//! A window `[from, to]` km keeps the grid points from `round(from/step)` to `round(to/step)`.

use super::compare::ProfileInput;
use super::profile::ProfileError;
use super::road_table::{read_distance_column, RoadFileError};
use super::vdri::{cycle_profile, detect_input, read_vdri, ProfileInput as Kind};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a profile could not be read for a comparison.
#[derive(Debug, Error)]
pub enum ProfileInputError {
    /// The file is not a usable VECTO cycle (or could not be read).
    #[error(transparent)]
    Profile(#[from] ProfileError),
    /// The Parquet file has no usable `distance` / `slope` columns.
    #[error(transparent)]
    RoadFile(#[from] RoadFileError),
    /// The Parquet file's grid differs from the comparison's.
    #[error("{file}: its grid step is {step_m} m, the comparison's {expected_m} m (--step-m)")]
    Step {
        /// File.
        file: PathBuf,
        /// Its step, m.
        step_m: f64,
        /// The comparison's step, m.
        expected_m: f64,
    },
    /// The window reaches beyond the profile.
    #[error("{file}: window {from_km}..{to_km} km reaches beyond the profile's {length_km:.3} km")]
    Window {
        /// File.
        file: PathBuf,
        /// Window start, km.
        from_km: f64,
        /// Window end, km.
        to_km: f64,
        /// The profile's length, km.
        length_km: f64,
    },
}

/// Reads `path` as a profile of class `class` on a `step_m` grid, cut to `window_km` (module
/// doc). Its label is the file stem, with `@FROM..TO` when windowed.
///
/// # Errors
/// [`ProfileInputError`].
pub fn read_profile_input(
    path: &Path,
    class: &str,
    window_km: Option<(f64, f64)>,
    step_m: f64,
) -> Result<ProfileInput, ProfileInputError> {
    let slope = match detect_input(path)? {
        Kind::VectoCycle => cycle_profile(&read_vdri(path)?, step_m)?.slope,
        Kind::Recording => {
            let col = read_distance_column(path, "slope")?;
            if (col.step_m - step_m).abs() > 1e-9 * step_m {
                return Err(ProfileInputError::Step {
                    file: path.to_path_buf(),
                    step_m: col.step_m,
                    expected_m: step_m,
                });
            }
            col.values
        }
    };
    let stem = path.file_stem().map_or_else(
        || path.display().to_string(),
        |s| s.to_string_lossy().into(),
    );
    let (name, slope) = match window_km {
        None => (stem, slope),
        Some((a, b)) => {
            let length_km = (slope.len().saturating_sub(1)) as f64 * step_m / 1000.0;
            if !(a >= 0.0 && a < b && b <= length_km + 1e-9) {
                return Err(ProfileInputError::Window {
                    file: path.to_path_buf(),
                    from_km: a,
                    to_km: b,
                    length_km,
                });
            }
            let last = slope.len() - 1;
            let i0 = ((a * 1000.0 / step_m).round() as usize).min(last);
            let i1 = ((b * 1000.0 / step_m).round() as usize).min(last);
            (format!("{stem}@{a}..{b}"), slope[i0..=i1].to_vec())
        }
    };
    Ok(ProfileInput {
        name,
        class: class.into(),
        origin: path.display().to_string(),
        slope,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vecto() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/real/vecto/UrbanDelivery.vdri")
    }

    #[test]
    fn a_window_keeps_its_grid_points_and_names_itself() {
        let whole = read_profile_input(&vecto(), "city", None, 1.0).unwrap();
        assert_eq!(whole.name, "UrbanDelivery");
        assert_eq!(whole.slope.len(), 27_817);
        let w = read_profile_input(&vecto(), "city", Some((1.0, 2.5)), 1.0).unwrap();
        assert_eq!(w.name, "UrbanDelivery@1..2.5");
        assert_eq!(w.slope, whole.slope[1000..=2500].to_vec());
        assert_eq!(w.class, "city");
    }

    #[test]
    fn a_window_beyond_the_profile_is_refused() {
        let e = read_profile_input(&vecto(), "", Some((20.0, 40.0)), 1.0).unwrap_err();
        assert!(
            e.to_string()
                .contains("window 20..40 km reaches beyond the profile's 27.816 km"),
            "{e}"
        );
        assert!(matches!(
            read_profile_input(&vecto(), "", Some((3.0, 2.0)), 1.0),
            Err(ProfileInputError::Window { .. })
        ));
    }
}
