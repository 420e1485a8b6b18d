//! The effect catalogue ([`crate::model::catalogue::CATALOGUE`]) in words: the Markdown table
//! docs/diagnosis/catalogue.md carries between its generated markers.

use crate::model::catalogue::{Domain, DrawRange, ModelForm, Scale, Tolerance, CATALOGUE};

/// The catalogue as a Markdown table (one row per effect: id, domain, parameter and unit,
/// default tolerance, the model-form allowances (full fit without and with the tyres' warm-up
/// stated, linearised estimate), draw range, fit step and domain,
/// fingerprint), as docs/diagnosis/catalogue.md carries it; a test keeps the two equal.
pub fn catalogue_markdown() -> String {
    fn g(x: f64) -> String {
        let s = format!("{x}");
        s.replace('-', "−")
    }
    fn pct(x: f64) -> String {
        g((x * 1000.0).round() / 10.0)
    }
    // an allowance carries two significant figures, down to hundredths of a per cent
    fn allowance_pct(x: f64) -> String {
        g((x * 1e4).round() / 100.0)
    }
    let mut out = String::from(
        "| id | domain | parameter (unit) | default tolerance | model-form allowance (full fit) | (full fit, warm-up stated) | (linearised estimate) | proof draw | fit step | fit domain | fingerprint |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in CATALOGUE.iter() {
        let u = if r.unit == "1" { "" } else { r.unit };
        let tol = match r.tolerance.default_tolerance() {
            Tolerance::Relative(x) => format!("±{} %", pct(x)),
            Tolerance::Absolute(x) => format!("±{} {u}", g(x)),
            Tolerance::None => "— (a switch)".to_string(),
        };
        let side = |t: Tolerance, sign: &str| match t {
            Tolerance::Relative(x) => format!("{sign}{} %", allowance_pct(x)),
            Tolerance::Absolute(x) => format!("{sign}{} {u}", g(x)),
            Tolerance::None => "none".to_string(),
        };
        let sides = |m: ModelForm| match (m.below, m.above) {
            (Tolerance::None, Tolerance::None) => "—".to_string(),
            (b, a) => format!("{} / {}", side(b, "−"), side(a, "+")),
        };
        let (allowance, warm_up, linearised) = (
            sides(r.model_form),
            sides(r.model_form_warm_up),
            sides(r.linearised_form),
        );
        let draw = match r.draw {
            DrawRange::Relative { lo, hi, down_only } => format!(
                "{}{}–{} % of θ₀",
                if down_only { "−" } else { "±" },
                pct(lo),
                pct(hi)
            ),
            DrawRange::Absolute { lo, hi, signed } => {
                format!("{}{}–{} {}", if signed { "±" } else { "" }, g(lo), g(hi), u)
            }
            DrawRange::Additive { lo, hi } => format!("θ₀ ± {}–{} {u}", g(lo), g(hi)),
            DrawRange::Set { lo, hi } => format!("{}–{} {u}", g(lo), g(hi)),
        };
        let f = r.fit;
        let (step, dom) = if f.switch {
            ("switch".to_string(), "—".to_string())
        } else {
            match f.scale {
                Scale::Relative => (
                    format!(
                        "{}{} % of θ₀",
                        if f.step >= 0.0 { "+" } else { "" },
                        pct(f.step)
                    ),
                    format!("{}–{} θ₀", g(f.lo), g(f.hi)),
                ),
                Scale::Absolute => (
                    format!(
                        "{}{} {}",
                        if f.step >= 0.0 { "+" } else { "" },
                        g(f.step),
                        u
                    ),
                    format!("{} to {} {u}", g(f.lo), g(f.hi)),
                ),
            }
        };
        let domain = match r.domain {
            Domain::Longitudinal => "longitudinal",
            Domain::Axle => "axle",
        };
        let cells = [tol, allowance, warm_up, linearised, draw, step, dom]
            .map(|c| c.trim_end().to_string());
        out.push_str(&format!(
            "| `{}` | {domain} | `{}` ({}) | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.id,
            r.parameter,
            r.unit,
            cells[0],
            cells[1],
            cells[2],
            cells[3],
            cells[4],
            cells[5],
            cells[6],
            r.fingerprint
        ));
    }
    out
}
