//! SVG plot of road-slope spectra (in the style of Myklebust & Eriksson (2012), fig. 9): log–log
//! PSD over spatial frequency with a shaded band (percentiles across roads, or the confidence band
//! of one road), PSD lines, the knees marked as vertical lines, the slope filter's cut-off f_co =
//! 4·10⁻³ 1/m and its −30 dB frequency f_lo = 2·10⁻² 1/m as black vertical lines (the paper's §5),
//! and the filter's magnitude response — zero-phase |H|² and causal |H|, in dB — on a second y axis
//! (right).
//!
//! To keep the SVG small the plot thins the bins to at most [`MAX_PLOT_POINTS`] log-spaced ones
//! (every bin at low frequency, fewer at high frequency); the Parquet tables hold every bin.
//! PSD values more than 10 decades below the largest are drawn at that floor.

use crate::road::study::FilterResponse;
use plotters::chart::DualCoordChartContext;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// Most bins drawn per series.
pub const MAX_PLOT_POINTS: usize = 600;

/// What to draw.
#[derive(Debug, Clone)]
pub struct PsdPlot<'a> {
    /// Title line.
    pub title: String,
    /// Bin frequencies, 1/m (bin 0 at 0 is not drawn on the log axis).
    pub freq_per_m: &'a [f64],
    /// Shaded band: lower, upper, legend label.
    pub band: (&'a [f64], &'a [f64], String),
    /// PSD lines: values, legend label, dashed.
    pub lines: Vec<(&'a [f64], String, bool)>,
    /// Knees: frequency (1/m), legend label.
    pub knees: Vec<(f64, String)>,
    /// Slope filter response on `freq_per_m`.
    pub filter: &'a FilterResponse,
}

/// Indices 1 … n−1, all of them while log-spaced targets are denser than the bins, thinned to
/// about `max_points` log-spaced ones above.
pub(crate) fn plot_indices(n: usize, max_points: usize) -> Vec<usize> {
    if n <= 1 {
        return Vec::new();
    }
    let last = (n - 1) as f64;
    let mut out: Vec<usize> = Vec::with_capacity(max_points + 1);
    for t in 0..=max_points {
        let i = (last.powf(t as f64 / max_points as f64)).round() as usize;
        let i = i.clamp(1, n - 1);
        if out.last() != Some(&i) {
            out.push(i);
        }
    }
    out
}

/// The chart both road plots draw on: log–log PSD axes (spatial frequency, `y_desc`) and the
/// slope filter's gain, −150 … 10 dB, on the right; the axes are drawn.
pub(crate) type PsdChart<'a, 'b> = DualCoordChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<LogCoord<f64>, LogCoord<f64>>,
    Cartesian2d<LogCoord<f64>, RangedCoordf64>,
>;

/// Builds a [`PsdChart`] on `root` over `x` (1/m) and `y`.
pub(crate) fn psd_chart<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    title: &str,
    title_size: u32,
    x: (f64, f64),
    y: (f64, f64),
    y_desc: &str,
) -> Result<PsdChart<'a, 'b>, String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", title_size))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .right_y_label_area_size(60)
        .build_cartesian_2d((x.0..x.1).log_scale(), (y.0..y.1).log_scale())
        .map_err(|x| e(&x))?
        .set_secondary_coord((x.0..x.1).log_scale(), -150.0f64..10.0f64);
    chart
        .configure_mesh()
        .x_desc("spatial frequency [1/m]")
        .y_desc(y_desc)
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|x| e(&x))?;
    chart
        .configure_secondary_axes()
        .y_desc("slope filter gain [dB]")
        .draw()
        .map_err(|x| e(&x))?;
    Ok(chart)
}

/// Draws the slope filter's cut-off f_co and its −30 dB frequency f_lo as black vertical lines
/// with their legend entries, where they fall inside `x`.
pub(crate) fn draw_filter_marks(
    chart: &mut PsdChart<'_, '_>,
    fc: &crate::road::slope_filter::SlopeFilterConfig,
    x: (f64, f64),
    y: (f64, f64),
) -> Result<(), String> {
    for (f, label) in [
        (
            fc.cutoff_per_m,
            format!("filter cut-off f_co = {:.0e} 1/m", fc.cutoff_per_m),
        ),
        (
            fc.stop_per_m,
            format!(
                "f_lo = {:.0e} 1/m (-{} dB required)",
                fc.stop_per_m, fc.required_attenuation_db
            ),
        ),
    ] {
        if f >= x.0 && f <= x.1 {
            chart
                .draw_series(LineSeries::new(
                    vec![(f, y.0), (f, y.1)],
                    BLACK.stroke_width(1),
                ))
                .map_err(|e| e.to_string())?
                .label(label)
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], BLACK));
        }
    }
    Ok(())
}

