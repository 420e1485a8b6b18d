//! VECTO distance-based driving cycles (`.vdri`) as road profiles.
//!
//! # Format
//! VECTO, the EU's regulatory heavy-duty CO2 simulator, defines a mission as a CSV table with
//! bracketed headers: `<s>` distance (m), `<v>` target speed (km/h), `<grad>` road grade (%,
//! i.e. 100·tan α), `<stop>` stop time (s), optionally more columns (`<Aux_…>`, `<n>`, …), which
//! are ignored here. Lines starting with `#` are comments. A file is recognised by its content
//! ([`vecto_header`]: the first non-comment line holds `<s>`), not by its extension. A
//! time-based cycle (`<t>`) has no distance axis and is refused.
//!
//! # Grade convention (VECTO's own)
//! The grade of row i holds from `<s>_i` to `<s>_{i+1}` and the altitude is its integral:
//! `z_0 = 0`, `z_{i+1} = z_i + (s_{i+1} − s_i)·grad_i/100`, as VECTO's reader computes it
//! (vecto-sim, `VectoCore/FileIO/Reader/DrivingCycleDataReader.cs`, `FilterDrivingCycleEntries`:
//! `altitude += (entry.Distance − distance) · entries[i−1].RoadGradientPercent / 100`). On the
//! grid `x_k = k·step_m` (distance from the first row) the elevation is that piecewise-linear
//! altitude, exact, and `slope` is the grade in force at `x_k`: `grad_i/100` for
//! `s_i ≤ s_0 + x_k < s_{i+1}` (the last row's grade at the end). The forward difference of the
//! elevation between two grid points inside one row interval is therefore that row's grade/100.
//!
//! # What the row spacing means for spectra
//! The rows are not uniform: the Long Haul cycle has 10 m rows through vertical curves and rows
//! up to 4.2 km apart on stretches of nearly constant grade (69 % of its length lies in intervals
//! longer than 100 m; across them the grade changes by 0.1 percentage points on median, so the
//! file was thinned to a grade tolerance). The held grade is a staircase: its steps add power
//! above the 10 m rows' Nyquist frequency (0.05 1/m) that is an artefact of the format, not road,
//! and variations smaller than the thinning tolerance on long stretches are absent.
//!
//! # Errors
//! [`ProfileError::Vdri`] naming file, line, column and value: a missing `<s>`/`<grad>` column,
//! a row with the wrong number of cells, a non-numeric or non-finite cell in `<s>`, `<v>`,
//! `<grad>` or `<stop>`, a decreasing distance, a grade outside the drive-log schema's slope
//! range (±30 %); [`ProfileError::TooFewFixes`] for fewer than 2 rows;
//! [`ProfileError::NeverMoves`] for a cycle shorter than two grid steps.

use super::profile::{ProfileError, ProfileSource, RoadProfile, VdriFacts};
use crate::schema::drive_log;
use crate::table::DriveMeta;
use std::path::Path;

/// What the header of a VECTO cycle says about its axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VectoHeader {
    /// Distance-based (`<s>` present).
    Distance,
    /// Time-based (`<t>` present, no `<s>`).
    Time,
}

fn header_cells(line: &str) -> Vec<String> {
    line.split(',')
        .map(|c| c.trim().to_ascii_lowercase())
        .collect()
}

/// The kind of VECTO cycle the start of a file holds, `None` when it is not one: the first
/// line that is neither empty nor a `#` comment must contain a `<s>` or `<t>` header cell.
pub fn vecto_header(head: &[u8]) -> Option<VectoHeader> {
    let text = String::from_utf8_lossy(head);
    let text = text.trim_start_matches('\u{feff}');
    let line = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))?;
    let cells = header_cells(line);
    if cells.iter().any(|c| c == "<s>") {
        Some(VectoHeader::Distance)
    } else if cells.iter().any(|c| c == "<t>") {
        Some(VectoHeader::Time)
    } else {
        None
    }
}

/// A distance-based VECTO driving cycle as read (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct VectoCycle {
    /// Source file.
    pub file: String,
    /// `<s>`, m.
    pub distance_m: Vec<f64>,
    /// `<grad>`/100 = tan α.
    pub grade: Vec<f64>,
    /// `<v>`, m/s (NaN where the file has no `<v>` column).
    pub target_speed_mps: Vec<f64>,
    /// `<stop>`, s (0 where the file has no `<stop>` column).
    pub stop_s: Vec<f64>,
}

