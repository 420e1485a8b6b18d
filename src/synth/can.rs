//! CAN sensors as a J1939 logger delivers them, from SI truth signals.
//!
//! A [`CanBus`] is a list of [`CanMessage`]s (one MCAP topic each, e.g. EEC1 on `/can/eec1`),
//! each carrying one or more [`CanChannel`]s (one JSON field each, e.g. `EngineSpeed`).
//!
//! Conventions:
//! - **Time.** Truth times are seconds from the start of the drive; `start_ns` (ns since the
//!   Unix epoch) is that start. Message `k` of a topic is scheduled at
//!   `t_k = phase_s + k / rate_hz` (s) for every `t_k` within the truth's time span, and its
//!   `log_time` is `start_ns + round(t_k · 10⁹)` ns, so intervals are `1/rate_hz` to within 1 ns.
//!   Rate, phase and dropouts belong to the message (one CAN frame carries all its fields).
//! - **Truth.** SI values per canonical column (`schemas/drive-log.toml`), linearly interpolated
//!   between samples, except integer columns (gear), which are held (zero-order hold). Before the
//!   first truth sample the first value is used (only reachable with a delay).
//! - **Wire value** of a channel at `t_k`: the truth at `t_k − delay_s` converted SI → wire unit
//!   (the exact inverse of the conversion ingest applies, [`crate::units::conversion`]), plus
//!   `noise_sigma · N(0, 1)` (wire units), saturated to `[wire_min, wire_max]`, then rounded to
//!   the nearest multiple of `resolution` inside that range. Multiples are written exactly where
//!   `1/resolution` is an integer (`q / 10` for 0.1 kPa, so `101.3`, not `101.30000000000001`);
//!   whole numbers are written as JSON integers.
//! - **Torque in %** is percent of a reference torque ([`TorqueReference`]): the engine's
//!   (J1939 EC1) for `engine_torque`, the retarder's for `retarder_torque`.
//! - **Dropouts.** At each scheduled message outside a gap, a gap starts with probability
//!   `start_probability`; its length is exponential with mean `mean_length_s` (s) and it covers
//!   `[t_k, t_k + length)`. Messages in a gap (including the one that started it) are not sent.
//! - **Randomness.** One [`Xoshiro256StarStar`] stream per channel (noise) and per message
//!   (dropouts), seeded with `splitmix64(seed) ^ fnv1a64(name)` (the canonical column for a
//!   channel, the topic for a message), so adding a channel changes no other channel's values.
//!   Noise is drawn for every scheduled message, sent or not, so dropouts do not shift the noise.
//! - **Channels the truth does not carry are not sent**; a message none of whose channels the
//!   truth carries is not sent at all. A truth column no channel carries is an error (a typo
//!   must not vanish silently).