/// Renders the plot to an SVG string.
///
/// # Errors
/// A message when there is nothing positive to draw or the backend fails.
pub fn render_psd_svg(p: &PsdPlot<'_>) -> Result<String, String> {
    let n = p.freq_per_m.len();
    let idx = plot_indices(n, MAX_PLOT_POINTS);
    if idx.is_empty() {
        return Err("fewer than two frequency bins".into());
    }
    let (x0, x1) = (p.freq_per_m[idx[0]], p.freq_per_m[n - 1]);
    let y_hi = idx
        .iter()
        .map(|&i| p.band.1[i])
        .chain(
            p.lines
                .iter()
                .flat_map(|(v, _, _)| idx.iter().map(|&i| v[i])),
        )
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    if !(y_hi > 0.0 && x1 > x0) {
        return Err("no positive PSD value to draw".into());
    }
    let y_top = y_hi * 3.0;
    let y_floor = y_hi * 1e-10;
    let clamp = |v: f64| {
        if v.is_finite() {
            v.max(y_floor)
        } else {
            y_floor
        }
    };
    let pts = |v: &[f64]| -> Vec<(f64, f64)> {
        idx.iter()
            .map(|&i| (p.freq_per_m[i], clamp(v[i])))
            .collect()
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 600)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| e.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = psd_chart(
            &root,
            &p.title,
            17,
            (x0, x1),
            (y_floor, y_top),
            "slope PSD [(tan α)² / (1/m)]",
        )?;

        let band_colour = RGBColor(70, 130, 200);
        let mut poly = pts(p.band.1);
        poly.extend(pts(p.band.0).into_iter().rev());
        chart
            .draw_series(std::iter::once(Polygon::new(
                poly,
                band_colour.mix(0.25).filled(),
            )))
            .map_err(|x| e(&x))?
            .label(p.band.2.clone())
            .legend(move |(x, y)| {
                Rectangle::new(
                    [(x, y - 5), (x + 15, y + 5)],
                    band_colour.mix(0.25).filled(),
                )
            });
        for (k, (v, label, dashed)) in p.lines.iter().enumerate() {
            let colour = if k == 0 {
                RGBColor(20, 60, 150)
            } else {
                RGBColor(40, 40, 40)
            };
            let style = colour.stroke_width(2);
            let anno = if *dashed {
                chart
                    .draw_series(DashedLineSeries::new(pts(v), 6, 4, style))
                    .map_err(|x| e(&x))?
            } else {
                chart
                    .draw_series(LineSeries::new(pts(v), style))
                    .map_err(|x| e(&x))?
            };
            anno.label(label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], style));
        }
        let vline = |f: f64| vec![(f, y_floor), (f, y_top)];
        let knee_colours = [
            RGBColor(120, 60, 170),
            RGBColor(0, 140, 70),
            RGBColor(220, 120, 0),
        ];
        for (k, (f, label)) in p.knees.iter().enumerate() {
            if !(f.is_finite() && *f >= x0 && *f <= x1) {
                continue;
            }
            let style = knee_colours[k % knee_colours.len()].stroke_width(2);
            chart
                .draw_series(DashedLineSeries::new(vline(*f), 8, 4, style))
                .map_err(|x| e(&x))?
                .label(label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], style));
        }
        let fc = p.filter.config;
        draw_filter_marks(&mut chart, &fc, (x0, x1), (y_floor, y_top))?;
        let red = RGBColor(200, 30, 30);
        let gain = |v: &[f64]| -> Vec<(f64, f64)> {
            idx.iter()
                .map(|&i| (p.freq_per_m[i], v[i].max(-150.0)))
                .collect()
        };
        let zp_style = red.stroke_width(2);
        chart
            .draw_secondary_series(LineSeries::new(gain(&p.filter.zero_phase_db), zp_style))
            .map_err(|x| e(&x))?
            .label(format!(
                "zero-phase filter |H|^2 (order {}, right axis)",
                fc.order
            ))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], zp_style));
        let c_style = red.mix(0.7).stroke_width(1);
        chart
            .draw_secondary_series(DashedLineSeries::new(
                gain(&p.filter.causal_db),
                5,
                3,
                c_style,
            ))
            .map_err(|x| e(&x))?
            .label(format!(
                "causal filter |H| (order {}, right axis)",
                p.filter.causal_order
            ))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], c_style));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plot_indices_keep_low_bins_and_thin_high_ones() {
        let idx = plot_indices(8193, 600);
        assert_eq!(&idx[..5], &[1, 2, 3, 4, 5]);
        assert_eq!(*idx.last().unwrap(), 8192);
        assert!(idx.len() <= 601 && idx.windows(2).all(|w| w[0] < w[1]));
        assert!(plot_indices(1, 10).is_empty());
    }
}
