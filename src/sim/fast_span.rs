//! Where the fast driveline integrator ([`super::fast::FastDriveline`]) hands its samples: a
//! whole [`Trajectory`] or the states alone (`StateSink`), and what a span of states returns
//! ([`SpanEnd`], with the step a simulation at a larger clutch capacity can resume from,
//! [`Resume`]).

use super::hybrid::{ClutchMode, Event, Trajectory, N_STATES};

/// Where [`FastDriveline::run_span`] puts its samples.
///
/// [`FastDriveline::run_span`]: super::fast::FastDriveline
pub(super) trait Sink {
    /// The sink reads the torques: they are computed for every sample.
    const TORQUES: bool;
    /// Sample at `t` (the last of the span when `last`); `torques` is (M_e, M_c, M_p, M_d,
    /// M_trans) in N·m when [`Sink::TORQUES`], else zeros.
    fn sample(
        &mut self,
        t: f64,
        y: &[f64; N_STATES],
        mode: ClutchMode,
        gear: usize,
        torques: [f64; 5],
        last: bool,
    );
    /// A mode switch or gear change.
    fn event(&mut self, e: Event);
    /// One accepted step.
    fn step(&mut self);
}

impl Sink for Trajectory {
    const TORQUES: bool = true;
    fn sample(
        &mut self,
        t: f64,
        y: &[f64; N_STATES],
        mode: ClutchMode,
        gear: usize,
        torques: [f64; 5],
        _last: bool,
    ) {
        self.t.push(t);
        self.y.push(*y);
        self.mode.push(mode);
        self.torques.push(torques);
        self.gear.push(gear);
    }
    fn event(&mut self, e: Event) {
        self.events.push(e);
    }
    fn step(&mut self) {
        self.stats.accepted += 1;
    }
}

/// Where a span of [`FastDriveline::simulate_span_states`] ended.
///
/// [`FastDriveline::simulate_span_states`]: super::fast::FastDriveline::simulate_span_states
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpanEnd {
    /// State at the span's end.
    pub y: [f64; N_STATES],
    /// Clutch mode at the span's end.
    pub mode: ClutchMode,
    /// The clutch was locked at every sample of the span, the first and the last included.
    pub locked_throughout: bool,
    /// Where the span can be taken up again with a larger clutch capacity: the start of the
    /// last whole step that began with the clutch locked before it first unlocked (`None`
    /// when it never unlocked, began slipping, or the integrator did not track it:
    /// [`FastDriveline::tracking_first_unlock`](super::fast::FastDriveline::tracking_first_unlock)).
    pub first_unlock: Option<Resume>,
}

/// A whole step of a span at which a simulation can start again
/// ([`super::fast::FastDriveline::resume_span_states`]): the step's index on the span's grid
/// of `dt` and the state at its start, clutch locked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resume {
    /// Index of the step on the span's grid (`t = t_start + k·dt`).
    pub(super) k: usize,
    /// State at the step's start.
    pub(super) y: [f64; N_STATES],
    /// The vehicle was held at standstill.
    pub(super) stuck: bool,
}

impl Resume {
    /// Index of the step on the span's grid.
    pub fn step(&self) -> usize {
        self.k
    }
}

/// The states alone, to a caller's closure
/// ([`FastDriveline::simulate_span_states`](super::fast::FastDriveline::simulate_span_states)).
pub(super) struct StateSink<'o> {
    pub(super) out: &'o mut dyn FnMut(f64, &[f64; N_STATES]),
    /// Hand over the span's last sample too.
    pub(super) last: bool,
    /// The last sample's state and mode.
    pub(super) end: ([f64; N_STATES], ClutchMode),
    /// Every sample so far had the clutch locked.
    pub(super) locked: bool,
}

impl Sink for StateSink<'_> {
    const TORQUES: bool = false;
    fn sample(
        &mut self,
        t: f64,
        y: &[f64; N_STATES],
        mode: ClutchMode,
        _gear: usize,
        _torques: [f64; 5],
        last: bool,
    ) {
        self.end = (*y, mode);
        self.locked &= mode == ClutchMode::Locked;
        if !last || self.last {
            (self.out)(t, y);
        }
    }
    fn event(&mut self, _e: Event) {}
    fn step(&mut self) {}
}
