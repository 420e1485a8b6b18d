//! The fleet report a person reads: one self-contained HTML page ([`fleet_html`]) with inline
//! SVG plots and no scripts or network resources. The vehicles whose evidence shows something
//! come first, each parameter outside its tolerance or with a change over time plotted drive by
//! drive (the 95 % interval of each drive, the tolerance band, the pooled estimate of each
//! segment and the change points), each drive linked to its diagnosis report; then a table of
//! every vehicle with its per-trip parameters' range and median.

use crate::fleet::evidence::{sig, ParameterEvidence, Status, VehicleEvidence};
use crate::fleet::trips::TripSummary;
use crate::time_fmt::utc_date;
use std::fmt::Write;

/// What the page says about the run.
#[derive(Debug, Clone, PartialEq)]
pub struct PageInfo<'a> {
    /// Pipeline name.
    pub pipeline: &'a str,
    /// Model version.
    pub model_version: &'a str,
}

/// HTML text escaped for element content and attribute values.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:2em;color:#222;max-width:1100px}\
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:2em;border-bottom:1px solid #ccc}\
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right;white-space:nowrap}\
td:first-child,th:first-child{text-align:left}.flag{color:#b00;font-weight:600}.note{color:#a60}.ok{color:#070}\
td.trip{text-align:left;white-space:normal}figure{margin:1em 0}figcaption{font-size:0.95em;margin-bottom:0.3em}svg{background:#fff;border:1px solid #ddd}";

/// Whether a parameter's evidence is worth a plot: outside its tolerance, or changed.
fn notable(p: &ParameterEvidence) -> bool {
    p.status == Status::Changed || p.status == Status::DiffersFromFile || !p.changes.is_empty()
}

/// The page (module documentation). `drive_link(vehicle_id, drive_id)` gives the link of a
/// drive's diagnosis report relative to the page.
pub fn fleet_html(
    info: &PageInfo<'_>,
    vehicles: &[VehicleEvidence],
    drive_link: &dyn Fn(&str, &str) -> String,
) -> String {
    let mut h = String::new();
    let drives: usize = vehicles.iter().map(|v| v.drives.len()).sum();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>Fleet evidence: {p} (model {m})</title><style>{STYLE}</style></head><body>\n\
         <h1>Fleet evidence: {p}, model version {m}</h1>\n<p>{nv} vehicles, {drives} diagnosed drives. \
         Each vehicle's drives are pooled parameter by parameter; a change over time needs a \
         p-value below 0.001 after the search over split points; a parameter is flagged when the \
         drives since a change put it outside the vehicle file's tolerance; one that differs from the \
         file on every drive is shown but not flagged (a truck's own model bias looks the same).</p>\n",
        p = esc(info.pipeline),
        m = esc(info.model_version),
        nv = vehicles.len(),
    );
    let flagged: Vec<&VehicleEvidence> = vehicles
        .iter()
        .filter(|v| v.parameters.iter().any(notable))
        .collect();
    let _ = writeln!(h, "<h2>Vehicles with findings ({})</h2>", flagged.len());
    if flagged.is_empty() {
        h.push_str("<p class=\"ok\">No vehicle has a parameter outside its tolerance or a change over time.</p>\n");
    }
    for v in &flagged {
        let _ = writeln!(
            h,
            "<h3 id=\"v-{id}\">{id}</h3>\n<p>{} drives, {} to {}.</p>",
            v.drives.len(),
            utc_date(v.drives[0].start_ns),
            utc_date(v.drives[v.drives.len() - 1].start_ns),
            id = esc(&v.vehicle_id),
        );
        for p in v.parameters.iter().filter(|p| notable(p)) {
            let class = match p.status {
                Status::Changed => "flag",
                Status::DiffersFromFile => "note",
                _ => "ok",
            };
            let _ = writeln!(
                h,
                "<figure><figcaption class=\"{class}\">{}</figcaption>{}</figure>",
                esc(&p.sentence()),
                trend_svg(v, p, drive_link)
            );
        }
    }
    h.push_str("<h2>Every vehicle</h2>\n<table><tr><th>vehicle</th><th>drives</th><th>first drive</th><th>last drive</th><th>explained</th><th>no significant mismatch</th><th>unexplained</th><th>flagged</th><th>changes</th><th>per trip</th></tr>\n");
    for v in vehicles {
        let verdicts = |name: &str| v.drives.iter().filter(|d| d.verdict == name).count();
        let out = v.flagged().count();
        let changes: usize = v.parameters.iter().map(|p| p.changes.len()).sum();
        let name = if v.parameters.iter().any(notable) {
            format!("<a href=\"#v-{0}\">{0}</a>", esc(&v.vehicle_id))
        } else {
            esc(&v.vehicle_id)
        };
        let per_trip = TripSummary::all(v)
            .iter()
            .map(|t| esc(&t.sentence()))
            .collect::<Vec<_>>()
            .join("<br>");
        let _ = writeln!(
            h,
            "<tr><td>{name}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td{}>{out}</td><td>{changes}</td><td class=\"trip\">{per_trip}</td></tr>",
            v.drives.len(),
            utc_date(v.drives[0].start_ns),
            utc_date(v.drives[v.drives.len() - 1].start_ns),
            verdicts("explained"),
            verdicts("no_significant_mismatch"),
            verdicts("unexplained"),
            if out > 0 { " class=\"flag\"" } else { "" },
        );
    }
    h.push_str("</table>\n</body></html>\n");
    h
}

/// Plot area of a trend: width, height and margins, px.
const W: f64 = 900.0;
const H: f64 = 260.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 15.0;
const TOP: f64 = 12.0;
const BOTTOM: f64 = 30.0;

/// One parameter's drives over time as an inline SVG.
fn trend_svg(
    v: &VehicleEvidence,
    p: &ParameterEvidence,
    drive_link: &dyn Fn(&str, &str) -> String,
) -> String {
    let pts = &p.points;
    let (t0, t1) = (pts[0].start_ns as f64, pts[pts.len() - 1].start_ns as f64);
    let span = (t1 - t0).max(1.0);
    let x = |t: i64| LEFT + (t as f64 - t0) / span * (W - LEFT - RIGHT);
    let mut lo = p.band.0.min(p.nominal);
    let mut hi = p.band.1.max(p.nominal);
    for q in pts {
        lo = lo.min(q.ci_low);
        hi = hi.max(q.ci_high);
    }
    let pad = 0.05 * (hi - lo).max(1e-12);
    let (lo, hi) = (lo - pad, hi + pad);
    let y = |val: f64| TOP + (hi - val) / (hi - lo) * (H - TOP - BOTTOM);
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" viewBox=\"0 0 {W} {H}\" role=\"img\" aria-label=\"{}\">",
        esc(&format!("{} of {}", p.effect.id(), v.vehicle_id))
    );
    // tolerance band and nominal
    let _ = write!(
        s,
        "<rect x=\"{LEFT}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#dfe\"><title>tolerance {} to {}</title></rect>\
         <line x1=\"{LEFT}\" x2=\"{:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"#070\" stroke-dasharray=\"4 3\"/>",
        y(p.band.1),
        W - LEFT - RIGHT,
        (y(p.band.0) - y(p.band.1)).max(0.5),
        sig(p.band.0),
        sig(p.band.1),
        W - RIGHT,
        y(p.nominal),
        y(p.nominal),
    );
    // axes and labels
    let _ = write!(
        s,
        "<line x1=\"{LEFT}\" x2=\"{LEFT}\" y1=\"{TOP}\" y2=\"{:.1}\" stroke=\"#444\"/>\
         <line x1=\"{LEFT}\" x2=\"{:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"#444\"/>",
        H - BOTTOM,
        W - RIGHT,
        H - BOTTOM,
        H - BOTTOM,
    );
    for k in 0..=4 {
        let val = lo + (hi - lo) * k as f64 / 4.0;
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\" text-anchor=\"end\">{}</text>",
            LEFT - 4.0,
            y(val) + 4.0,
            esc(&sig(val))
        );
    }
    let unit = if p.unit == "1" { "" } else { p.unit.as_str() };
    let _ = write!(
        s,
        "<text x=\"4\" y=\"{:.1}\" font-size=\"11\">{}</text>\
         <text x=\"{LEFT}\" y=\"{:.1}\" font-size=\"11\">{}</text>\
         <text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\" text-anchor=\"end\">{}</text>",
        TOP + 10.0,
        esc(unit),
        H - 8.0,
        utc_date(pts[0].start_ns),
        W - RIGHT,
        H - 8.0,
        utc_date(pts[pts.len() - 1].start_ns),
    );
    // segments' pooled estimates with their intervals
    for seg in &p.segments {
        let (xa, xb) = (x(pts[seg.start].start_ns), x(pts[seg.end - 1].start_ns));
        let q = &seg.pooled;
        let _ = write!(
            s,
            "<rect x=\"{xa:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#36c\" fill-opacity=\"0.15\"/>\
             <line x1=\"{xa:.1}\" x2=\"{xb:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"#36c\" stroke-width=\"2\"><title>{} ({} to {}) over {} drives</title></line>",
            y(q.ci_high),
            (xb - xa).max(1.0),
            (y(q.ci_low) - y(q.ci_high)).max(0.5),
            y(q.value),
            y(q.value),
            sig(q.value),
            sig(q.ci_low),
            sig(q.ci_high),
            q.n,
        );
    }
    // change points
    for c in &p.changes {
        let xc = x(pts[c.at].start_ns);
        let _ = write!(
            s,
            "<line x1=\"{xc:.1}\" x2=\"{xc:.1}\" y1=\"{TOP}\" y2=\"{:.1}\" stroke=\"#b00\" stroke-dasharray=\"6 3\"><title>change before {} (p = {:.1e})</title></line>",
            H - BOTTOM,
            utc_date(pts[c.at].start_ns),
            c.p_value,
        );
    }
    // the drives, each linked to its report
    for q in pts {
        let xq = x(q.start_ns);
        let _ = write!(
            s,
            "<a href=\"{}\"><line x1=\"{xq:.1}\" x2=\"{xq:.1}\" y1=\"{:.1}\" y2=\"{:.1}\" stroke=\"#555\"/>\
             <circle cx=\"{xq:.1}\" cy=\"{:.1}\" r=\"3\" fill=\"#222\"><title>{} {}: {} ({} to {}), {}</title></circle></a>",
            esc(&drive_link(&v.vehicle_id, &q.drive_id)),
            y(q.ci_low),
            y(q.ci_high),
            y(q.value),
            esc(&q.drive_id),
            utc_date(q.start_ns),
            sig(q.value),
            sig(q.ci_low),
            sig(q.ci_high),
            esc(&q.method),
        );
    }
    s.push_str("</svg>");
    s
}