use crate::ingest::{ingest_file, IngestError, IngestOptions, Mapping};
use crate::io::{config_hash, drive_log_columns, write_table, AtomicFile, OutputError, TableMeta};
use crate::rng::{splitmix64, Xoshiro256StarStar};
use crate::schema::{drive_log, Dtype};
use crate::table::DriveLog;
use crate::units::{conversion, Conversion, UnitError};
use serde_json::{Map, Number, Value};
use std::collections::BTreeMap;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a synthetic CAN log could not be made.
#[derive(Debug, Error)]
pub enum SynthError {
    /// A message rate that is not finite and positive.
    #[error("topic {topic}: rate {rate_hz} Hz must be finite and > 0")]
    BadRate {
        /// MCAP topic.
        topic: String,
        /// The rate given, Hz.
        rate_hz: f64,
    },
    /// A resolution that is not finite and positive.
    #[error("channel {column}: resolution {resolution} (wire units) must be finite and > 0")]
    BadResolution {
        /// Canonical column.
        column: String,
        /// The resolution given, wire units.
        resolution: f64,
    },
    /// Another channel parameter out of its domain.
    #[error("channel {column}: {parameter} = {value} must be {requirement}")]
    BadChannel {
        /// Canonical column.
        column: String,
        /// Parameter name (with its unit).
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// A message parameter out of its domain.
    #[error("topic {topic}: {parameter} = {value} must be {requirement}")]
    BadMessage {
        /// MCAP topic.
        topic: String,
        /// Parameter name (with its unit).
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// A reference torque that is not finite and positive.
    #[error("{which} reference torque {value_nm} N·m must be finite and > 0")]
    BadReferenceTorque {
        /// `engine` or `retarder`.
        which: &'static str,
        /// The value given, N·m.
        value_nm: f64,
    },
    /// The same topic, field or column twice, or a column that is not canonical.
    #[error("{what} {name:?}")]
    BadName {
        /// What is wrong (`duplicate topic`, `unknown canonical column`, …).
        what: &'static str,
        /// The name.
        name: String,
    },
    /// A wire unit that cannot be converted into the column's SI unit.
    #[error("channel {column}: {source}")]
    Unit {
        /// Canonical column.
        column: String,
        /// Cause.
        #[source]
        source: UnitError,
    },
    /// Truth times that are too few, not finite or not strictly increasing.
    #[error("truth time sample {index} = {t_s} s: {problem}")]
    BadTruthTime {
        /// Sample index.
        index: usize,
        /// The time, s from the start.
        t_s: f64,
        /// What is wrong.
        problem: &'static str,
    },
    /// A NaN or infinite truth value.
    #[error("truth column {column}, sample {index} at {t_s} s: value {value} is not finite")]
    NonFiniteTruth {
        /// Canonical column.
        column: String,
        /// Sample index.
        index: usize,
        /// Its time, s from the start.
        t_s: f64,
        /// The value.
        value: f64,
    },
    /// A truth column whose length differs from the time axis.
    #[error("truth column {column} has {len} samples, the time axis {expected}")]
    RaggedTruth {
        /// Canonical column.
        column: String,
        /// Its length.
        len: usize,
        /// Length of the time axis.
        expected: usize,
    },
    /// A truth column no channel of the bus carries.
    #[error("truth column {column} is not carried by any channel of the bus")]
    UnknownTruthColumn {
        /// The column.
        column: String,
    },
    /// File-system error writing the MCAP.
    #[error("writing {path}: {source}")]
    Io {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// MCAP encoder error.
    #[error("writing {path}: {source}")]
    Mcap {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: Box<mcap::McapError>,
    },
    /// A chunk compression level the encoder does not have.
    #[error("MCAP {compression} compression level {level} must be 0 (default) … {max}")]
    BadCompressionLevel {
        /// `zstd` or `lz4`.
        compression: &'static str,
        /// The level given.
        level: u32,
        /// The highest level.
        max: u32,
    },
    /// The bus's mapping did not parse, or the written MCAP did not ingest.
    #[error(transparent)]
    Ingest(Box<IngestError>),
    /// The canonical Parquet could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
}

impl From<IngestError> for SynthError {
    fn from(e: IngestError) -> Self {
        SynthError::Ingest(Box::new(e))
    }
}

/// Which reference torque a `%` torque channel is a percentage of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TorqueReference {
    /// Not a percent torque.
    None,
    /// [`CanBus::reference_torque_nm`] (J1939 EC1 engine reference torque, SPN 544).
    Engine,
    /// [`CanBus::retarder_reference_torque_nm`] (J1939 retarder reference torque, SPN 556).
    Retarder,
}

/// One signal field of a CAN message.
#[derive(Debug, Clone, PartialEq)]
pub struct CanChannel {
    /// Canonical column (`schemas/drive-log.toml`).
    pub column: String,
    /// JSON field in the topic's messages.
    pub field: String,
    /// Wire unit, as a mapping file names it (`km/h`, `rpm`, `%`, `kPa`, …).
    pub wire_unit: String,
    /// Reference torque of a `%` torque channel.
    pub torque_reference: TorqueReference,
    /// Resolution, wire units: sent values are multiples of it.
    pub resolution: f64,
    /// Gaussian noise standard deviation, wire units, added before quantisation.
    pub noise_sigma: f64,
    /// Delay, s: the message at `t` carries the truth at `t − delay_s`.
    pub delay_s: f64,
    /// Lowest wire value (saturation), wire units.
    pub wire_min: f64,
    /// Highest wire value (saturation), wire units.
    pub wire_max: f64,
}

/// Dropout process of a message (see the module conventions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dropouts {
    /// Probability, per scheduled message outside a gap, that a gap starts there.
    pub start_probability: f64,
    /// Mean gap length, s (exponentially distributed).
    pub mean_length_s: f64,
}

impl Dropouts {
    /// No dropouts.
    pub const NONE: Dropouts = Dropouts {
        start_probability: 0.0,
        mean_length_s: 0.0,
    };
}

/// One CAN message group: an MCAP topic at its own rate, carrying one or more fields.
#[derive(Debug, Clone, PartialEq)]
pub struct CanMessage {
    /// Message name (J1939 PG acronym, e.g. `EEC1`), used as the MCAP schema name.
    pub name: String,
    /// MCAP topic.
    pub topic: String,
    /// Rate, Hz.
    pub rate_hz: f64,
    /// Time of the first message after the start, s.
    pub phase_s: f64,
    /// Dropout process.
    pub dropouts: Dropouts,
    /// Fields.
    pub channels: Vec<CanChannel>,
}

/// A CAN bus: message groups and the reference torques of its `%` torque channels.
#[derive(Debug, Clone, PartialEq)]
pub struct CanBus {
    /// Message groups.
    pub messages: Vec<CanMessage>,
    /// Engine reference torque (J1939 EC1, SPN 544), N·m.
    pub reference_torque_nm: f64,
    /// Retarder reference torque (J1939 SPN 556), N·m.
    pub retarder_reference_torque_nm: f64,
}

/// Retarder reference torque of the default bus, N·m — the value the bundled
/// `j1939-json-mcap` mapping assumes for the fixture fleet.
pub const RETARDER_REFERENCE_TORQUE_NM: f64 = 3500.0;

#[allow(clippy::too_many_arguments)]
fn ch(
    column: &str,
    field: &str,
    wire_unit: &str,
    torque_reference: TorqueReference,
    resolution: f64,
    noise_sigma: f64,
    wire_min: f64,
    wire_max: f64,
) -> CanChannel {
    CanChannel {
        column: column.into(),
        field: field.into(),
        wire_unit: wire_unit.into(),
        torque_reference,
        resolution,
        noise_sigma,
        delay_s: 0.0,
        wire_min,
        wire_max,
    }
}

fn msg(
    name: &str,
    topic: &str,
    rate_hz: f64,
    phase_s: f64,
    channels: Vec<CanChannel>,
) -> CanMessage {
    CanMessage {
        name: name.into(),
        topic: topic.into(),
        rate_hz,
        phase_s,
        dropouts: Dropouts::NONE,
        channels,
    }
}

impl CanBus {
    /// The J1939 heavy-truck bus of the synthetic drives, with the names of the bundled
    /// `schemas/mappings/j1939-json-mcap.toml` mapping (which assumes
    /// `reference_torque_nm = 2600`):
    ///
    /// | message | topic.field | column | rate | resolution | range | noise σ |
    /// |---|---|---|---|---|---|---|
    /// | CCVS1 | `/can/ccvs1.WheelBasedVehicleSpeed` | vehicle_speed | 10 Hz | 1/256 km/h | 0…250.996 km/h | 0.05 km/h |
    /// | EEC1 | `/can/eec1.EngineSpeed` | engine_speed | 50 Hz | 0.125 rpm | 0…8031.875 rpm | 1 rpm |
    /// | EEC1 | `/can/eec1.ActualEnginePercentTorque` | engine_torque | 50 Hz | 1 % of reference | −125…125 % | 0.5 % |
    /// | ETC2 | `/can/etc2.TransmissionCurrentGear` | gear | 10 Hz | 1 | −125…125 | 0 |
    /// | SLOPE | `/can/slope.RoadSlope` | road_slope | 10 Hz | 1 % | −30…30 % | 0.2 % |
    /// | ASC4 | `/can/asc4.BellowPressure{Front,Rear,Tag}Axle` | bellow_pressure_* | 10 Hz | 0.1 kPa | 0…6425.5 kPa | 1 kPa |
    /// | ERC1 | `/can/erc1.ActualRetarderPercentTorque` | retarder_torque | 10 Hz | 1 % of 3500 N·m | 0…125 % | 0 |
    /// | BRAKE | `/can/brake.ServiceBrakeForce` | brake_force | 10 Hz | 0.1 kN | 0…2000 kN | 0.2 kN |
    /// | CLUTCH | `/can/clutch.ClutchActuatorPosition` | clutch_position | 10 Hz | 0.4 % | 0…100 % | 0 |
    ///
    /// Phases stagger the topics by 2 ms (CCVS1 0 ms, EEC1 2 ms, ETC2 4 ms, …, BRAKE 12 ms,
    /// CLUTCH 14 ms), as
    /// frames on one bus never share a time stamp. No delays, no dropouts.
    pub fn j1939_truck(reference_torque_nm: f64) -> Self {
        use TorqueReference as R;
        let bellow =
            |column: &str, field: &str| ch(column, field, "kPa", R::None, 0.1, 1.0, 0.0, 6425.5);
        CanBus {
            messages: vec![
                msg(
                    "CCVS1",
                    "/can/ccvs1",
                    10.0,
                    0.0,
                    vec![ch(
                        "vehicle_speed",
                        "WheelBasedVehicleSpeed",
                        "km/h",
                        R::None,
                        1.0 / 256.0,
                        0.05,
                        0.0,
                        64255.0 / 256.0,
                    )],
                ),
                msg(
                    "EEC1",
                    "/can/eec1",
                    50.0,
                    0.002,
                    vec![
                        ch(
                            "engine_speed",
                            "EngineSpeed",
                            "rpm",
                            R::None,
                            0.125,
                            1.0,
                            0.0,
                            8031.875,
                        ),
                        ch(
                            "engine_torque",
                            "ActualEnginePercentTorque",
                            "%",
                            R::Engine,
                            1.0,
                            0.5,
                            -125.0,
                            125.0,
                        ),
                    ],
                ),
                msg(
                    "ETC2",
                    "/can/etc2",
                    10.0,
                    0.004,
                    vec![ch(
                        "gear",
                        "TransmissionCurrentGear",
                        "1",
                        R::None,
                        1.0,
                        0.0,
                        -125.0,
                        125.0,
                    )],
                ),
                msg(
                    "SLOPE",
                    "/can/slope",
                    10.0,
                    0.006,
                    vec![ch(
                        "road_slope",
                        "RoadSlope",
                        "%",
                        R::None,
                        1.0,
                        0.2,
                        -30.0,
                        30.0,
                    )],
                ),
                msg(
                    "ASC4",
                    "/can/asc4",
                    10.0,
                    0.008,
                    vec![
                        bellow("bellow_pressure_front", "BellowPressureFrontAxle"),
                        bellow("bellow_pressure_rear", "BellowPressureRearAxle"),
                        bellow("bellow_pressure_tag", "BellowPressureTagAxle"),
                    ],
                ),
                msg(
                    "ERC1",
                    "/can/erc1",
                    10.0,
                    0.010,
                    vec![ch(
                        "retarder_torque",
                        "ActualRetarderPercentTorque",
                        "%",
                        R::Retarder,
                        1.0,
                        0.0,
                        0.0,
                        125.0,
                    )],
                ),
                msg(
                    "BRAKE",
                    "/can/brake",
                    10.0,
                    0.012,
                    vec![ch(
                        "brake_force",
                        "ServiceBrakeForce",
                        "kN",
                        R::None,
                        0.1,
                        0.2,
                        0.0,
                        2000.0,
                    )],
                ),
                msg(
                    "CLUTCH",
                    "/can/clutch",
                    10.0,
                    0.014,
                    vec![ch(
                        "clutch_position",
                        "ClutchActuatorPosition",
                        "%",
                        R::None,
                        0.4,
                        0.0,
                        0.0,
                        100.0,
                    )],
                ),
            ],
            reference_torque_nm,
            retarder_reference_torque_nm: RETARDER_REFERENCE_TORQUE_NM,
        }
    }

