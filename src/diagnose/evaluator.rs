//! The models of a recording at one greedy round's parameters, as step 3 of the diagnosis,
//! explain, evaluates them (docs/diagnosis/method.md): the compared views with fixed weights
//! ([`ModelView`]), a simulation's outputs with their weighted mean squares ([`Eval`]), and the
//! [`Evaluator`] that simulates a parameter value and scores it: the cost (the mean over views
//! of their weighted mean squares, dimensionless), the deviance between two values, the
//! whiteness and effective samples of a residual, the inner products of the screen and the fit,
//! and the correlation of two fitted corrections.

use super::deviance::events_deviance;
use super::extended::{ExtendedError, Theta};
use super::problem::{effective_samples, weighted_ms, whiteness, Part, Problem, Whiteness};
use super::row_column::RowColumn;
use crate::model::catalogue::{Domain, Effect};
use std::sync::Arc;

/// Weighted mean square of an output change below which a model view counts as unchanged
/// ([`Evaluator::changed`]): an RMS change of 1 % of the channels' weights `σ_c`.
pub const MATERIAL_CHANGE_MS: f64 = 1e-4;

/// The compared outputs of one view of a model ([`super::problem::View`]) with their
/// weights; "model" in the cost, screen and acceptance tests means such a view.
#[derive(Debug, Clone)]
pub struct ModelView {
    /// Model.
    pub domain: Domain,
    /// Its channels ([`Problem::channels`] indices).
    pub chans: Vec<usize>,
    /// Their weights σ_c.
    pub sigmas: Vec<f64>,
    /// A view with its own term of the deviance ([`Evaluator::deviance`],
    /// [`super::problem::ViewKind::own_term`]).
    pub own_term: bool,
    /// The effects the view is scored for ([`super::problem::ViewKind::only_for`]).
    pub only_for: Option<&'static [Effect]>,
}

impl ModelView {
    /// Whether `e` is fitted and scored on this view (when it changes it): any effect, or one
    /// of the view's own.
    pub fn serves(&self, e: Effect) -> bool {
        self.only_for.is_none_or(|x| x.contains(&e))
    }
}

/// Simulated outputs of every model in use at one parameter value, with the weighted mean
/// squares per model.
#[derive(Debug, Clone)]
pub struct Eval {
    /// Parameter value (NaN for the round's base).
    pub value: f64,
    /// Outputs per model view, per channel.
    pub outputs: Vec<Arc<Vec<RowColumn>>>,
    /// Weighted train mean square per model.
    pub train: Vec<f64>,
    /// Weighted held-out mean square per model (NaN when `train_only`).
    pub heldout: Vec<f64>,
    /// Simulated on the train part alone ([`Evaluator::eval_train`]): the outputs outside the
    /// longitudinal model's train windows are NaN.
    pub train_only: bool,
}

/// Which models an effect changes (its fit and score use their outputs).
pub type Active = Vec<bool>;

/// The models of a problem at the round's parameters with fixed weights: what a screen and fit
/// evaluate.
#[derive(Debug)]
pub struct Evaluator<'p, 'a> {
    /// The problem.
    pub problem: &'p Problem<'a>,
    /// Every model in use.
    pub models: Vec<ModelView>,
    /// The round's parameters.
    pub theta: Theta,
    /// Row spacing, s.
    pub dt_s: f64,
}

/// Weight of one channel's rows in the cost and its inner products: `1/(n σ² n_c n_m)` for `n`
/// rows (at least 1) of a channel with noise floor `σ` (its unit), `n_c` channels in its model
/// and `n_m` models counted, so each model's weighted mean square counts `1/n_m`.
#[inline]
fn channel_weight(rows: usize, sigma: f64, n_chans: usize, n_models: f64) -> f64 {
    1.0 / (rows.max(1) as f64 * sigma * sigma * n_chans as f64 * n_models)
}

