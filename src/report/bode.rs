//! `fleetdyn bode`: the per-gear resonance table of the linear driveline model (Myklebust &
//! Eriksson (2012), §3) as text, Parquet (schema `bode`) and an SVG Bode-magnitude plot.

use crate::io::{config_hash, write_table, OutColumn, OutData, OutputError, TableMeta};
use crate::model::driveline::DrivelineParams;
use crate::model::linear::linearize;
use crate::model::resonance::{resonance, Path, Resonance};
use plotters::prelude::*;
use std::fmt;
use std::path::Path as FsPath;

/// Canonical text of the driveline `p` and gear `ratios`, for the config hash of a Bode table.
pub fn fingerprint(p: &DrivelineParams, ratios: &[f64]) -> String {
    crate::io::canonical("bode:v2", &(p, ratios))
}

/// One gear's row.
#[derive(Debug, Clone, PartialEq)]
pub struct BodeRow {
    /// `F_dr → v`, open loop.
    pub fdr_open: Resonance,
    /// `M_e → v`, open loop.
    pub me_open: Resonance,
    /// `F_dr → v`, closed loop.
    pub fdr_closed: Resonance,
    /// i_t·i_f.
    pub total_ratio: f64,
    /// Natural frequency of the lowest oscillatory open-loop mode, Hz.
    pub mode_hz: f64,
    /// Its damping ratio.
    pub mode_damping: f64,
}

/// The per-gear table.
#[derive(Debug, Clone, PartialEq)]
pub struct BodeTable {
    /// Vehicle id.
    pub vehicle_id: String,
    /// Rows, gear 1 first.
    pub rows: Vec<BodeRow>,
}

impl BodeTable {
    /// Analyses every forward gear.
    pub fn new(vehicle_id: &str, p: &DrivelineParams, ratios: &[f64]) -> Self {
        let rows = (1..=ratios.len())
            .map(|g| {
                let fdr_open = resonance(p, ratios, g, Path::ResistanceOpen);
                let lin = linearize(p, ratios, g, fdr_open.v0_mps);
                let mode = lin
                    .open
                    .eigenvalues()
                    .into_iter()
                    .filter(|z| z.im > 0.0)
                    .min_by(|a, b| a.norm().total_cmp(&b.norm()));
                let (mode_hz, mode_damping) = mode.map_or((f64::NAN, f64::NAN), |z| {
                    (z.norm() / (2.0 * std::f64::consts::PI), -z.re / z.norm())
                });
                BodeRow {
                    me_open: resonance(p, ratios, g, Path::EngineTorqueOpen),
                    fdr_closed: resonance(p, ratios, g, Path::ResistanceClosed),
                    total_ratio: lin.total_ratio,
                    fdr_open,
                    mode_hz,
                    mode_damping,
                }
            })
            .collect();
        Self {
            vehicle_id: vehicle_id.into(),
            rows,
        }
    }

    /// Lowest gear from which on `F_dr → v` (open loop) has no peak, if any.
    pub fn open_loop_peak_gone_from(&self) -> Option<usize> {
        (0..self.rows.len())
            .find(|&k| self.rows[k..].iter().all(|r| r.fdr_open.peak_hz.is_none()))
            .map(|k| self.rows[k].fdr_open.gear)
    }

    /// Writes the table as Parquet (schema `bode`).
    ///
    /// # Errors
    /// [`OutputError`].
    pub fn write(&self, path: &FsPath, fingerprint: &str) -> Result<(), OutputError> {
        let col = |name: &str, unit: &str, f: &dyn Fn(&BodeRow) -> Option<f64>| {
            OutColumn::f64(
                name,
                unit,
                self.rows.iter().map(|r| f(r).unwrap_or(f64::NAN)).collect(),
            )
        };
        let cols = vec![
            OutColumn {
                name: "gear".into(),
                unit: "1".into(),
                data: OutData::I16(self.rows.iter().map(|r| r.fdr_open.gear as f64).collect()),
            },
            col("total_ratio", "1", &|r| Some(r.total_ratio)),
            col("v0", "m/s", &|r| Some(r.fdr_open.v0_mps)),
            col("v_top", "m/s", &|r| Some(r.fdr_open.v_top_mps)),
            col("fdr_open_peak_frequency", "Hz", &|r| r.fdr_open.peak_hz),
            col("fdr_open_peak_spatial_frequency", "1/m", &|r| {
                r.fdr_open.peak_per_m
            }),
            col("fdr_open_peak_height", "dB", &|r| {
                r.fdr_open.peak_over_rigid_db
            }),
            col("me_open_peak_frequency", "Hz", &|r| r.me_open.peak_hz),
            col("me_open_peak_height", "dB", &|r| {
                r.me_open.peak_over_rigid_db
            }),
            col("fdr_closed_peak_frequency", "Hz", &|r| r.fdr_closed.peak_hz),
            col("fdr_closed_peak_spatial_frequency", "1/m", &|r| {
                r.fdr_closed.peak_per_m
            }),
            col("fdr_closed_peak_height", "dB", &|r| {
                r.fdr_closed.peak_over_rigid_db
            }),
            col("shuffle_mode_frequency", "Hz", &|r| Some(r.mode_hz)),
            col("shuffle_mode_damping", "1", &|r| Some(r.mode_damping)),
        ];
        let meta = TableMeta {
            table: "bode".into(),
            drive_id: String::new(),
            vehicle_id: Some(self.vehicle_id.clone()),
            source_file: String::new(),
            config_hash: config_hash(&[fingerprint.as_bytes()]),
            extra: vec![(
                "operating_point".into(),
                "engine at 1200 rpm in each gear".into(),
            )],
        };
        write_table(path, &meta, &cols)
    }
}

