//! Reference pages generated from the schema files: the Markdown tables the book under `docs/`
//! carries for the vehicle file (`schemas/vehicle.toml`), the canonical drive log
//! (`schemas/drive-log.toml`), every output table (`schemas/outputs/*.toml`) and the bundled
//! mapping files (`schemas/mappings/*.toml`).
//!
//! Every function here is pure: it takes the text of a schema file and returns Markdown, so the
//! same tables can be rendered from the embedded files, from the files on disk or from a file a
//! user edits. The files are read with the `toml` crate into structures of this module that
//! reject unknown keys, so a schema that gains a field fails here until its page shows it.
//!
//! A page embeds a generated table between two HTML comments,
//!
//! ```text
//! <!-- generated:NAME:begin -->
//! …the table…
//! <!-- generated:NAME:end -->
//! ```
//!
//! ([`begin_marker`], [`end_marker`]); [`section`] reads the text between them and [`splice`]
//! replaces it. The integration test `tests/it/docs_schema_reference.rs` asserts that every
//! page holds exactly what these functions render from the files in `schemas/`, and rewrites the
//! pages when run with `FLEETDYN_WRITE_DOCS=1`.
//!
//! Conventions of the rendered text: units are written as the schema writes them (SI, ASCII:
//! `N*m`, `kg*m^2`, `1` for a dimensionless quantity); numbers as Rust's shortest round-trip
//! decimal, in exponent form below 10⁻³ and from 10⁶ on; table cells escape the Markdown
//! characters that would end a cell or start emphasis or HTML.

use super::SchemaError;
use serde::Deserialize;
use std::collections::BTreeMap;

/// The comment that opens generated section `name` on a page.
pub fn begin_marker(name: &str) -> String {
    format!("<!-- generated:{name}:begin -->")
}

/// The comment that closes generated section `name` on a page.
pub fn end_marker(name: &str) -> String {
    format!("<!-- generated:{name}:end -->")
}

/// The text between the markers of section `name` on `page`, without the newline that ends the
/// begin marker's line; `None` when a marker is missing, repeated or out of order.
pub fn section<'a>(page: &'a str, name: &str) -> Option<&'a str> {
    let (a, b) = bounds(page, name)?;
    Some(&page[a..b])
}

/// `page` with the text of section `name` replaced by `body` (the markers stay); `None` when a
/// marker is missing, repeated or out of order.
pub fn splice(page: &str, name: &str, body: &str) -> Option<String> {
    let (a, b) = bounds(page, name)?;
    Some(format!("{}{}{}", &page[..a], body, &page[b..]))
}

/// Byte range of a section's body: after the begin marker's line, up to the end marker.
fn bounds(page: &str, name: &str) -> Option<(usize, usize)> {
    let begin = begin_marker(name);
    let end = end_marker(name);
    if page.matches(&begin).count() != 1 || page.matches(&end).count() != 1 {
        return None;
    }
    let mut a = page.find(&begin)? + begin.len();
    if page[a..].starts_with('\n') {
        a += 1;
    }
    let b = page.find(&end)?;
    (a <= b).then_some((a, b))
}