impl<'p, 'a> Evaluator<'p, 'a> {
    /// Evaluator of `problem` at `theta` with the weights of its outputs `base` (one per model
    /// in [`Problem::domains`] order) and `noise_floor` ([`Problem::sigmas`]).
    pub fn new(
        problem: &'p Problem<'a>,
        theta: Theta,
        base: &[Arc<Vec<RowColumn>>],
        noise_floor: Option<&std::collections::BTreeMap<String, f64>>,
        dt_s: f64,
    ) -> Self {
        let models = problem
            .views()
            .iter()
            .zip(base)
            .map(|(v, y)| ModelView {
                domain: v.domain,
                chans: v.chans.clone(),
                sigmas: problem.sigmas(&v.chans, y, noise_floor),
                own_term: v.kind.own_term(),
                only_for: v.kind.only_for(),
            })
            .collect();
        Self {
            problem,
            models,
            theta,
            dt_s,
        }
    }

    /// The evaluator of `problem` at its nominal parameters, weighted by `noise_floor` and the
    /// nominal outputs ([`Problem::sigmas`]), with those outputs evaluated: where a diagnosis'
    /// first round starts, and what the proof's oracle check and the study examples score.
    pub fn at_nominal(
        problem: &'p Problem<'a>,
        noise_floor: Option<&std::collections::BTreeMap<String, f64>>,
    ) -> (Self, Eval) {
        let bases: Vec<Arc<Vec<RowColumn>>> = problem
            .nominal_outputs()
            .iter()
            .map(|y| Arc::new(y.clone()))
            .collect();
        let ev = Self::new(
            problem,
            *problem.nominal(),
            &bases,
            noise_floor,
            problem.row_spacing_s(),
        );
        let base = ev.eval_outputs(f64::NAN, bases);
        (ev, base)
    }

    fn ms(&self, m: usize, y: &[RowColumn], part: Part) -> f64 {
        let v = &self.models[m];
        weighted_ms(self.problem.channels(), &v.chans, &v.sigmas, y, part)
    }

    /// The evaluation of outputs `outputs` (one per model).
    pub fn eval_outputs(&self, value: f64, outputs: Vec<Arc<Vec<RowColumn>>>) -> Eval {
        let train = (0..self.models.len())
            .map(|m| self.ms(m, &outputs[m], Part::Train))
            .collect();
        let heldout = (0..self.models.len())
            .map(|m| self.ms(m, &outputs[m], Part::Heldout))
            .collect();
        Eval {
            value,
            outputs,
            train,
            heldout,
            train_only: false,
        }
    }

    /// Simulates the models of `active` with `e`'s parameter at `value`; the others keep
    /// `base`'s outputs.
    ///
    /// # Errors
    /// [`ExtendedError`] from a model.
    pub fn eval(
        &self,
        base: &Eval,
        active: &[bool],
        e: Effect,
        value: f64,
    ) -> Result<Eval, ExtendedError> {
        let outputs = self.outputs_at(base, active, e, value, false)?;
        Ok(self.eval_outputs(value, outputs))
    }

    /// The outputs per model view with `e`'s parameter at `value`: the views of `active`
    /// simulated (the longitudinal model on its train windows alone when `train_only`), the
    /// others `base`'s.
    fn outputs_at(
        &self,
        base: &Eval,
        active: &[bool],
        e: Effect,
        value: f64,
        train_only: bool,
    ) -> Result<Vec<Arc<Vec<RowColumn>>>, ExtendedError> {
        let mut th = self.theta;
        th.set(e, value);
        let sims = self.problem.simulate_views_on(active, &th, train_only)?;
        Ok(sims
            .into_iter()
            .zip(&base.outputs)
            .map(|(y, b)| y.map_or_else(|| b.clone(), Arc::new))
            .collect())
    }