    /// The same bus with every noise σ set to zero.
    pub fn without_noise(mut self) -> Self {
        for c in self.messages.iter_mut().flat_map(|m| m.channels.iter_mut()) {
            c.noise_sigma = 0.0;
        }
        self
    }

    /// The same bus with `dropouts` on every message.
    pub fn with_dropouts(mut self, dropouts: Dropouts) -> Self {
        for m in &mut self.messages {
            m.dropouts = dropouts;
        }
        self
    }

    /// All channels with their message.
    pub fn channels(&self) -> impl Iterator<Item = (&CanMessage, &CanChannel)> {
        self.messages
            .iter()
            .flat_map(|m| m.channels.iter().map(move |c| (m, c)))
    }

    fn reference_nm(&self, r: TorqueReference) -> Option<f64> {
        match r {
            TorqueReference::None => None,
            TorqueReference::Engine => Some(self.reference_torque_nm),
            TorqueReference::Retarder => Some(self.retarder_reference_torque_nm),
        }
    }

    /// The wire → SI conversion ingest applies to a channel.
    ///
    /// # Errors
    /// [`SynthError::BadName`] for a non-canonical column, [`SynthError::Unit`] for a unit that
    /// does not convert into the column's quantity.
    pub fn conversion(&self, c: &CanChannel) -> Result<Conversion, SynthError> {
        let spec = drive_log()
            .column(&c.column)
            .filter(|s| s.name != "timestamp")
            .ok_or_else(|| SynthError::BadName {
                what: "unknown canonical column",
                name: c.column.clone(),
            })?;
        conversion(
            &c.wire_unit,
            &spec.quantity,
            self.reference_nm(c.torque_reference),
        )
        .map_err(|source| SynthError::Unit {
            column: c.column.clone(),
            source,
        })
    }

