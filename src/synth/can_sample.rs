//! Sampling SI truth signals on a [`CanBus`]: every scheduled message of every topic, its
//! fields at their wire resolution with noise, delay and dropouts ([`sample`]).
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

use super::can_bus::{step_range, step_value, CanBus, CanChannel};
use super::can_error::SynthError;
use crate::rng::{splitmix64, Xoshiro256StarStar};
use crate::schema::{drive_log, Dtype};
use crate::units::Conversion;
use serde_json::{Map, Number, Value};

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