    /// [`Evaluator::eval`] for a train cost: the longitudinal model simulated on the windows the
    /// train part reads ([`Problem::train_windows`]), the held-out mean squares NaN. Its train
    /// mean squares and its outputs on the train rows are [`Evaluator::eval`]'s, bit for bit,
    /// at about half the simulation (the parts alternate block by block); what reads the
    /// held-out part (the acceptance rule, the whiteness, the next round's base) takes a whole
    /// evaluation.
    ///
    /// # Errors
    /// [`ExtendedError`] from a model.
    pub fn eval_train(
        &self,
        base: &Eval,
        active: &[bool],
        e: Effect,
        value: f64,
    ) -> Result<Eval, ExtendedError> {
        let outputs = self.outputs_at(base, active, e, value, true)?;
        let train = (0..self.models.len())
            .map(|m| self.ms(m, &outputs[m], Part::Train))
            .collect();
        Ok(Eval {
            value,
            outputs,
            train,
            heldout: vec![f64::NAN; self.models.len()],
            train_only: true,
        })
    }

    /// Whether model view `m`'s outputs differ materially between `a` and `b`: the weighted
    /// mean square of the change over all valid rows (the cost's weights) above
    /// [`MATERIAL_CHANGE_MS`]. Why not any change: the shuffle modes are the linearised
    /// driveline's, whose damping (not its stiffness) takes the road load's slope, so a drag
    /// or rolling-resistance change moves them by parts per million — a view that would
    /// otherwise count for every longitudinal effect and set its sample count.
    pub fn changed(&self, m: usize, a: &Eval, b: &Eval) -> bool {
        self.change_ms(m, a, b) > MATERIAL_CHANGE_MS
    }

    /// The weighted mean square of the change of model view `m`'s outputs from `b` to `a`
    /// over all valid rows (the cost's weights; [`Evaluator::changed`]'s figure).
    pub fn change_ms(&self, m: usize, a: &Eval, b: &Eval) -> f64 {
        let v = &self.models[m];
        let ch = self.problem.channels();
        let mut ms = 0.0;
        for (k, (&c, sg)) in v.chans.iter().zip(&v.sigmas).enumerate() {
            let (ya, yb) = (&a.outputs[m][k], &b.outputs[m][k]);
            let (mut s, mut n) = (0.0, 0usize);
            for part in [Part::Train, Part::Heldout] {
                for &i in ch[c].rows(part) {
                    s += ch[c].weight(i) * (ya[i] - yb[i]).powi(2);
                    n += 1;
                }
            }
            ms += s / (n.max(1) as f64 * sg * sg);
        }
        ms / v.chans.len().max(1) as f64
    }

    /// The pooled views of `active` (its own-term views switched off).
    pub fn pooled(&self, active: &[bool]) -> Vec<bool> {
        active
            .iter()
            .zip(&self.models)
            .map(|(a, v)| *a && !v.own_term)
            .collect()
    }

