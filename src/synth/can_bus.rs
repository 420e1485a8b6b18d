//! A CAN bus as a J1939 logger sees it. A [`CanBus`] is a list of [`CanMessage`]s (one MCAP
//! topic each, e.g. EEC1 on `/can/eec1`), each carrying one or more [`CanChannel`]s (one JSON
//! field each, e.g. `EngineSpeed`). A message has its rate (Hz), phase (s) and dropout process;
//! a channel its wire unit, resolution, range and noise σ (wire units) and its delay (s). How a
//! truth is sampled on a bus is [`super::can_sample`].
//!
//! **Torque in %** is percent of a reference torque ([`TorqueReference`]): the engine's
//! (J1939 EC1) for `engine_torque`, the retarder's for `retarder_torque`.

use super::can_error::SynthError;
use crate::ingest::Mapping;
use crate::schema::drive_log;
use crate::units::{conversion, Conversion};

/// Which reference torque a `%` torque channel is a percentage of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum TorqueReference {
    /// Not a percent torque.
    None,
    /// [`CanBus::reference_torque_nm`] (J1939 EC1 engine reference torque, SPN 544).
    Engine,
    /// [`CanBus::retarder_reference_torque_nm`] (J1939 retarder reference torque, SPN 556).
    Retarder,
}

/// One signal field of a CAN message.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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

/// Dropout process of a message (see the conventions of [`super::can_sample`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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

    pub(super) fn reference_nm(&self, r: TorqueReference) -> Option<f64> {
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
pub(super) fn step_range(c: &CanChannel) -> (f64, f64) {
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