    /// Checks every parameter (see [`SynthError`] for what is rejected).
    ///
    /// # Errors
    /// The first bad parameter found, naming its topic or column and value.
    pub fn validate(&self) -> Result<(), SynthError> {
        for (which, v) in [
            ("engine", self.reference_torque_nm),
            ("retarder", self.retarder_reference_torque_nm),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SynthError::BadReferenceTorque { which, value_nm: v });
            }
        }
        let mut topics: Vec<&str> = Vec::new();
        let mut columns: Vec<&str> = Vec::new();
        for m in &self.messages {
            if topics.contains(&m.topic.as_str()) {
                return Err(SynthError::BadName {
                    what: "duplicate topic",
                    name: m.topic.clone(),
                });
            }
            topics.push(&m.topic);
            if !(m.rate_hz.is_finite() && m.rate_hz > 0.0) {
                return Err(SynthError::BadRate {
                    topic: m.topic.clone(),
                    rate_hz: m.rate_hz,
                });
            }
            let bad = |parameter, value, requirement| SynthError::BadMessage {
                topic: m.topic.clone(),
                parameter,
                value,
                requirement,
            };
            if !(m.phase_s.is_finite() && m.phase_s >= 0.0) {
                return Err(bad("phase_s", m.phase_s, "finite and >= 0"));
            }
            let p = m.dropouts.start_probability;
            if !(0.0..=1.0).contains(&p) {
                return Err(bad("dropouts.start_probability", p, "in [0, 1]"));
            }
            let l = m.dropouts.mean_length_s;
            if !(l.is_finite() && l >= 0.0) {
                return Err(bad("dropouts.mean_length_s", l, "finite and >= 0"));
            }
            let mut fields: Vec<&str> = Vec::new();
            for c in &m.channels {
                if fields.contains(&c.field.as_str()) {
                    return Err(SynthError::BadName {
                        what: "duplicate field",
                        name: format!("{}.{}", m.topic, c.field),
                    });
                }
                fields.push(&c.field);
                if columns.contains(&c.column.as_str()) {
                    return Err(SynthError::BadName {
                        what: "duplicate column",
                        name: c.column.clone(),
                    });
                }
                columns.push(&c.column);
                self.conversion(c)?;
                if !(c.resolution.is_finite() && c.resolution > 0.0) {
                    return Err(SynthError::BadResolution {
                        column: c.column.clone(),
                        resolution: c.resolution,
                    });
                }
                let bad = |parameter, value, requirement| SynthError::BadChannel {
                    column: c.column.clone(),
                    parameter,
                    value,
                    requirement,
                };
                if !(c.noise_sigma.is_finite() && c.noise_sigma >= 0.0) {
                    return Err(bad("noise_sigma", c.noise_sigma, "finite and >= 0"));
                }
                if !(c.delay_s.is_finite() && c.delay_s >= 0.0) {
                    return Err(bad("delay_s", c.delay_s, "finite and >= 0"));
                }
                if !c.wire_min.is_finite() {
                    return Err(bad("wire_min", c.wire_min, "finite"));
                }
                if !(c.wire_max.is_finite() && c.wire_max >= c.wire_min) {
                    return Err(bad("wire_max", c.wire_max, "finite and >= wire_min"));
                }
                let (lo, hi) = step_range(c);
                if lo > hi {
                    return Err(bad(
                        "wire_max",
                        c.wire_max,
                        "at least one resolution step above wire_min",
                    ));
                }
            }
        }
        Ok(())
    }

    /// A `mcap-json` mapping that ingests this bus: every channel's topic, field, wire unit and
    /// reference torque. For `j1939_truck(2600.0)` it maps exactly as the bundled
    /// `j1939-json-mcap` mapping does.
    ///
    /// # Errors
    /// [`SynthError::Ingest`] if the generated mapping does not parse (bad unit or column).
    pub fn mapping(&self) -> Result<Mapping, SynthError> {
        let mut text = String::from(
            "name = \"synth-can\"\ndescription = \"mapping of a fleetdyn synthetic CAN bus\"\nformat = \"mcap-json\"\n",
        );
        for (m, c) in self.channels() {
            text.push_str(&format!(
                "\n[signals.{}]\ntopic = {:?}\nfield = {:?}\nunit = {:?}\n",
                c.column, m.topic, c.field, c.wire_unit
            ));
            if let Some(r) = self.reference_nm(c.torque_reference) {
                text.push_str(&format!("reference_torque_nm = {r:?}\n"));
            }
        }
        Ok(Mapping::parse(&text, "<synth-can bus>")?)
    }
}