    /// Deviance of `x` against the reference `r` on the views of `active`,
    /// `D = n_pooled ln(J_p(x)/J_p(r)) + Σ_own N_v (J_v(x) − J_v(r)) / max(1, J_v(r))` on
    /// `part` (the train part for every fit and interval; a switch's rule 3 adds the held-out
    /// part's, [`super::explain`]): the
    /// speeds and pressures pooled (`J_p` the mean of their weighted mean squares, `n_pooled`
    /// their effective sample count — the fewest over their largely redundant channels,
    /// [`Evaluator::n_eff`], or the cluster count), and each own-term view (the shuffle modes,
    /// the torque reversals) as `N_v (J_v(x) − J_v(r)) / max(1, J_v(r))`, `N_v` its effective
    /// samples of `part` at `r` ([`effective_samples`]: the events) — the χ² difference of
    /// samples whose variances are known (each event's own weight, the standardised mean
    /// square `J_v` is 1 at them), scaled by the reference's overdispersion when its residual
    /// exceeds them (a quasi-likelihood). Why not the profiled form `N_v ln(J_v(x)/J_v(r))` of
    /// the pooled views: with a few events a one-parameter fit can leave a near-zero residual,
    /// and a variance profiled from it makes any other value look excluded (a proof lash drive
    /// with one train reversal: a 95 % lash interval of ±3.5 % around 0.030 rad, which the true
    /// 0.037 rad lies far outside). A group `x` and `r` both leave at zero
    /// cost adds nothing.
    pub fn deviance(&self, x: &Eval, r: &Eval, active: &[bool], n_pooled: f64, part: Part) -> f64 {
        let pooled = self.pooled(active);
        let mut d = 0.0;
        if pooled.contains(&true) {
            let (jx, jr) = (self.cost(x, &pooled, part), self.cost(r, &pooled, part));
            if jx > 0.0 && jr > 0.0 && n_pooled.is_finite() {
                d += n_pooled.max(1.0) * (jx / jr).ln();
            }
        }
        let (xs, rs) = match part {
            Part::Train => (&x.train, &r.train),
            Part::Heldout => (&x.heldout, &r.heldout),
        };
        for (m, v) in self.models.iter().enumerate() {
            if active[m] && v.own_term && xs[m] > 0.0 && rs[m] > 0.0 {
                let n = v
                    .chans
                    .iter()
                    .enumerate()
                    .map(|(k, &c)| {
                        effective_samples(&self.problem.channels()[c], &r.outputs[m][k], part)
                    })
                    .fold(f64::INFINITY, f64::min);
                if n.is_finite() {
                    d += events_deviance(n, xs[m], rs[m]);
                }
            }
        }
        d
    }

    /// Cost of `x` over the models of `active`: the mean of their weighted mean squares.
    pub fn cost(&self, x: &Eval, active: &[bool], part: Part) -> f64 {
        let v = match part {
            Part::Train => &x.train,
            Part::Heldout => &x.heldout,
        };
        let (mut s, mut n) = (0.0, 0);
        for (m, a) in active.iter().enumerate() {
            if *a {
                s += v[m];
                n += 1;
            }
        }
        s / n.max(1) as f64
    }

    /// Weighted inner product over the train rows of the models of `active`, consistent with
    /// [`Evaluator::cost`]: `cost = ⟨r, r⟩`. `a` and `b` map (model, channel slot, row) to a
    /// value.
    pub fn inner(
        &self,
        active: &[bool],
        a: impl Fn(usize, usize, usize) -> f64,
        b: impl Fn(usize, usize, usize) -> f64,
    ) -> f64 {
        self.inner_on(active, a, b, &[Part::Train])
    }

    /// [`Evaluator::inner`] on `parts`: each part's inner product (its rows weighted as the
    /// cost weights them), summed over the parts.
    pub(super) fn inner_on(
        &self,
        active: &[bool],
        a: impl Fn(usize, usize, usize) -> f64,
        b: impl Fn(usize, usize, usize) -> f64,
        parts: &[Part],
    ) -> f64 {
        let ch = self.problem.channels();
        let n_act = active.iter().filter(|x| **x).count().max(1) as f64;
        let mut s = 0.0;
        for (m, v) in self.models.iter().enumerate() {
            if !active[m] {
                continue;
            }
            for (k, (&c, sg)) in v.chans.iter().zip(&v.sigmas).enumerate() {
                for &part in parts {
                    let rows = ch[c].rows(part);
                    let w = channel_weight(rows.len(), *sg, v.chans.len(), n_act);
                    let chan = &ch[c];
                    let mut acc = 0.0;
                    for &i in rows {
                        acc += chan.weight(i) * a(m, k, i) * b(m, k, i);
                    }
                    s += w * acc;
                }
            }
        }
        s
    }