/// Reads a distance-based `.vdri` file.
///
/// # Errors
/// See the module doc.
pub fn read_vdri(path: &Path) -> Result<VectoCycle, ProfileError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| ProfileError::Io {
        file: file.clone(),
        source,
    })?;
    let err = |line: usize, column: &str, value: &str, message: &str| ProfileError::Vdri {
        file: file.clone(),
        line,
        column: column.into(),
        value: value.into(),
        message: message.into(),
    };
    let text = String::from_utf8(bytes).map_err(|e| {
        err(
            0,
            "-",
            &format!("byte {}", e.utf8_error().valid_up_to()),
            "not UTF-8 text",
        )
    })?;
    let text = text.trim_start_matches('\u{feff}');
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (hline, header) = lines
        .next()
        .ok_or_else(|| err(0, "-", "", "no header line"))?;
    let cells = header_cells(header);
    let find = |name: &str| cells.iter().position(|c| c == name);
    let s_col = find("<s>").ok_or_else(|| {
        err(
            hline,
            "<s>",
            header,
            if find("<t>").is_some() {
                "a time-based VECTO cycle has no distance axis; a road profile needs <s>"
            } else {
                "no <s> distance column in the header"
            },
        )
    })?;
    let g_col = find("<grad>")
        .ok_or_else(|| err(hline, "<grad>", header, "no <grad> column in the header"))?;
    let (v_col, stop_col) = (find("<v>"), find("<stop>"));
    let max_grade = drive_log()
        .column("road_slope")
        .and_then(|c| c.valid_max)
        .unwrap_or(0.3);

    let mut c = VectoCycle {
        file: file.clone(),
        distance_m: Vec::new(),
        grade: Vec::new(),
        target_speed_mps: Vec::new(),
        stop_s: Vec::new(),
    };
    for (line, l) in lines {
        let row: Vec<&str> = l.split(',').map(str::trim).collect();
        if row.len() != cells.len() {
            return Err(err(
                line,
                "-",
                l,
                &format!("{} cells where the header has {}", row.len(), cells.len()),
            ));
        }
        let num = |k: usize| -> Result<f64, ProfileError> {
            let v: f64 = row[k]
                .parse()
                .map_err(|_| err(line, &cells[k], row[k], "not a number"))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(err(line, &cells[k], row[k], "not a finite number"))
            }
        };
        let s = num(s_col)?;
        let g = num(g_col)? / 100.0;
        let v = v_col.map(num).transpose()?.map_or(f64::NAN, |v| v / 3.6);
        let stop = stop_col.map(num).transpose()?.unwrap_or(0.0);
        if let Some(&prev) = c.distance_m.last() {
            if s < prev {
                return Err(err(
                    line,
                    "<s>",
                    row[s_col],
                    &format!("distance decreases (previous row {prev} m)"),
                ));
            }
        }
        if g.abs() > max_grade {
            return Err(err(
                line,
                "<grad>",
                row[g_col],
                &format!(
                    "grade outside ±{} % (the drive-log schema's road_slope range)",
                    100.0 * max_grade
                ),
            ));
        }
        c.distance_m.push(s);
        c.grade.push(g);
        c.target_speed_mps.push(v);
        c.stop_s.push(stop);
    }
    if c.distance_m.len() < 2 {
        return Err(ProfileError::TooFewFixes {
            file,
            column: "<s>".into(),
            fixes: c.distance_m.len(),
            min: 2,
        });
    }
    Ok(c)
}