/// Lowest and highest step index `q` with `q · resolution` inside the wire range.
fn step_range(c: &CanChannel) -> (f64, f64) {
    (
        (c.wire_min / c.resolution - 1e-9).ceil(),
        (c.wire_max / c.resolution + 1e-9).floor(),
    )
}

/// `q · resolution`, exact where `1/resolution` is an integer.
pub(crate) fn step_value(q: f64, resolution: f64) -> f64 {
    let inv = 1.0 / resolution;
    let n = inv.round();
    if n >= 1.0 && (inv - n).abs() <= 1e-9 * n {
        q / n
    } else {
        q * resolution
    }
}

/// Truth signals: times in s from the start, SI values per canonical column.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Truth {
    /// Sample times, s from the start, strictly increasing (at least two).
    pub t_s: Vec<f64>,
    /// (canonical column, SI values), each as long as `t_s`.
    pub columns: Vec<(String, Vec<f64>)>,
}

impl Truth {
    fn validate(&self, bus: &CanBus) -> Result<(), SynthError> {
        if self.t_s.len() < 2 {
            return Err(SynthError::BadTruthTime {
                index: self.t_s.len(),
                t_s: f64::NAN,
                problem: "the truth needs at least two samples",
            });
        }
        for (i, &t) in self.t_s.iter().enumerate() {
            if !t.is_finite() {
                return Err(SynthError::BadTruthTime {
                    index: i,
                    t_s: t,
                    problem: "not finite",
                });
            }
            if i > 0 && t <= self.t_s[i - 1] {
                return Err(SynthError::BadTruthTime {
                    index: i,
                    t_s: t,
                    problem: "not after the previous sample",
                });
            }
        }
        for (k, (name, values)) in self.columns.iter().enumerate() {
            if !bus.channels().any(|(_, c)| &c.column == name) {
                return Err(SynthError::UnknownTruthColumn {
                    column: name.clone(),
                });
            }
            if self.columns[..k].iter().any(|(n, _)| n == name) {
                return Err(SynthError::BadName {
                    what: "duplicate truth column",
                    name: name.clone(),
                });
            }
            if values.len() != self.t_s.len() {
                return Err(SynthError::RaggedTruth {
                    column: name.clone(),
                    len: values.len(),
                    expected: self.t_s.len(),
                });
            }
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(SynthError::NonFiniteTruth {
                    column: name.clone(),
                    index: i,
                    t_s: self.t_s[i],
                    value: values[i],
                });
            }
        }
        Ok(())
    }

    /// Value of `values` at `t` (linear, or held when `hold`), clamped to the end values.
    fn at(&self, values: &[f64], t: f64, hold: bool) -> f64 {
        let n = self.t_s.len();
        let i = self.t_s.partition_point(|&x| x <= t); // first sample after t
        if i == 0 {
            return values[0];
        }
        if i == n || hold {
            return values[i - 1];
        }
        let (t0, t1) = (self.t_s[i - 1], self.t_s[i]);
        values[i - 1] + (values[i] - values[i - 1]) * (t - t0) / (t1 - t0)
    }
}