    /// The Gram matrix `G[p][q] = ⟨f_p, f_q⟩` (upper triangle, `q ≥ p`) and `g[p] = ⟨f_p, r⟩` of
    /// [`Evaluator::inner`] over the models of `active`: each entry is that inner product bit
    /// for bit (every row's term and every sum in the same order), with each function read once
    /// per row instead of once per pair. The rows are read in blocks, so the extra memory is a
    /// block of values per function, whatever the drive's length.
    pub fn gram(
        &self,
        active: &[bool],
        fs: &[&dyn Fn(usize, usize, usize) -> f64],
        r: &dyn Fn(usize, usize, usize) -> f64,
    ) -> (Vec<Vec<f64>>, Vec<f64>) {
        const BLOCK: usize = 1024;
        let n = fs.len();
        let ch = self.problem.channels();
        let n_act = active.iter().filter(|x| **x).count().max(1) as f64;
        let mut gram: Vec<Vec<f64>> = (0..n).map(|p| vec![0.0; n - p]).collect();
        let mut g = vec![0.0; n];
        let mut vals = vec![[0.0; BLOCK]; n];
        let mut wr = [0.0; BLOCK];
        let mut ws = [0.0; BLOCK];
        for (m, v) in self.models.iter().enumerate() {
            if !active[m] {
                continue;
            }
            for (k, (&c, sg)) in v.chans.iter().zip(&v.sigmas).enumerate() {
                let rows = ch[c].rows(Part::Train);
                let w = channel_weight(rows.len(), *sg, v.chans.len(), n_act);
                let chan = &ch[c];
                let mut acc: Vec<Vec<f64>> = (0..n).map(|p| vec![0.0; n - p]).collect();
                let mut acc_g = vec![0.0; n];
                for block in rows.chunks(BLOCK) {
                    let b = block.len();
                    for (j, &i) in block.iter().enumerate() {
                        ws[j] = chan.weight(i);
                        wr[j] = r(m, k, i);
                    }
                    for (f, x) in fs.iter().zip(vals.iter_mut()) {
                        for (j, &i) in block.iter().enumerate() {
                            x[j] = f(m, k, i);
                        }
                    }
                    for p in 0..n {
                        let xp = &vals[p][..b];
                        let mut a = acc_g[p];
                        for j in 0..b {
                            a += ws[j] * xp[j] * wr[j];
                        }
                        acc_g[p] = a;
                        for q in p..n {
                            let xq = &vals[q][..b];
                            let mut a = acc[p][q - p];
                            for j in 0..b {
                                a += ws[j] * xp[j] * xq[j];
                            }
                            acc[p][q - p] = a;
                        }
                    }
                }
                for p in 0..n {
                    g[p] += w * acc_g[p];
                    for (x, a) in gram[p].iter_mut().zip(&acc[p]) {
                        *x += w * a;
                    }
                }
            }
        }
        (gram, g)
    }

    /// Residual of `x` at (model, channel slot, row).
    pub(super) fn resid<'e>(&'e self, x: &'e Eval) -> impl Fn(usize, usize, usize) -> f64 + 'e {
        let ch = self.problem.channels();
        move |m, k, i| ch[self.models[m].chans[k]].measured[i] - x.outputs[m][k][i]
    }

    /// Whiteness of `x`'s held-out residual over the models of `active` (means of
    /// [`whiteness`]'s figures over the models).
    pub fn whiteness(&self, x: &Eval, active: &[bool]) -> Whiteness {
        self.whiteness_on(x, active, &[Part::Heldout])
    }

    /// Whiteness of `x`'s residual on `parts` over the models of `active`: the means of
    /// [`whiteness`]'s figures over the models and the parts (each part on its own, so that
    /// no lag spans the boundary of two parts).
    pub fn whiteness_on(&self, x: &Eval, active: &[bool], parts: &[Part]) -> Whiteness {
        let (mut q, mut p, mut n) = (0.0, 0.0, 0);
        for (m, v) in self.models.iter().enumerate() {
            if !active[m] {
                continue;
            }
            for &part in parts {
                let w = whiteness(
                    self.problem.channels(),
                    &v.chans,
                    &v.sigmas,
                    &x.outputs[m],
                    part,
                    self.dt_s,
                );
                q += w.q_per_n;
                p += w.nonwhite_power;
                n += 1;
            }
        }
        let n = n.max(1) as f64;
        Whiteness {
            q_per_n: q / n,
            nonwhite_power: p / n,
        }
    }

