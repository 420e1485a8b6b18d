//! SVG plots of an axle-load simulation: the three normal forces as scale readings (t) over
//! time, and the three bellow gauge pressures (bar) over time — the quantities of the axle-load
//! thesis (docs/models/axle.md), figures 4.4/4.7 and 4.2/4.5. Each plot is rendered in memory
//! and written atomically.

use super::plot_points::m4_points;
use crate::io::AtomicFile;
use crate::sim::axle::AxleTrajectory;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a plot could not be made.
#[derive(Debug, Error)]
pub enum PlotError {
    /// Nothing to draw: no finite sample.
    #[error("plot {path}: no finite samples to draw")]
    Empty {
        /// Target path.
        path: PathBuf,
    },
    /// The drawing backend failed.
    #[error("plot {path}: {message}")]
    Draw {
        /// Target path.
        path: PathBuf,
        /// The backend's message.
        message: String,
    },
    /// Writing the file failed.
    #[error("writing {path}: {source}")]
    Io {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

const AXLES: [&str; 3] = ["front", "rear (driven)", "tag"];

/// Finite range of all series, padded by 5 % (at least ±`min_pad`).
fn range(series: &[Vec<(f64, f64)>], min_pad: f64) -> Option<(f64, f64, f64, f64)> {
    let pts = series
        .iter()
        .flatten()
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let (x0, x1, y0, y1) = pts.fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), &(x, y)| (a.min(x), b.max(x), c.min(y), d.max(y)),
    );
    if !(x0.is_finite() && y0.is_finite()) {
        return None;
    }
    let pad = (0.05 * (y1 - y0)).max(min_pad);
    let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
    Some((x0, x1, y0 - pad, y1 + pad))
}

/// Size of a plot, pixels (width, height).
const PLOT_SIZE: (u32, u32) = (900, 500);

/// Draws one panel of three series and writes it to `path`. Each line holds the points an M4
/// aggregation over twice the plot's width in columns keeps ([`m4_points`]: the same drawing,
/// at most 7 200 points a line whatever the drive's length).
fn plot(
    path: &Path,
    title: &str,
    y_desc: &str,
    series: [Vec<(f64, f64)>; 3],
    min_pad: f64,
) -> Result<(), PlotError> {
    let draw = |message: String| PlotError::Draw {
        path: path.to_path_buf(),
        message,
    };
    let (x0, x1, y0, y1) = range(&series, min_pad).ok_or_else(|| PlotError::Empty {
        path: path.to_path_buf(),
    })?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, PLOT_SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| draw(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("time [s]")
            .y_desc(y_desc)
            .draw()
            .map_err(|e| draw(e.to_string()))?;
        for (k, s) in series.into_iter().enumerate() {
            let colour = Palette99::pick(k).to_rgba();
            let finite = m4_points(s, (x0, x1), 2 * PLOT_SIZE.0 as usize);
            chart
                .draw_series(LineSeries::new(finite, colour.stroke_width(2)))
                .map_err(|e| draw(e.to_string()))?
                .label(AXLES[k])
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], colour));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| draw(e.to_string()))?;
        root.present().map_err(|e| draw(e.to_string()))?;
    }
    let io = |source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    };
    AtomicFile::write_all(path, svg.as_bytes()).map_err(io)
}

/// Plots the front, rear and tag normal forces as scale readings `N/g` in tonnes over time.
///
/// # Errors
/// [`PlotError`] when there is no finite sample, drawing fails or the file cannot be written
/// (nothing is then left at `path`).
pub fn plot_normal_forces(
    path: &Path,
    traj: &AxleTrajectory,
    gravity_m_per_s2: f64,
    title: &str,
) -> Result<(), PlotError> {
    let to_t = 1.0 / (gravity_m_per_s2 * 1000.0);
    let series = [0, 1, 2].map(|i| {
        traj.t_s
            .iter()
            .zip(&traj.normal_n[i])
            .map(|(&t, &n)| (t, n * to_t))
            .collect()
    });
    plot(path, title, "normal force N/g [t]", series, 0.05)
}

/// Plots the front, rear and tag bellow gauge pressures in bar over time.
///
/// # Errors
/// As [`plot_normal_forces`].
pub fn plot_pressures(path: &Path, traj: &AxleTrajectory, title: &str) -> Result<(), PlotError> {
    let series = [0, 1, 2].map(|i| {
        traj.t_s
            .iter()
            .zip(&traj.pressure_pa[i])
            .map(|(&t, &p)| (t, p / 1e5))
            .collect()
    });
    plot(path, title, "bellow gauge pressure [bar]", series, 0.02)
}