/// One logged message: topic, log time (ns since the Unix epoch) and the decoded JSON object.
#[derive(Debug, Clone, PartialEq)]
pub struct CanFrame {
    /// MCAP topic.
    pub topic: String,
    /// Log time, ns since the Unix epoch.
    pub log_time_ns: i64,
    /// Field → wire value.
    pub fields: Map<String, Value>,
}

/// FNV-1a, 64 bit, of a name (stream derivation; fixed so streams never change).
fn fnv1a64(name: &str) -> u64 {
    let mut h: u64 = 0xCBF2_9CE4_8422_2325;
    for b in name.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    h
}

pub(crate) fn stream(seed: u64, name: &str) -> Xoshiro256StarStar {
    let mut s = seed;
    Xoshiro256StarStar::seed_from_u64(splitmix64(&mut s) ^ fnv1a64(name))
}

fn json_number(x: f64) -> Value {
    if x.fract() == 0.0 && x.abs() < 1e15 {
        Value::from(x as i64)
    } else {
        Number::from_f64(x).map_or(Value::Null, Value::Number)
    }
}

/// Inverse of `conv`: SI → wire.
pub(crate) fn to_wire(conv: Conversion, si: f64) -> f64 {
    match conv {
        Conversion::Linear { factor, offset } => (si - offset) / factor,
        Conversion::AngleToGrade { to_rad } => si.atan() / to_rad,
    }
}

/// Samples `truth` on `bus`: every message that is sent, in time order (ties in bus order).
///
/// `start_ns` is the epoch time of truth time 0; `seed` selects noise and dropouts (see the
/// module conventions).
///
/// # Errors
/// Any bad bus parameter ([`CanBus::validate`]) or truth (too short, non-increasing or
/// non-finite times, NaN values, ragged or unknown columns).
pub fn sample(
    bus: &CanBus,
    truth: &Truth,
    start_ns: i64,
    seed: u64,
) -> Result<Vec<CanFrame>, SynthError> {
    bus.validate()?;
    truth.validate(bus)?;
    let schema = drive_log();
    let t_end = *truth.t_s.last().expect("validated: two samples");
    let t_first = truth.t_s[0];
    let mut out: Vec<(i64, usize, CanFrame)> = Vec::new();
    for (mi, m) in bus.messages.iter().enumerate() {
        struct Live<'a> {
            c: &'a CanChannel,
            values: &'a [f64],
            conv: Conversion,
            hold: bool,
            rng: Xoshiro256StarStar,
            steps: (f64, f64),
        }
        let mut live: Vec<Live> = Vec::new();
        for c in &m.channels {
            let Some((_, values)) = truth.columns.iter().find(|(n, _)| *n == c.column) else {
                continue;
            };
            let hold = schema.column(&c.column).map(|s| s.dtype) == Some(Dtype::I16);
            live.push(Live {
                c,
                values,
                conv: bus.conversion(c)?,
                hold,
                rng: stream(seed, &c.column),
                steps: step_range(c),
            });
        }
        if live.is_empty() {
            continue;
        }
        let mut drop_rng = stream(seed, &m.topic);
        let mut gap_end = f64::NEG_INFINITY;
        let mut k: u64 = 0;
        loop {
            let t = m.phase_s + k as f64 / m.rate_hz;
            if t > t_end {
                break;
            }
            k += 1;
            if t < t_first {
                continue;
            }
            let mut fields = Map::new();
            for l in &mut live {
                let si = truth.at(l.values, t - l.c.delay_s, l.hold);
                let noise = l.c.noise_sigma * l.rng.standard_normal();
                let wire = (to_wire(l.conv, si) + noise).clamp(l.c.wire_min, l.c.wire_max);
                let q = (wire / l.c.resolution).round().clamp(l.steps.0, l.steps.1);
                fields.insert(
                    l.c.field.clone(),
                    json_number(step_value(q, l.c.resolution)),
                );
            }
            if t < gap_end {
                continue;
            }
            if drop_rng.next_f64() < m.dropouts.start_probability {
                let u = drop_rng.next_f64();
                gap_end = t - m.dropouts.mean_length_s * (1.0 - u).ln();
                continue;
            }
            let log_time_ns = start_ns.saturating_add((t * 1e9).round() as i64);
            out.push((
                log_time_ns,
                mi,
                CanFrame {
                    topic: m.topic.clone(),
                    log_time_ns,
                    fields,
                },
            ));
        }
    }
    out.sort_by_key(|(t, mi, _)| (*t, *mi));
    Ok(out.into_iter().map(|(_, _, f)| f).collect())
}