impl fmt::Display for BodeTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let opt =
            |x: Option<f64>, prec: usize| x.map_or("-".to_string(), |v| format!("{v:.prec$}"));
        writeln!(
            f,
            "vehicle {}: resonances of the linear driveline (operating point: engine at 1200 rpm)",
            self.vehicle_id
        )?;
        writeln!(f, "gear  ratio   v0    v_top | F_dr->v open: f [Hz]  f_s [1/m]  peak [dB] | M_e->v open: f [Hz] peak [dB] | F_dr->v closed: f [Hz]  peak [dB] | mode [Hz] zeta")?;
        for r in &self.rows {
            writeln!(
                f,
                "{:>4} {:>6.2} {:>5.2} {:>6.2} | {:>19} {:>10} {:>10} | {:>18} {:>9} | {:>21} {:>10} | {:>9.2} {:.3}",
                r.fdr_open.gear,
                r.total_ratio,
                r.fdr_open.v0_mps,
                r.fdr_open.v_top_mps,
                opt(r.fdr_open.peak_hz, 3),
                opt(r.fdr_open.peak_per_m, 5),
                opt(r.fdr_open.peak_over_rigid_db, 1),
                opt(r.me_open.peak_hz, 3),
                opt(r.me_open.peak_over_rigid_db, 1),
                opt(r.fdr_closed.peak_hz, 3),
                opt(r.fdr_closed.peak_over_rigid_db, 1),
                r.mode_hz,
                r.mode_damping
            )?;
        }
        Ok(())
    }
}

/// Draws |F_dr → v| (dB) over frequency for every gear, open and closed loop, as SVG.
///
/// # Errors
/// A message when drawing or writing fails.
pub fn plot_svg(
    path: &FsPath,
    p: &DrivelineParams,
    ratios: &[f64],
    table: &BodeTable,
) -> Result<(), String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let panels = root.split_evenly((1, 2));
        let n = 300usize;
        let freqs: Vec<f64> = (0..n)
            .map(|k| 0.05 * (1000f64).powf(k as f64 / (n - 1) as f64))
            .collect();
        for (panel, closed) in panels.iter().zip([false, true]) {
            let curves: Vec<Vec<(f64, f64)>> = table
                .rows
                .iter()
                .map(|r| {
                    let lin = linearize(p, ratios, r.fdr_open.gear, r.fdr_open.v0_mps);
                    let ss = if closed { &lin.closed } else { &lin.open };
                    freqs
                        .iter()
                        .map(|&f| (f, 20.0 * ss.freq_response(1, f).norm().log10()))
                        .collect()
                })
                .collect();
            let (lo, hi) = curves
                .iter()
                .flatten()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(_, y)| {
                    (lo.min(y), hi.max(y))
                });
            let title = if closed {
                "F_dr -> v, closed loop (PI)"
            } else {
                "F_dr -> v, open loop"
            };
            let mut chart = ChartBuilder::on(panel)
                .caption(title, ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(55)
                .build_cartesian_2d((0.05f64..50.0f64).log_scale(), (lo - 5.0)..(hi + 5.0))
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc("frequency [Hz]")
                .y_desc("|v/F_dr| [dB re 1 m/s/N]")
                .draw()
                .map_err(|e| e.to_string())?;
            for (k, c) in curves.into_iter().enumerate() {
                let colour = Palette99::pick(k).to_rgba();
                chart
                    .draw_series(LineSeries::new(c, colour.stroke_width(2)))
                    .map_err(|e| e.to_string())?
                    .label(format!("gear {}", k + 1))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], colour));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    // written whole or not at all, like every fleetdyn output
    crate::io::AtomicFile::write_all(path, svg.as_bytes())
        .map_err(|e| format!("{}: {e}", path.display()))
}