/// The road profile of a cycle on the grid `k·step_m` from its first row (module doc).
///
/// # Errors
/// [`ProfileError::Setting`] for a step that is not positive and finite;
/// [`ProfileError::NeverMoves`] for a cycle shorter than two steps.
pub fn cycle_profile(c: &VectoCycle, step_m: f64) -> Result<RoadProfile, ProfileError> {
    if !(step_m.is_finite() && step_m > 0.0) {
        return Err(ProfileError::Setting {
            key: "step_m".into(),
            value: step_m.to_string(),
            rule: "must be positive and finite".into(),
        });
    }
    let s0 = c.distance_m[0];
    let s: Vec<f64> = c.distance_m.iter().map(|x| x - s0).collect();
    let n = s.len();
    let length = s[n - 1];
    if length < 2.0 * step_m {
        return Err(ProfileError::NeverMoves {
            file: c.file.clone(),
            distance_m: length,
            fixes: n,
            duration_s: 0.0,
            min_m: 2.0 * step_m,
        });
    }
    // VECTO's altitude at the rows
    let mut z = vec![0.0; n];
    for i in 1..n {
        z[i] = z[i - 1] + (s[i] - s[i - 1]) * c.grade[i - 1];
    }
    let n_grid = (length / step_m + 1e-9).floor() as usize + 1;
    let mut distance = Vec::with_capacity(n_grid);
    let mut elevation = Vec::with_capacity(n_grid);
    let mut slope = Vec::with_capacity(n_grid);
    let mut i = 0;
    for k in 0..n_grid {
        let x = k as f64 * step_m;
        // last row with s_i <= x
        while i + 1 < n && s[i + 1] <= x {
            i += 1;
        }
        distance.push(x);
        elevation.push(z[i] + c.grade[i] * (x - s[i]));
        slope.push(c.grade[i]);
    }
    let mut gaps: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_by(f64::total_cmp);
    let stem = Path::new(&c.file)
        .file_stem()
        .map(|x| x.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok(RoadProfile {
        meta: DriveMeta {
            drive_id: stem,
            vehicle_id: None,
            source_file: c.file.clone(),
            segment: None,
        },
        source: ProfileSource::Vdri(VdriFacts {
            rows: n,
            start_m: s0,
            length_m: length,
            spacing_m: (gaps[0], gaps[gaps.len() / 2], gaps[gaps.len() - 1]),
        }),
        step_m,
        distance_m: distance,
        elevation_m: elevation,
        elevation_smoothed_m: None,
        slope,
        latitude_deg: None,
        longitude_deg: None,
        imu_slope: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_detection_by_content() {
        assert_eq!(
            vecto_header(b"<s>,<v>,<grad>,<stop>\n0,0,1,2\n"),
            Some(VectoHeader::Distance)
        );
        assert_eq!(
            vecto_header(b"\xef\xbb\xbf# comment\n\n <S> , <v>\n"),
            Some(VectoHeader::Distance)
        );
        assert_eq!(vecto_header(b"<t>,<v>\n"), Some(VectoHeader::Time));
        assert_eq!(vecto_header(b"PAR1\x00\x00"), None);
        assert_eq!(vecto_header(b"t,speed\n1,2\n"), None);
    }

    #[test]
    fn elevation_is_vectos_altitude_and_slope_the_held_grade() {
        let c = VectoCycle {
            file: "x.vdri".into(),
            distance_m: vec![0.0, 10.0, 25.0],
            grade: vec![0.02, -0.01, 0.0],
            target_speed_mps: vec![f64::NAN; 3],
            stop_s: vec![0.0; 3],
        };
        let p = cycle_profile(&c, 5.0).unwrap();
        assert_eq!(p.distance_m, vec![0.0, 5.0, 10.0, 15.0, 20.0, 25.0]);
        let z = [0.0, 0.1, 0.2, 0.15, 0.1, 0.05];
        for (a, b) in p.elevation_m.iter().zip(z) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        assert_eq!(p.slope, vec![0.02, 0.02, -0.01, -0.01, -0.01, 0.0]);
    }
}

/// What a road-profile input holds, recognised by content (not by the file name).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProfileInput {
    /// A recording for ingest (Parquet or MCAP magic, or anything that is not a VECTO cycle:
    /// ingest then reports the unknown format).
    Recording,
    /// A VECTO distance-based driving cycle (`.vdri` CSV with a `<s>` header).
    VectoCycle,
}

/// Looks at the first 4 KiB of `path`: Parquet (`PAR1`) or MCAP magic is a recording; a text
/// whose first non-comment line has a `<s>` header cell is a VECTO cycle.
///
/// # Errors
/// [`ProfileError::Io`] when the file cannot be read; [`ProfileError::Vdri`] for a time-based
/// VECTO cycle (`<t>` without `<s>`), which has no distance axis.
pub fn detect_input(path: &Path) -> Result<ProfileInput, ProfileError> {
    use std::io::Read as _;
    let file = path.display().to_string();
    let mut head = Vec::with_capacity(4096);
    std::fs::File::open(path)
        .and_then(|f| f.take(4096).read_to_end(&mut head))
        .map_err(|source| ProfileError::Io {
            file: file.clone(),
            source,
        })?;
    if head.starts_with(b"PAR1") || head.starts_with(b"\x89MCAP") {
        return Ok(ProfileInput::Recording);
    }
    match vecto_header(&head) {
        Some(VectoHeader::Distance) => Ok(ProfileInput::VectoCycle),
        Some(VectoHeader::Time) => Err(ProfileError::Vdri {
            file,
            line: 1,
            column: "<t>".into(),
            value: String::new(),
            message: "a time-based VECTO cycle has no distance axis; a road profile needs <s>"
                .into(),
        }),
        None => Ok(ProfileInput::Recording),
    }
}