    /// Fewest effective samples of `part` ([`effective_samples`]) over the channels of the pooled
    /// views of `active` (the speeds, the pressures; an own-term view has its own count in
    /// [`Evaluator::deviance`]); when `active` has no pooled view, the fewest over its own-term
    /// views, so that the figure reported with a fit is always a sample count.
    pub fn n_eff(&self, x: &Eval, active: &[bool], part: Part) -> f64 {
        let fewest = |own: bool| {
            let mut n = f64::INFINITY;
            for (m, v) in self.models.iter().enumerate() {
                if active[m] && v.own_term == own {
                    for (k, &c) in v.chans.iter().enumerate() {
                        n = n.min(effective_samples(
                            &self.problem.channels()[c],
                            &x.outputs[m][k],
                            part,
                        ));
                    }
                }
            }
            n
        };
        let n = fewest(false);
        if n.is_finite() {
            n
        } else {
            fewest(true)
        }
    }

    /// Cluster-robust effective sample count of a fit at `best` with sensitivity `a` over the
    /// pooled views of `active` ([`super::fit_interval`]; [`Evaluator::pooled`]): `(N_cl, B)`, `B`
    /// the train blocks with valid rows.
    pub(super) fn cluster_n_eff(
        &self,
        best: &Eval,
        active: &[bool],
        a: impl Fn(usize, usize, usize) -> f64,
    ) -> Option<(f64, usize)> {
        let ch = self.problem.channels();
        let block = &self.problem.split().block;
        let nb = block.iter().copied().max().map_or(0, |b| b + 1);
        let pooled = self.pooled(active);
        let n_act = pooled.iter().filter(|x| **x).count().max(1) as f64;
        let mut g = vec![0.0; nb];
        let mut used = vec![false; nb];
        let mut h = 0.0;
        for (m, v) in self.models.iter().enumerate() {
            if !pooled[m] {
                continue;
            }
            for (k, (&c, sg)) in v.chans.iter().zip(&v.sigmas).enumerate() {
                let rows = ch[c].rows(Part::Train);
                let w = channel_weight(rows.len(), *sg, v.chans.len(), n_act);
                for &i in rows {
                    let (ai, wi) = (a(m, k, i), w * ch[c].weight(i));
                    let ri = ch[c].measured[i] - best.outputs[m][k][i];
                    g[block[i]] += wi * ai * ri;
                    h += wi * ai * ai;
                    used[block[i]] = true;
                }
            }
        }
        let b = used.iter().filter(|u| **u).count();
        if b < 2 || h <= 0.0 || !h.is_finite() {
            return None;
        }
        let v = b as f64 / (b - 1) as f64 * g.iter().map(|x| x * x).sum::<f64>() / (h * h);
        let j = self.cost(best, &pooled, Part::Train);
        let n = if v > 0.0 { j / (h * v) } else { f64::INFINITY };
        Some((n, b))
    }

    /// Weighted correlation over all valid rows (train and held-out) of every model of two
    /// corrections `a − base` and `b − base`.
    pub fn correction_correlation(&self, base: &Eval, a: &Eval, b: &Eval) -> f64 {
        let ch = self.problem.channels();
        let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
        for (m, v) in self.models.iter().enumerate() {
            for (k, (&c, sg)) in v.chans.iter().zip(&v.sigmas).enumerate() {
                let w0 = 1.0 / (sg * sg);
                for part in [Part::Train, Part::Heldout] {
                    for &i in ch[c].rows(part) {
                        let w = w0 * ch[c].weight(i);
                        let x = a.outputs[m][k][i] - base.outputs[m][k][i];
                        let y = b.outputs[m][k][i] - base.outputs[m][k][i];
                        ab += w * x * y;
                        aa += w * x * x;
                        bb += w * y * y;
                    }
                }
            }
        }
        if aa > 0.0 && bb > 0.0 {
            ab / (aa * bb).sqrt()
        } else {
            0.0
        }
    }
}