/// Text for a Markdown table cell: escapes what would end the cell (`|`), start emphasis
/// (`*`), a link (`[`, `]`), a code span (`` ` ``) or HTML (`<`, `>`), and folds line breaks.
fn cell(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\\' | '|' | '*' | '[' | ']' | '`' | '<' | '>' => {
                out.push('\\');
                out.push(c);
            }
            '\n' | '\r' => out.push(' '),
            _ => out.push(c),
        }
    }
    out
}

/// A schema meaning for a table cell, escaped.
fn meaning(text: &str) -> String {
    cell(text)
}

/// A code span for a table cell (`|` escaped, as GitHub and mdBook tables need it).
fn code(text: &str) -> String {
    format!("`{}`", text.replace('|', "\\|"))
}

/// A number as the schema means it: shortest round-trip decimal, exponent form below 10⁻³ and
/// from 10⁶ on (`1e8`, `2.5e-5`), a minus sign for negatives.
fn number(x: f64) -> String {
    let a = x.abs();
    let s = if a != 0.0 && !(1e-3..1e6).contains(&a) {
        format!("{x:e}")
    } else {
        format!("{x}")
    };
    s.replace('-', "−")
}

fn parse<T: for<'de> Deserialize<'de>>(text: &str, name: &str) -> Result<T, SchemaError> {
    toml::from_str(text).map_err(|e| SchemaError::Parse {
        name: name.into(),
        source: e,
    })
}

fn invalid(name: &str, message: String) -> SchemaError {
    SchemaError::Invalid {
        name: name.into(),
        message,
    }
}

// ---------------------------------------------------------------------------------------------
// Vehicle file

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VehicleSchemaDoc {
    #[allow(dead_code)]
    schema_version: String,
    driveline: Vec<VehicleKeyDoc>,
    axles: Vec<VehicleKeyDoc>,
    #[serde(default)]
    sensors: Vec<VehicleKeyDoc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VehicleKeyDoc {
    key: String,
    unit: String,
    min: f64,
    max: f64,
    shape: String,
    #[serde(default)]
    pair: Option<String>,
    #[serde(default)]
    default: Option<f64>,
    meaning: String,
}

/// The sections of a vehicle file that `schemas/vehicle.toml` describes key by key.
pub const VEHICLE_SECTIONS: [&str; 3] = ["driveline", "axles", "sensors"];

/// The keys of one section of a vehicle file (`"driveline"`, `"axles"` or `"sensors"`, see
/// [`VEHICLE_SECTIONS`]) as a Markdown table: key, SI unit, accepted range `[min, max]`, shape
/// (one number, one per forward gear, or a curve paired with another key) and meaning.
///
/// `vehicle_toml` is the text of `schemas/vehicle.toml`.
///
/// # Errors
/// [`SchemaError::Parse`] when the text is not the vehicle schema (unknown keys included);
/// [`SchemaError::Invalid`] for an unknown section or shape.
pub fn vehicle_section_markdown(vehicle_toml: &str, section: &str) -> Result<String, SchemaError> {
    const NAME: &str = "vehicle.toml";
    let doc: VehicleSchemaDoc = parse(vehicle_toml, NAME)?;
    let keys = match section {
        "driveline" => &doc.driveline,
        "axles" => &doc.axles,
        "sensors" => &doc.sensors,
        other => return Err(invalid(NAME, format!("no section [{other}]"))),
    };
    let mut out = String::from("| key | unit | range | shape | meaning |\n|---|---|---|---|---|\n");
    for k in keys {
        let shape = match (k.shape.as_str(), &k.pair) {
            ("scalar", None) => "one number".to_string(),
            ("per_gear", None) => "one number per forward gear".to_string(),
            ("curve", Some(p)) => format!("curve, as many points as {}", code(p)),
            (s, p) => {
                return Err(invalid(
                    NAME,
                    format!(
                        "key {}: shape `{s}` with pair `{}`",
                        k.key,
                        p.as_deref().unwrap_or("(none)")
                    ),
                ))
            }
        };
        let shape = match k.default {
            Some(d) => format!("{shape}; optional, absent: {}", number(d)),
            None => shape,
        };
        out.push_str(&format!(
            "| {} | {} | {} … {} | {} | {} |\n",
            code(&k.key),
            code(&k.unit),
            number(k.min),
            number(k.max),
            shape,
            meaning(&k.meaning)
        ));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Canonical drive log

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DriveLogDoc {
    #[allow(dead_code)]
    schema_version: String,
    #[allow(dead_code)]
    stages: Vec<String>,
    columns: Vec<DriveLogColumnDoc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DriveLogColumnDoc {
    name: String,
    dtype: String,
    unit: String,
    quantity: String,
    needed_by: Vec<String>,
    interpolation: String,
    #[serde(default)]
    valid_min: Option<f64>,
    #[serde(default)]
    valid_max: Option<f64>,
    meaning: String,
}

/// A logical column type as the pages write it (`timestamp[ns, UTC]`, `f64`, `i16`, `string`,
/// `u64`, `bool`).
fn dtype(name: &str, dtype: &str) -> Result<&'static str, SchemaError> {
    Ok(match dtype {
        "timestamp_ns_utc" => "timestamp[ns, UTC]",
        "f64" => "f64",
        "i16" => "i16",
        "str" => "string",
        "u64" => "u64",
        "bool" => "bool",
        other => return Err(invalid(name, format!("unknown dtype `{other}`"))),
    })
}

/// The canonical drive log's columns as a Markdown table: name, type, SI unit, the stages that
/// need the column (`all` = every stage, `—` = none: optional), how it is carried between
/// samples (linear, hold, or the time axis), the accepted range and the meaning.
///
/// `drive_log_toml` is the text of `schemas/drive-log.toml`.
///
/// # Errors
/// [`SchemaError::Parse`] when the text is not the drive-log schema (unknown keys included);
/// [`SchemaError::Invalid`] for an unknown type or interpolation.
pub fn drive_log_markdown(drive_log_toml: &str) -> Result<String, SchemaError> {
    const NAME: &str = "drive-log.toml";
    let doc: DriveLogDoc = parse(drive_log_toml, NAME)?;
    let mut out = String::from(
        "| column | type | unit | quantity | needed by | between samples | accepted range | meaning |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for c in &doc.columns {
        let needed = if c.needed_by.is_empty() {
            "—".to_string()
        } else {
            c.needed_by.join(", ")
        };
        let interpolation = match c.interpolation.as_str() {
            "linear" => "linear",
            "hold" => "hold",
            "none" => "time axis",
            other => {
                return Err(invalid(
                    NAME,
                    format!("column {}: interpolation `{other}`", c.name),
                ))
            }
        };
        let range = match (c.valid_min, c.valid_max) {
            (Some(a), Some(b)) => format!("{} … {}", number(a), number(b)),
            (Some(a), None) => format!("≥ {}", number(a)),
            (None, Some(b)) => format!("≤ {}", number(b)),
            (None, None) => "—".to_string(),
        };
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            code(&c.name),
            dtype(NAME, &c.dtype)?,
            code(&c.unit),
            cell(&c.quantity),
            needed,
            interpolation,
            range,
            meaning(&c.meaning)
        ));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Output tables

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputDoc {
    name: String,
    passthrough_drive_log: bool,
    columns: Vec<OutputColumnDoc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputColumnDoc {
    name: String,
    dtype: String,
    unit: String,
    meaning: String,
    #[serde(default)]
    optional: bool,
}

/// The name an output schema file declares (`name = "…"`), which is also the name of its
/// generated section on the outputs page (`output-NAME`).
///
/// # Errors
/// [`SchemaError::Parse`] when the text is not an output schema.
pub fn output_name(output_toml: &str) -> Result<String, SchemaError> {
    Ok(parse::<OutputDoc>(output_toml, "output schema")?.name)
}

/// One output table's columns as Markdown: a table of column, type, unit and meaning (an
/// optional column says so), followed, when the schema passes drive-log columns through, by a
/// sentence saying that the input's canonical columns follow the fixed ones.
///
/// `output_toml` is the text of one `schemas/outputs/*.toml` file. A unit of `from_run` (it
/// depends on the compared signal) is written as "the row's signal unit".
///
/// # Errors
/// [`SchemaError::Parse`] when the text is not an output schema (unknown keys included);
/// [`SchemaError::Invalid`] for an unknown type.
pub fn output_markdown(output_toml: &str) -> Result<String, SchemaError> {
    let doc: OutputDoc = parse(output_toml, "output schema")?;
    let name = format!("{}.toml", doc.name);
    let mut out = String::from("| column | type | unit | meaning |\n|---|---|---|---|\n");
    for c in &doc.columns {
        let unit = if c.unit == "from_run" {
            "the row's signal unit".to_string()
        } else if c.unit.contains(' ') {
            cell(&c.unit)
        } else {
            code(&c.unit)
        };
        let optional = if c.optional { " (optional)" } else { "" };
        out.push_str(&format!(
            "| {}{} | {} | {} | {} |\n",
            code(&c.name),
            optional,
            dtype(&name, &c.dtype)?,
            unit,
            meaning(&c.meaning)
        ));
    }
    if doc.passthrough_drive_log {
        out.push_str(
            "\nAfter these, every canonical drive-log column the input has, with its canonical \
             name, type and unit; non-canonical columns kept from the source follow as `f64` \
             with their own unit.\n",
        );
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// Mapping files

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MappingDoc {
    name: String,
    #[serde(default)]
    description: String,
    format: String,
    #[serde(default)]
    detect_columns: Vec<String>,
    #[serde(default)]
    vehicle_id: Option<String>,
    #[serde(default)]
    time: Option<MappingTimeDoc>,
    #[serde(default)]
    long: Option<MappingLongDoc>,
    signals: BTreeMap<String, MappingSignalDoc>,
    #[serde(default)]
    passthrough_units: BTreeMap<String, String>,
    #[serde(default)]
    passthrough_signals: BTreeMap<String, MappingSignalDoc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MappingTimeDoc {
    #[serde(default)]
    column: Option<String>,
    #[serde(default)]
    unit: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MappingLongDoc {
    signal_column: String,
    value_column: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MappingSignalDoc {
    #[serde(default)]
    source: Option<String>,
    #[serde(default)]
    topic: Option<String>,
    #[serde(default)]
    field: Option<String>,
    unit: String,
    #[serde(default)]
    reference_torque_nm: Option<f64>,
    #[serde(default)]
    message: Option<String>,
    #[serde(default)]
    signal: Option<String>,
    #[serde(default)]
    reference_torque_from: Option<String>,
    #[serde(default)]
    valid_signal: Option<String>,
    #[serde(default)]
    source_address: Option<u8>,
}

impl MappingSignalDoc {
    /// Where the value comes from, in the words of its format.
    fn source(&self, mapping: &str, column: &str) -> Result<String, SchemaError> {
        let mut s = match (
            &self.source,
            &self.topic,
            &self.field,
            &self.message,
            &self.signal,
        ) {
            (Some(src), None, None, None, None) => code(src),
            (None, Some(t), Some(f), None, None) => format!("{} field {}", code(t), code(f)),
            (None, None, None, Some(m), Some(g)) => code(&format!("{m}.{g}")),
            _ => {
                return Err(invalid(
                    mapping,
                    format!("signal {column}: needs source, topic + field, or message + signal"),
                ))
            }
        };
        if let Some(v) = &self.valid_signal {
            s.push_str(&format!(", valid when {} ≠ 0", code(v)));
        }
        if let Some(a) = self.source_address {
            s.push_str(&format!(", source address {a}"));
        }
        Ok(s)
    }

    /// The unit, with the reference torque a `%` torque is scaled by.
    fn unit(&self) -> String {
        let mut u = code(&self.unit);
        if let Some(r) = self.reference_torque_nm {
            u.push_str(&format!(" of {} N·m", number(r)));
        }
        if let Some(r) = &self.reference_torque_from {
            u.push_str(&format!(" of {}", code(r)));
        }
        u
    }
}

/// Every bundled mapping file as Markdown: an overview table (mapping, format, how it is
/// chosen, description), then one table per mapping of canonical column ← source and unit,
/// with its time column and kept (pass-through) columns.
///
/// `files` holds `(file name, text)` of each `schemas/mappings/*.toml`; they are rendered in the
/// order given.
///
/// # Errors
/// [`SchemaError::Parse`] when a text is not a mapping file (unknown keys included);
/// [`SchemaError::Invalid`] for a signal with no usable source or an unknown format.
pub fn mappings_markdown(files: &[(&str, &str)]) -> Result<String, SchemaError> {
    let docs = files
        .iter()
        .map(|(file, text)| Ok((*file, parse::<MappingDoc>(text, file)?)))
        .collect::<Result<Vec<_>, SchemaError>>()?;
    let mut out = String::from("| mapping | format | chosen | description |\n|---|---|---|---|\n");
    for (file, m) in &docs {
        let chosen = match (m.format.as_str(), m.detect_columns.is_empty()) {
            ("parquet-wide" | "parquet-long", false) => format!(
                "automatically, for Parquet with columns {}",
                m.detect_columns
                    .iter()
                    .map(|c| code(c))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            ("mcap-json", _) => "automatically, for MCAP with JSON topics".to_string(),
            ("can-dbc", _) => "with `--dbc` (raw CAN frames)".to_string(),
            ("parquet-wide" | "parquet-long", true) => "with `--mapping` only".to_string(),
            (other, _) => return Err(invalid(file, format!("unknown format `{other}`"))),
        };
        out.push_str(&format!(
            "| {} | {} | {} | {} |\n",
            code(&m.name),
            code(&m.format),
            chosen,
            cell(&m.description)
        ));
    }
    for (file, m) in &docs {
        out.push_str(&format!(
            "\n#### `{}`\n\n`schemas/mappings/{}`",
            m.name, file
        ));
        if let Some(t) = &m.time {
            match (&t.column, &t.unit) {
                (Some(c), Some(u)) => out.push_str(&format!(
                    "; time column {} in {} since the Unix epoch",
                    code(c),
                    code(u)
                )),
                (Some(c), None) => out.push_str(&format!("; time column {}", code(c))),
                (None, Some(u)) => out.push_str(&format!("; time unit {}", code(u))),
                (None, None) => {}
            }
        }
        if let Some(l) = &m.long {
            out.push_str(&format!(
                "; long layout: signal name in {}, value in {}",
                code(&l.signal_column),
                code(&l.value_column)
            ));
        }
        if let Some(v) = &m.vehicle_id {
            out.push_str(&format!(
                "; vehicle id {} when the source names none",
                code(v)
            ));
        }
        out.push_str(".\n\n| canonical column | from | unit |\n|---|---|---|\n");
        for (column, s) in &m.signals {
            out.push_str(&format!(
                "| {} | {} | {} |\n",
                code(column),
                s.source(file, column)?,
                s.unit()
            ));
        }
        for (column, s) in &m.passthrough_signals {
            out.push_str(&format!(
                "| {} (kept as is) | {} | {} |\n",
                code(column),
                s.source(file, column)?,
                s.unit()
            ));
        }
        for (column, unit) in &m.passthrough_units {
            out.push_str(&format!(
                "| {} (kept as is) | {} | {} |\n",
                code(column),
                code(column),
                code(unit)
            ));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_are_read_and_replaced_between_their_markers() {
        let page = "a\n<!-- generated:x:begin -->\nold\n<!-- generated:x:end -->\nb\n";
        assert_eq!(section(page, "x"), Some("old\n"));
        let new = splice(page, "x", "new\n").unwrap();
        assert_eq!(
            new,
            "a\n<!-- generated:x:begin -->\nnew\n<!-- generated:x:end -->\nb\n"
        );
        assert_eq!(section(page, "y"), None);
        let twice = format!("{page}{page}");
        assert_eq!(section(&twice, "x"), None);
    }

    #[test]
    fn cells_escape_markdown() {
        assert_eq!(cell("a|b *c* <d>"), "a\\|b \\*c\\* \\<d\\>");
        assert_eq!(code("x|y"), "`x\\|y`");
        assert_eq!(number(1e8), "1e8");
        assert_eq!(number(-0.3), "−0.3");
        assert_eq!(number(0.001), "0.001");
        assert_eq!(number(0.0), "0");
    }

    #[test]
    fn unknown_keys_are_errors() {
        let text = "name = \"t\"\npassthrough_drive_log = false\nnew_key = 1\n[[columns]]\n\
                    name = \"a\"\ndtype = \"f64\"\nunit = \"m\"\nmeaning = \"x\"\n";
        assert!(output_markdown(text).is_err());
    }
}