/// Provenance and randomness of a synthetic drive.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthOptions {
    /// Epoch time of truth time 0, ns since the Unix epoch.
    pub start_ns: i64,
    /// Seed of noise and dropouts.
    pub seed: u64,
    /// Drive id written into the MCAP metadata (and so into the drive log).
    pub drive_id: String,
    /// Vehicle id written into the MCAP metadata, if any.
    pub vehicle_id: Option<String>,
}

/// The JSON schema record of a message: an object of numeric fields with their units.
fn json_schema(bus: &CanBus, m: &CanMessage) -> Vec<u8> {
    let mut props = Map::new();
    for c in &m.channels {
        let mut p = Map::new();
        p.insert("type".into(), Value::from("number"));
        p.insert(
            "description".into(),
            Value::from(format!(
                "{} in {}{}, resolution {}",
                c.column,
                c.wire_unit,
                bus.reference_nm(c.torque_reference)
                    .map(|r| format!(" of {r} N*m"))
                    .unwrap_or_default(),
                c.resolution
            )),
        );
        props.insert(c.field.clone(), Value::Object(p));
    }
    let mut s = Map::new();
    s.insert("type".into(), Value::from("object"));
    s.insert("title".into(), Value::from(m.name.clone()));
    s.insert("properties".into(), Value::Object(props));
    serde_json::to_vec(&Value::Object(s)).expect("JSON of strings and maps")
}

/// Chunk compression of a written MCAP file (both are what ingest reads).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum McapCompression {
    /// zstd at the encoder's default level (3), single-threaded.
    #[default]
    Zstd,
    /// LZ4 frames at the encoder's default level, no block checksums (the chunk CRC covers
    /// them).
    Lz4,
}

/// Writes `frames` as MCAP, atomically: zstd chunks (single-threaded, so the bytes do not depend
/// on the machine), one JSON-schema record and one `json` channel per bus message that has
/// frames, a metadata record `drive` with `drive_id`, `vehicle_id` (if any), `seed` and
/// `generator`. Message `sequence` counts per channel from 0; `publish_time = log_time`.
///
/// # Errors
/// [`SynthError::BadName`] for a frame whose topic is not on the bus; I/O and MCAP encoder
/// errors. On any error no file is left at `path`.
pub fn write_mcap(
    path: &Path,
    bus: &CanBus,
    frames: &[CanFrame],
    opts: &SynthOptions,
) -> Result<(), SynthError> {
    write_mcap_with(path, bus, frames, opts, McapCompression::Zstd, 0)
}

/// [`write_mcap`] with the chunk compression and its level chosen (`level` 0: the encoder's
/// default, zstd 3 or LZ4's fast mode; zstd 1…22, LZ4 1…12 with ≥ 3 its high-compression
/// mode). Chunks hold at most 1 MiB of uncompressed records (the encoder's default); every chunk
/// carries its CRC; message indexes and the summary are written.
///
/// # Errors
/// As [`write_mcap`]; [`SynthError::BadCompressionLevel`] for a level above the encoder's.
pub fn write_mcap_with(
    path: &Path,
    bus: &CanBus,
    frames: &[CanFrame],
    opts: &SynthOptions,
    compression: McapCompression,
    level: u32,
) -> Result<(), SynthError> {
    let (name, max) = match compression {
        McapCompression::Zstd => ("zstd", 22),
        McapCompression::Lz4 => ("lz4", 12),
    };
    if level > max {
        return Err(SynthError::BadCompressionLevel {
            compression: name,
            level,
            max,
        });
    }
    let io_err = |source| SynthError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mcap_err = |source| SynthError::Mcap {
        path: path.to_path_buf(),
        source: Box::new(source),
    };
    let tmp = AtomicFile::create(path).map_err(io_err)?;
    let handle = BufWriter::new(tmp.try_clone_file().map_err(io_err)?);
    let mut w = mcap::WriteOptions::new()
        .compression(Some(match compression {
            McapCompression::Zstd => mcap::Compression::Zstd,
            McapCompression::Lz4 => mcap::Compression::Lz4,
        }))
        .compression_threads(0)
        .compression_level(level)
        .library("fleetdyn-synth")
        .create(handle)
        .map_err(mcap_err)?;
    let mut metadata = BTreeMap::new();
    metadata.insert("drive_id".to_string(), opts.drive_id.clone());
    if let Some(v) = &opts.vehicle_id {
        metadata.insert("vehicle_id".to_string(), v.clone());
    }
    metadata.insert("seed".to_string(), opts.seed.to_string());
    metadata.insert(
        "generator".to_string(),
        format!("fleetdyn {} synth::can", env!("CARGO_PKG_VERSION")),
    );
    w.write_metadata(&mcap::records::Metadata {
        name: "drive".into(),
        metadata,
    })
    .map_err(mcap_err)?;
    // topic -> (channel id, next sequence)
    let mut ids: BTreeMap<&str, (u16, u32)> = BTreeMap::new();
    for m in &bus.messages {
        if !frames.iter().any(|f| f.topic == m.topic) {
            continue;
        }
        let schema = w
            .add_schema(&m.name, "jsonschema", &json_schema(bus, m))
            .map_err(mcap_err)?;
        let id = w
            .add_channel(schema, &m.topic, "json", &BTreeMap::new())
            .map_err(mcap_err)?;
        ids.insert(&m.topic, (id, 0));
    }
    for f in frames {
        let (id, seq) = ids
            .get_mut(f.topic.as_str())
            .ok_or_else(|| SynthError::BadName {
                what: "frame topic not on the bus",
                name: f.topic.clone(),
            })?;
        let data = serde_json::to_vec(&Value::Object(f.fields.clone())).expect("JSON of numbers");
        let t = u64::try_from(f.log_time_ns).unwrap_or(0);
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: *id,
                sequence: *seq,
                log_time: t,
                publish_time: t,
            },
            &data,
        )
        .map_err(mcap_err)?;
        *seq += 1;
    }
    w.finish().map_err(mcap_err)?;
    let mut handle = w.into_inner();
    handle.flush().map_err(io_err)?;
    drop(handle);
    tmp.commit().map_err(io_err)
}

/// Samples `truth` on `bus`, writes the MCAP at `mcap_path`, ingests it with the bus's mapping
/// ([`CanBus::mapping`]; otherwise ingest's defaults, so e.g. a wheel-speed dropout longer than
/// the 2 s NaN-run limit fails as it would for a real log) and writes the resulting canonical
/// drive log as Parquet at `parquet_path` (table `drive_log`). Returns that drive log.
///
/// Both files appear atomically, and together: if ingest or the Parquet step fails, the MCAP is
/// removed again.
///
/// # Errors
/// As [`sample`] and [`write_mcap`]; [`SynthError::Ingest`] if the MCAP does not ingest;
/// [`SynthError::Output`] if the Parquet cannot be written.
pub fn write_can_drive(
    mcap_path: &Path,
    parquet_path: &Path,
    bus: &CanBus,
    truth: &Truth,
    opts: &SynthOptions,
) -> Result<DriveLog, SynthError> {
    let frames = sample(bus, truth, opts.start_ns, opts.seed)?;
    let mapping = bus.mapping()?;
    write_mcap(mcap_path, bus, &frames, opts)?;
    // the pair appears together or not at all: a failed ingest or Parquet write removes the MCAP
    let rest = || -> Result<DriveLog, SynthError> {
        let ingest = IngestOptions {
            mapping: Some(mapping),
            ..IngestOptions::default()
        };
        let log = ingest_file(mcap_path, &ingest)?.log;
        let meta = TableMeta {
            table: "drive_log".into(),
            drive_id: log.meta.drive_id.clone(),
            vehicle_id: log.meta.vehicle_id.clone(),
            source_file: log.meta.source_file.clone(),
            config_hash: config_hash(&[
                format!("synth-can:v1 seed={} bus={bus:?}", opts.seed).as_bytes()
            ]),
            extra: vec![("synth_seed".into(), opts.seed.to_string())],
        };
        write_table(parquet_path, &meta, &drive_log_columns(&log))?;
        Ok(log)
    };
    rest().inspect_err(|_| {
        let _ = std::fs::remove_file(mcap_path);
    })
}
