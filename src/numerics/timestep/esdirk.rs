//! The ESDIRK integrator (TR-BDF2 or ESDIRK4, [`Scheme`]): stages, error control, the
//! step-size levels and the cache of factorised stage matrices, outputs at requested times
//! (quintic Hermite with its error controlled, [`Dense`], for a time-invariant A).

use faer::sparse::SparseColMat;

use super::error::StepError;
use super::generator::{apply, shifted, Generator};
use super::tableau::Scheme;
use crate::base::cancel::Cancel;
use crate::base::limits::memory_limit_bytes;
use crate::numerics::sparse::faer_lu::{FaerLu, Ordering};
use crate::numerics::sparse::pattern_lu::PatternLu;
use crate::numerics::sparse::{Check, FactorError, Factorization};

/// Safety factor of the step-size proposal.
const SAFETY: f64 = 0.9;
/// A step's dense output may err as much as the step itself is estimated to, or this
/// fraction of what the step may err where its estimate is smaller: the outputs are then as
/// good as the steps' ends. Held to the step's allowance instead (‖e‖ ≤ tol·h), outputs
/// inside the long steps of a density near its stationary state were much worse than the
/// ends (the linear oscillator at 80x80, tol 1e−6, one output at t = 400 inside a step of
/// 200: L1 4.9e−6 from the stationary density against 3.4e−7 at a step's end; case 1 at
/// 100x200 from t = 40: 2.6e−5 against 5.4e−9).
const DENSE_FLOOR: f64 = 1e-3;
/// When a stage solve is accepted (as the grid's stationary solve).
const CHECK: Check = Check {
    refine_above: 1e-14,
    limit: 1e-12,
};
/// With [`Esdirk::reuse_across_times`]: the most corrections of one solve preconditioned by
/// a factor of another time's stage matrix before the matrix is factorised itself.
const MAX_SWEEPS: usize = 6;
/// ... and the corrections beyond the first of each solve a factor may cost in all before
/// it is replaced by the stage matrix at the time asked: a factorisation costs about 9
/// solves at 128x128 cells. On the modulated linear oscillator at 96x96 the run's time was
/// flat for limits from 8 to 32 and for counting every correction or only those beyond
/// the first (99 and 56 factorisations in 175 steps): the solves dominate.
const REFACTOR_SWEEPS: usize = 16;

/// The error a step may make: its estimate e must satisfy
/// ‖e‖ ≤ `absolute` + `relative` · ‖y‖ in the weighted L1 norm ‖u‖ = weight · Σ|uᵢ|
/// (for cell averages of a density, weight = the cell's area: an L1 distance of densities).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Tolerance {
    /// Relative to the solution's norm.
    pub(crate) relative: f64,
    /// Absolute.
    pub(crate) absolute: f64,
}

/// The solution at one requested time.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Output {
    /// The time.
    pub(crate) t: f64,
    /// The solution.
    pub(crate) y: Vec<f64>,
    /// weight · Σ yᵢ.
    pub(crate) mass: f64,
    /// weight · Σ max(−yᵢ, 0): negative values are reported, never clipped.
    pub(crate) negative_mass: f64,
}

/// Counts of what a run did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Stats {
    /// Accepted steps.
    pub(crate) accepted: usize,
    /// Rejected steps.
    pub(crate) rejected: usize,
    /// Stage matrices factorised.
    pub(crate) factorizations: usize,
    /// Distinct step sizes used.
    pub(crate) step_sizes: usize,
    /// Corrections of solves preconditioned by another time's factor
    /// ([`Esdirk::reuse_across_times`]).
    pub(crate) sweeps: usize,
}

/// The outputs of a run, in the order of the requested times.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct History {
    /// One per requested time.
    pub(crate) outputs: Vec<Output>,
    /// What the run did.
    pub(crate) stats: Stats,
}

/// An ESDIRK method on dy/dt = A(t) y (see the module's documentation).
pub(crate) struct Esdirk<'a, G: Generator> {
    generator: &'a G,
    scheme: Scheme,
    tolerance: Tolerance,
    weight: f64,
    order: Option<Vec<usize>>,
    first_step: Option<f64>,
    fixed: bool,
    across_times: bool,
    per_unit_time: bool,
    conserve: bool,
    max_steps: usize,
    cache: usize,
    cancel: Option<Cancel>,
}

/// The stage vectors of one step: y₁ (the last stage), A y at the implicit stages (the
/// last is f₁ = A(t + h) y₁) and the error estimate.
struct Work {
    y1: Vec<f64>,
    f: Vec<Vec<f64>>,
    est: Vec<f64>,
}

impl Work {
    fn new(n: usize, stages: usize) -> Work {
        Work {
            y1: vec![0.0; n],
            f: vec![vec![0.0; n]; stages - 1],
            est: vec![0.0; n],
        }
    }

    /// f₁ = A(t + h) y₁.
    fn f1(&self) -> &[f64] {
        self.f.last().expect("at least one implicit stage")
    }
}

/// A factorised stage matrix.
enum Stage {
    Pattern(PatternLu),
    Faer(Box<FaerLu>),
}

struct Entry {
    key: (u64, u64),
    matrix: SparseColMat<usize, f64>,
    factor: Stage,
    used: usize,
    /// The time of the generator in `matrix`.
    at: u64,
    /// Corrections taken with this factor for other times' stage matrices.
    sweeps: usize,
}

impl<'a, G: Generator> Esdirk<'a, G> {
    /// A TR-BDF2 stepper for `generator` at tolerance 1e-6 relative and absolute, weight 1.
    pub(crate) fn new(generator: &'a G) -> Self {
        Esdirk {
            generator,
            scheme: Scheme::TrBdf2,
            tolerance: Tolerance {
                relative: 1e-6,
                absolute: 1e-6,
            },
            weight: 1.0,
            order: None,
            first_step: None,
            fixed: false,
            across_times: false,
            per_unit_time: true,
            conserve: false,
            max_steps: 1_000_000,
            cache: 3,
            cancel: None,
        }
    }

    /// The method (default TR-BDF2).
    pub(crate) fn scheme(mut self, scheme: Scheme) -> Self {
        self.scheme = scheme;
        self
    }

    pub(crate) fn tolerance(mut self, tolerance: Tolerance) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// The weight of every component in the norms, mass and negative mass.
    pub(crate) fn weight(mut self, weight: f64) -> Self {
        self.weight = weight;
        self
    }

    /// The elimination order of the stage matrices (position → column): factorised by the
    /// pattern LU, faer's LU (COLAMD) where that fails its check. Without an order, faer's
    /// LU alone.
    pub(crate) fn order(mut self, order: Vec<usize>) -> Self {
        self.order = Some(order);
        self
    }

    /// The first step (else chosen from the norms of A³y₀).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn first_step(mut self, h: f64) -> Self {
        self.first_step = Some(h);
        self
    }

    /// Every step the first one, no error control (for convergence tests).
    #[cfg(test)]
    pub(crate) fn fixed(mut self) -> Self {
        self.fixed = true;
        self
    }

    /// Bounds each step's error itself, ‖e‖ ≤ tolerance, instead of its error per unit time
    /// (the default): longer steps, but the global error is then about the tolerance times
    /// the number of steps, and falls only as the tolerance's 2/3 power.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn per_step(mut self) -> Self {
        self.per_unit_time = false;
        self
    }

    /// The generator's columns sum to zero (checked at the start: every column sum within
    /// 1e−12 of A's largest entry, else [`StepError::Setting`]), and each stage solve keeps
    /// the mass exactly: the exact solve has 1ᵀx = 1ᵀb (1ᵀ(I − dhA) = 1ᵀ), so the defect its
    /// residual leaves (up to 1e−12 per output on a stiff chain) is put back in proportion
    /// to |xᵢ|, a change within the solve's own error. Mass then drifts only by the rounding
    /// of sums.
    pub(crate) fn conserve_mass(mut self) -> Self {
        self.conserve = true;
        self
    }

    /// For a generator that depends on t: a stage matrix's factor serves the later stage
    /// times of the same step size as the preconditioner of an iteration on the stage
    /// matrix of the time asked (x ← x + M⁻¹(b − (I − γhA(t))x), to the same backward error
    /// as a direct solve), and the matrix at t is factorised instead when that iteration
    /// stalls or the factor's extra corrections have cost about a factorisation. Every solve is
    /// of its own time's matrix; only the work changes. Off by default.
    pub(crate) fn reuse_across_times(mut self) -> Self {
        self.across_times = true;
        self
    }

    /// How many factorised stage matrices are kept (default 3).
    // Run-control for the transient's and reliability's front ends, not wired yet.
    #[allow(dead_code)]
    pub(crate) fn cache(mut self, entries: usize) -> Self {
        self.cache = entries.max(1);
        self
    }

    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn max_steps(mut self, steps: usize) -> Self {
        self.max_steps = steps;
        self
    }

    // Run-control for the transient's and reliability's front ends, not wired yet.
    #[allow(dead_code)]
    pub(crate) fn cancel(mut self, cancel: Cancel) -> Self {
        self.cancel = Some(cancel);
        self
    }

    fn check(&self, y0: &[f64], t0: f64, times: &[f64]) -> Result<(), StepError> {
        let setting = |setting, value: String, expected| StepError::Setting {
            setting,
            value,
            expected,
        };
        let Tolerance { relative, absolute } = self.tolerance;
        let fine = |u: f64| u.is_finite() && u >= 0.0;
        if !(fine(relative) && fine(absolute) && relative + absolute > 0.0) {
            return Err(setting(
                "tolerance",
                format!("{relative:e} relative, {absolute:e} absolute"),
                "finite, non-negative, not both zero",
            ));
        }
        if !(self.weight.is_finite() && self.weight > 0.0) {
            return Err(setting(
                "weight",
                format!("{}", self.weight),
                "finite, positive",
            ));
        }
        if y0.len() != self.generator.dim() || y0.iter().any(|y| !y.is_finite()) {
            return Err(setting(
                "initial",
                format!("{} values", y0.len()),
                "one finite value per unknown",
            ));
        }
        let ordered = t0.is_finite()
            && times.iter().all(|t| t.is_finite())
            && times.first().is_none_or(|&t| t >= t0)
            && times.windows(2).all(|w| w[0] <= w[1]);
        if !ordered {
            return Err(setting(
                "times",
                format!("{times:?} from {t0}"),
                "finite, non-decreasing, none before the start",
            ));
        }
        if self.conserve {
            let a = self.generator.at(t0)?;
            let mut worst = (0.0f64, 0.0f64);
            for c in 0..a.ncols() {
                let column = a.val_of_col(c);
                let sum: f64 = column.iter().sum();
                let big = column.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                worst = (worst.0.max(sum.abs()), worst.1.max(big));
            }
            if worst.0.is_nan() || worst.0 > 1e-12 * worst.1 {
                return Err(setting(
                    "conserve_mass",
                    format!(
                        "a column sum of {:e} (largest entry {:e})",
                        worst.0, worst.1
                    ),
                    "a generator whose columns sum to zero",
                ));
            }
        }
        if let Some(h) = self.first_step {
            if !(h.is_finite() && h > 0.0) {
                return Err(setting("first_step", format!("{h}"), "finite, positive"));
            }
        }
        Ok(())
    }

    fn norm(&self, u: &[f64]) -> f64 {
        self.weight * u.iter().map(|v| v.abs()).sum::<f64>()
    }

    fn output(&self, t: f64, y: Vec<f64>) -> Output {
        let mass = self.weight * y.iter().sum::<f64>();
        let negative_mass = self.weight * y.iter().filter(|v| **v < 0.0).map(|v| -v).sum::<f64>();
        Output {
            t,
            y,
            mass,
            negative_mass,
        }
    }

    /// A first step whose leading error term, about h^q‖A^q y₀‖/(2q!) for an estimate of
    /// order q (per unit time h^(q−1)‖A^q y₀‖/(2q!)), is half the tolerance.
    fn initial_step(&self, t0: f64, y0: &[f64], span: f64) -> Result<f64, StepError> {
        let q = self.scheme.tableau().estimate_order;
        let a = self.generator.at(t0)?;
        let (mut u, mut v) = (y0.to_vec(), vec![0.0; y0.len()]);
        for _ in 0..q {
            apply(&a, &u, &mut v);
            std::mem::swap(&mut u, &mut v);
        }
        let scale = self.tolerance.absolute + self.tolerance.relative * self.norm(y0);
        let factorial: f64 = (1..=q).map(f64::from).product();
        let top = self.norm(&u);
        Ok(if top > 0.0 && top.is_finite() {
            let ratio = factorial * scale / top;
            if self.per_unit_time {
                ratio.powf(1.0 / f64::from(q - 1)).min(span)
            } else {
                ratio.powf(1.0 / f64::from(q)).min(span)
            }
        } else {
            span
        })
    }

    /// Integrates from (`t0`, `y0`) and returns y at each of `times`.
    pub(crate) fn run(&self, y0: &[f64], t0: f64, times: &[f64]) -> Result<History, StepError> {
        self.check(y0, t0, times)?;
        let n = y0.len();
        let end = times.last().copied().unwrap_or(t0);
        let span = end - t0;
        let mut outputs = Vec::with_capacity(times.len());
        let mut next = 0;
        while next < times.len() && times[next] == t0 {
            outputs.push(self.output(t0, y0.to_vec()));
            next += 1;
        }
        let mut stats = Stats::default();
        if next == times.len() {
            return Ok(History { outputs, stats });
        }
        let mut cache: Vec<Entry> = Vec::new();
        let mut sizes: Vec<u64> = Vec::new();
        let base = match self.first_step {
            Some(h) => h,
            None => aligned(self.initial_step(t0, y0, span)?, t0, times),
        };
        // Steps are base·2^level, none longer than the span.
        let mut level: i32 = 0;
        let longest = (span / base).log2().floor() as i32;
        let min_step = 1e-12 * span.max(t0.abs());
        let (mut t, mut y) = (t0, y0.to_vec());
        let mut f = vec![0.0; n];
        apply(&*self.generator.at(t0)?, &y, &mut f);
        let tableau = self.scheme.tableau();
        let mut work = Work::new(n, tableau.c.len());
        // The estimate is O(h^q): per step, or O(h^(q−1)) per unit time.
        let q = f64::from(tableau.estimate_order);
        let exponent = if self.per_unit_time {
            -1.0 / (q - 1.0)
        } else {
            -1.0 / q
        };
        // A time-invariant A gives y″ = A²y, and with it the quintic Hermite outputs whose
        // error is controlled (`Dense`, `DENSE_FLOOR`); otherwise no step is longer than the interval
        // between the outputs it serves, which are then cubic Hermite: over a longer step
        // the cubic's error outgrows the controlled step's (measured with ESDIRK4 on a first
        // passage: R(t) 3.7e-3 off at tolerance 1e-4 over steps of ~10 outputs).
        let invariant = (!self.fixed && self.generator.time_invariant())
            .then(|| self.generator.at(t0))
            .transpose()?;
        let mut dense = invariant.as_deref().map(|a| Dense::new(a, &f));
        while next < times.len() {
            if stats.accepted + stats.rejected >= self.max_steps {
                return Err(StepError::TooManySteps {
                    time: t,
                    steps: stats.accepted + stats.rejected,
                });
            }
            if self.cancel.as_ref().is_some_and(Cancel::is_cancelled) {
                return Err(StepError::Cancelled { time: t });
            }
            if dense.is_none() {
                let previous = if next == 0 { t0 } else { times[next - 1] };
                let gap = times[next] - previous;
                if gap > 0.0 {
                    // (Evenly spaced outputs' gaps differ in the last bits.)
                    level = level.min(((gap / base).log2() + 1e-9).floor() as i32);
                }
            }
            let h = base * 2f64.powi(level);
            if h < min_step {
                return Err(StepError::StepSizeTooSmall {
                    time: t,
                    step: h,
                    min: min_step,
                });
            }
            if !sizes.contains(&h.to_bits()) {
                sizes.push(h.to_bits());
            }
            self.step(&mut cache, &mut stats, t, h, &y, &f, &mut work)?;
            let scale = self.tolerance.absolute
                + self.tolerance.relative * self.norm(&y).max(self.norm(&work.y1));
            let per = if self.per_unit_time { h * scale } else { scale };
            let err = self.norm(&work.est) / per;
            // The dense output's error against the step's own, where an output falls inside
            // this step (it decides acceptance) or may fall inside the next (it limits the
            // growth).
            let ahead = |span: f64| times[next] < t + span * h;
            let interpolation = match (&mut dense, invariant.as_deref()) {
                (Some(d), Some(a)) if ahead(4.0) => {
                    apply(a, work.f1(), &mut d.g1);
                    let ends = Ends {
                        y: &y,
                        f: &f,
                        y1: &work.y1,
                        f1: work.f1(),
                    };
                    // As a multiple of the step's own estimated error (floored).
                    Some(self.weight * d.error(h, ends) / (per * err.max(DENSE_FLOOR)))
                }
                _ => None,
            };
            let inside = interpolation.filter(|_| ahead(1.0)).unwrap_or(0.0);
            let finite =
                err.is_finite() && inside.is_finite() && work.y1.iter().all(|v| v.is_finite());
            // The step size the two errors allow, as a factor of h. Above the floor the dense
            // output's ratio to the step's error grows about as h (measured ×2.5 and ×3.9
            // per doubling on case 1 from t = 11 to 19); below it, it is an error against a
            // fixed allowance, O(h⁴) per unit time (O(h⁵) per step: the slower growth taken).
            let allowed = |err: f64, interpolation: f64| {
                let step = SAFETY * err.max(1e-10).powf(exponent);
                let power = if err < DENSE_FLOOR { -0.25 } else { -1.0 };
                step.min(SAFETY * interpolation.max(1e-10).powf(power))
            };
            if self.fixed || (finite && err <= 1.0 && inside <= 1.0) {
                stats.accepted += 1;
                while next < times.len() && times[next] <= t + h {
                    let s = (times[next] - t) / h;
                    let value = match &dense {
                        Some(d) => {
                            let ends = Ends {
                                y: &y,
                                f: &f,
                                y1: &work.y1,
                                f1: work.f1(),
                            };
                            d.value(s, h, ends)
                        }
                        None => hermite(s, h, &y, &f, &work.y1, work.f1()),
                    };
                    outputs.push(self.output(times[next], value));
                    next += 1;
                }
                t += h;
                std::mem::swap(&mut y, &mut work.y1);
                // f₁ becomes f; the old f fills the last stage's slot, rewritten next step.
                std::mem::swap(&mut f, work.f.last_mut().expect("an implicit stage"));
                if let (Some(d), Some(a)) = (&mut dense, invariant.as_deref()) {
                    if interpolation.is_some() {
                        std::mem::swap(&mut d.g, &mut d.g1);
                    } else {
                        apply(a, &f, &mut d.g);
                    }
                }
                if !self.fixed {
                    // Grow only when the error allows twice the step (h stays on its level,
                    // and its factorisation in the cache, as long as it can).
                    let proposal = allowed(err, interpolation.unwrap_or(0.0));
                    let up = proposal.log2().floor().clamp(0.0, 2.0) as i32;
                    level = (level + up).min(longest.max(level));
                }
            } else {
                stats.rejected += 1;
                let proposal = if finite { allowed(err, inside) } else { 0.25 };
                let down = (-proposal.log2()).ceil().clamp(1.0, 10.0) as i32;
                level -= down;
            }
        }
        stats.step_sizes = sizes.len();
        Ok(History { outputs, stats })
    }

    /// One step of size `h` from (`t`, `y`): y₁ and the filtered error estimate.
    #[cfg(test)]
    pub(crate) fn one_step(&self, t: f64, h: f64, y: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let mut f = vec![0.0; y.len()];
        apply(&self.generator.at(t).expect("a test operator"), y, &mut f);
        let mut work = Work::new(y.len(), self.scheme.tableau().c.len());
        let (mut cache, mut stats) = (Vec::new(), Stats::default());
        self.step(&mut cache, &mut stats, t, h, y, &f, &mut work)
            .expect("a test step solves");
        (work.y1, work.est)
    }

    /// One step of size `h` from (`t`, `y`, `f` = A(t) y): the stages, y₁ and f₁ = A(t + h) y₁,
    /// and the embedded error estimate filtered by (I − γ h A(t + h))⁻¹, into `work`.
    #[allow(clippy::too_many_arguments)]
    fn step(
        &self,
        cache: &mut Vec<Entry>,
        stats: &mut Stats,
        t: f64,
        h: f64,
        y: &[f64],
        f: &[f64],
        work: &mut Work,
    ) -> Result<(), StepError> {
        let tableau = self.scheme.tableau();
        let Work { y1, f: stages, est } = work;
        implicit_stages(
            self.scheme,
            (t, h),
            (y, f),
            y1,
            stages,
            |_, at, b| self.solve(cache, stats, h, at, b),
            |_, at, y, out| {
                apply(&*self.generator.at(at)?, y, out);
                Ok(())
            },
        )?;
        // The embedded estimate, filtered by (I − γ h A(t+h))⁻¹.
        let (e0, e) = tableau.error.split_first().expect("stages");
        for (k, o) in est.iter_mut().enumerate() {
            let sum = stages
                .iter()
                .zip(e)
                .fold(e0 * f[k], |acc, (g, w)| acc + w * g[k]);
            *o = h * sum;
        }
        self.solve(cache, stats, h, t + h, est)
    }

    /// Solves (I − γ h A(t)) x = `b` in place, factorising the matrix unless cached (or,
    /// with [`Esdirk::reuse_across_times`], iterating with another time's factor).
    fn solve(
        &self,
        cache: &mut Vec<Entry>,
        stats: &mut Stats,
        h: f64,
        t: f64,
        b: &mut [f64],
    ) -> Result<(), StepError> {
        let invariant = self.generator.time_invariant();
        let across = self.across_times && !invariant;
        let key = (
            h.to_bits(),
            if invariant || across { 0 } else { t.to_bits() },
        );
        let clock = stats.accepted + stats.rejected;
        let failed = |detail: String| StepError::Factorization {
            time: t,
            step: h,
            detail,
        };
        let gamma_h = self.scheme.tableau().gamma * h;
        let mut fresh = None;
        let at = match cache.iter().position(|e| e.key == key) {
            Some(at) if across && cache[at].at != t.to_bits() => {
                let matrix = shifted(&*self.generator.at(t)?, gamma_h);
                let entry = &mut cache[at];
                entry.used = clock;
                let iterated = (entry.sweeps < REFACTOR_SWEEPS)
                    .then(|| match &entry.factor {
                        Stage::Pattern(lu) => {
                            lu.preconditioned_solve(matrix.as_ref(), b, CHECK.limit, MAX_SWEEPS)
                        }
                        Stage::Faer(lu) => {
                            lu.preconditioned_solve(matrix.as_ref(), b, CHECK.limit, MAX_SWEEPS)
                        }
                    })
                    .flatten();
                if let Some((x, sweeps)) = iterated {
                    // A solve of another time's matrix needs one correction at least (the
                    // matrices differ); only those beyond it count against the factor.
                    entry.sweeps += sweeps.saturating_sub(1);
                    stats.sweeps += sweeps;
                    self.put_back(b, &x);
                    return Ok(());
                }
                // The factor is replaced by this time's (its analysis and memory reused).
                fresh = Some((matrix, Some(cache.swap_remove(at))));
                None
            }
            Some(at) => Some(at),
            None => None,
        };
        let at = match at {
            Some(at) => at,
            None => {
                let (matrix, evicted) = match fresh {
                    Some(replaced) => replaced,
                    None => {
                        let matrix = shifted(&*self.generator.at(t)?, gamma_h);
                        // The entry this one replaces, whose memory the new factors may reuse.
                        let evicted = (cache.len() >= self.cache).then(|| {
                            let oldest =
                                (0..cache.len()).min_by_key(|&k| cache[k].used).unwrap_or(0);
                            cache.swap_remove(oldest)
                        });
                        (matrix, evicted)
                    }
                };
                let factor = self
                    .factor(&matrix, cache, evicted)
                    .map_err(|e| failed(e.to_string()))?;
                stats.factorizations += 1;
                cache.push(Entry {
                    key,
                    matrix,
                    factor,
                    used: clock,
                    at: t.to_bits(),
                    sweeps: 0,
                });
                cache.len() - 1
            }
        };
        let entry = &mut cache[at];
        entry.used = clock;
        let a = entry.matrix.as_ref();
        let x = match &entry.factor {
            Stage::Pattern(lu) => lu.checked_solve(a, b, CHECK),
            Stage::Faer(lu) => lu.checked_solve(a, b, CHECK),
        }
        .or_else(|e| match &entry.factor {
            // A pattern LU that fails on this right-hand side is replaced by faer's.
            Stage::Pattern(_) => {
                let lu = FaerLu::factor(a, Ordering::Colamd, memory_limit_bytes())?;
                let x = lu.checked_solve(a, b, CHECK);
                entry.factor = Stage::Faer(Box::new(lu));
                x.map_err(|faer| FactorError::Faer(format!("{e}; faer's LU: {faer}")))
            }
            Stage::Faer(_) => Err(e),
        })
        .map_err(|e| failed(e.to_string()))?;
        self.put_back(b, &x);
        Ok(())
    }

    /// `b` ← `x`, the solution of a stage solve with right-hand side `b`; with
    /// [`Esdirk::conserve_mass`], the mass defect its residual leaves put back.
    fn put_back(&self, b: &mut [f64], x: &[f64]) {
        let defect = b.iter().sum::<f64>() - x.iter().sum::<f64>();
        b.copy_from_slice(x);
        if self.conserve && defect != 0.0 {
            let total: f64 = b.iter().map(|v| v.abs()).sum();
            if total > 0.0 {
                b.iter_mut().for_each(|v| *v += defect * v.abs() / total);
            }
        }
    }

    /// Factorises the stage matrix `m`: the pattern LU in the given order (its symbolic
    /// analysis taken from a cached pattern LU of a matrix of the same pattern: a
    /// time-dependent generator's stage matrices share one pattern, and the analysis was a
    /// tenth of each factorisation at 80x80 cells), faer's LU where that fails.
    /// `evicted`, the entry dropped to make room, lends its analysis and its memory when its
    /// pattern is the same.
    fn factor(
        &self,
        m: &SparseColMat<usize, f64>,
        cache: &[Entry],
        evicted: Option<Entry>,
    ) -> Result<Stage, FactorError> {
        let limit = memory_limit_bytes();
        let faer = || {
            FaerLu::factor(m.as_ref(), Ordering::Colamd, limit).map(|lu| Stage::Faer(Box::new(lu)))
        };
        let Some(order) = &self.order else {
            return faer();
        };
        let spare = evicted.and_then(|e| match e.factor {
            Stage::Pattern(lu) if same_pattern(&e.matrix, m) => Some(lu),
            _ => None,
        });
        // A cached factor of the same pattern lends its analysis when no spare does.
        let analysed = || {
            cache.iter().find_map(|e| match &e.factor {
                Stage::Pattern(lu) if same_pattern(&e.matrix, m) => Some(lu),
                _ => None,
            })
        };
        let pattern = match spare {
            Some(spare) => spare.refactor_into(m.as_ref(), limit),
            None => match analysed() {
                Some(lu) => lu.refactor(m.as_ref(), limit),
                None => PatternLu::factor(m.as_ref(), order.clone(), limit),
            },
        };
        match pattern {
            Ok(lu) => Ok(Stage::Pattern(lu)),
            Err(e @ FactorError::TooLarge { .. }) => Err(e),
            Err(_) => faer(),
        }
    }
}

/// The implicit stages of one step of `scheme` of length h from (t, y, f = A(t) y): stage
/// i + 1 solves (I − γ h A(t + cᵢ₊₁ h)) Y = y + h Σⱼ aᵢⱼ fⱼ by `solve(i, time, b)` (b in, Y
/// out) and stores A Y in `stages[i]` by `derivative(i, time, Y, out)`; `y1` ends as the
/// last stage, the step's result (the methods are stiffly accurate), and the last of
/// `stages` as f₁ = A(t + h) y₁. The stepper and the periodic state's fixed lattice both
/// step with it, each with its own way of solving a stage.
pub(crate) fn implicit_stages(
    scheme: Scheme,
    (t, h): (f64, f64),
    (y, f): (&[f64], &[f64]),
    y1: &mut [f64],
    stages: &mut [Vec<f64>],
    mut solve: impl FnMut(usize, f64, &mut [f64]) -> Result<(), StepError>,
    mut derivative: impl FnMut(usize, f64, &[f64], &mut [f64]) -> Result<(), StepError>,
) -> Result<(), StepError> {
    let tableau = scheme.tableau();
    for (i, row) in tableau.a.iter().enumerate() {
        // Stage i + 1: (I − γ h A(t + c h)) Y = y + h Σ_j a_j f_j.
        let (done, rest) = stages.split_at_mut(i);
        for (k, o) in y1.iter_mut().enumerate() {
            let explicit = done
                .iter()
                .zip(&row[1..])
                .fold(row[0] * f[k], |acc, (g, a)| acc + a * g[k]);
            *o = y[k] + h * explicit;
        }
        let at = t + tableau.c[i + 1] * h;
        solve(i, at, y1)?;
        derivative(i, at, y1, &mut rest[0])?;
    }
    Ok(())
}

/// The first step `h` shortened to the first output interval over a power of two, so that
/// the steps (base·2^level) can fill evenly spaced outputs' intervals exactly: a step no
/// longer than the interval (the cap in [`Esdirk::run`] for an A that depends on t) is then
/// the whole interval rather than the largest power-of-two fraction of it below, which may
/// be barely over half; with dense outputs, short steps end on outputs.
fn aligned(h: f64, t0: f64, times: &[f64]) -> f64 {
    let mut previous = t0;
    let first = times.iter().find_map(|&t| {
        let gap = t - previous;
        previous = t;
        (gap > 0.0).then_some(gap)
    });
    match first {
        Some(gap) if h.is_finite() && h > 0.0 => {
            let halvings = (gap / h).log2().ceil().max(0.0);
            gap / 2f64.powf(halvings)
        }
        _ => h,
    }
}

/// Whether two matrices have the same compressed-column pattern.
fn same_pattern(a: &SparseColMat<usize, f64>, b: &SparseColMat<usize, f64>) -> bool {
    let (a, b) = (a.symbolic(), b.symbolic());
    a.ncols() == b.ncols() && a.col_ptr() == b.col_ptr() && a.row_idx() == b.row_idx()
}

/// The cubic Hermite interpolant at fraction `s` of the step of length `h` from (y, f) to
/// (y₁, f₁).
fn hermite(s: f64, h: f64, y: &[f64], f: &[f64], y1: &[f64], f1: &[f64]) -> Vec<f64> {
    let (s2, s3) = (s * s, s * s * s);
    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
    let h10 = (s3 - 2.0 * s2 + s) * h;
    let h01 = -2.0 * s3 + 3.0 * s2;
    let h11 = (s3 - s2) * h;
    (0..y.len())
        .map(|k| h00 * y[k] + h10 * f[k] + h01 * y1[k] + h11 * f1[k])
        .collect()
}

/// Quintic Hermite outputs on a step of a time-invariant A, from the values y, the
/// derivatives f = Ay and the second derivatives g = A²y at both ends: sixth order, its
/// error s³(1 − s)³h⁶y⁽⁶⁾/720 at fraction s of the step.
///
/// In s, the quintic is the cubic Hermite interpolant of y and f plus
/// s²(1 − s)²((1 − s)α + sβ), with α and β fixed by g at the two ends: α = h⁴y⁗/24 +
/// h⁵y⁽⁵⁾/60 + …, β = h⁴y⁗/24 + h⁵y⁽⁵⁾/40 + …. Either quartic (g at one end only) is
/// the quintic minus s³(1 − s)²(β − α) or s²(1 − s)³(α − β), so the quintic's distance from
/// them, at most [`QUARTIC_GAP`]·‖β − α‖ = 2.9e−4·h⁵‖y⁽⁵⁾‖ over the step, estimates the
/// quartics' error and bounds the quintic's (at most 2.2e−5·h⁶‖y⁽⁶⁾‖) while the step
/// resolves the solution's variation (h‖y⁽⁶⁾‖ < 13‖y⁽⁵⁾‖), as the embedded estimate bounds the
/// step's. The estimate also sees a g spoiled by stiff components of y that A² amplifies
/// (they differ between the two ends: the L-stable step damps them). It does not overstate
/// the quintic's error where it limits the steps: the quintic's distance from the septic
/// (A³y at both ends too), its own leading error term, read 1.35 times this estimate on
/// case 1 at 100x200 from t = 5 to 29, steps of 0.5.
struct Dense {
    /// A²y at the step's start.
    g: Vec<f64>,
    /// A²y₁ at its end.
    g1: Vec<f64>,
}

/// max over s of s³(1 − s)² (at s = 3/5).
const QUARTIC_GAP: f64 = 108.0 / 3125.0;

impl Dense {
    fn new(a: &SparseColMat<usize, f64>, f: &[f64]) -> Dense {
        let mut g = vec![0.0; f.len()];
        apply(a, f, &mut g);
        Dense {
            g1: vec![0.0; f.len()],
            g,
        }
    }

    /// α and β of component k (see [`Dense`]): half the misfit of the cubic's second
    /// derivative in s at either end.
    fn coefficients(&self, k: usize, h: f64, ends: Ends<'_>) -> (f64, f64) {
        let Ends { y, f, y1, f1 } = ends;
        let (hh, dy) = (h * h, y1[k] - y[k]);
        let alpha = 0.5 * (hh * self.g[k] - 6.0 * dy + h * (4.0 * f[k] + 2.0 * f1[k]));
        let beta = 0.5 * (hh * self.g1[k] + 6.0 * dy - h * (2.0 * f[k] + 4.0 * f1[k]));
        (alpha, beta)
    }

    /// The estimate [`QUARTIC_GAP`]·Σₖ|βₖ − αₖ| of the quintic's error over the step
    /// (unweighted L1).
    fn error(&self, h: f64, ends: Ends<'_>) -> f64 {
        let gap: f64 = (0..ends.y.len())
            .map(|k| {
                let (alpha, beta) = self.coefficients(k, h, ends);
                (beta - alpha).abs()
            })
            .sum();
        QUARTIC_GAP * gap
    }

    /// The quintic at fraction `s` of the step of length `h`.
    fn value(&self, s: f64, h: f64, ends: Ends<'_>) -> Vec<f64> {
        let bubble = s * s * (1.0 - s) * (1.0 - s);
        let mut value = hermite(s, h, ends.y, ends.f, ends.y1, ends.f1);
        for (k, v) in value.iter_mut().enumerate() {
            let (alpha, beta) = self.coefficients(k, h, ends);
            *v += bubble * ((1.0 - s) * alpha + s * beta);
        }
        value
    }
}

/// The values and derivatives at both ends of a step.
#[derive(Clone, Copy)]
struct Ends<'a> {
    y: &'a [f64],
    f: &'a [f64],
    y1: &'a [f64],
    f1: &'a [f64],
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::Triplet;

    /// The quintic on exact ends of x' = v, v' = −4x − 0.4v (y = e^{At}y₀) over steps of
    /// 0.4 to 0.05: its worst error at 99 points of the step is below the estimate (by 9 to
    /// 97 times), which falls about as h⁵ (measured 24 to 33 per halving) while the error
    /// falls about as h⁶ (58 to 63).
    #[test]
    fn the_quintic_is_within_its_estimate() {
        let t = [
            Triplet::new(0usize, 1usize, 1.0),
            Triplet::new(1, 0, -4.0),
            Triplet::new(1, 1, -0.4),
        ];
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(2, 2, &t).unwrap();
        // exp(At)(1, 0), ζω = 0.2, ω_d = √3.96.
        let exact = |t: f64| {
            let wd = 3.96f64.sqrt();
            let (c, s, e) = ((wd * t).cos(), (wd * t).sin(), (-0.2 * t).exp());
            vec![e * (c + 0.2 / wd * s), e * (-4.0 / wd * s)]
        };
        let derivative = |y: &[f64]| {
            let mut f = vec![0.0; 2];
            apply(&a, y, &mut f);
            f
        };
        let (mut last_estimate, mut last_error) = (f64::NAN, f64::NAN);
        for h in [0.4, 0.2, 0.1, 0.05] {
            let t0 = 0.3;
            let (y, y1) = (exact(t0), exact(t0 + h));
            let (f, f1) = (derivative(&y), derivative(&y1));
            let mut dense = Dense::new(&a, &f);
            apply(&a, &f1, &mut dense.g1);
            let ends = Ends {
                y: &y,
                f: &f,
                y1: &y1,
                f1: &f1,
            };
            let estimate = dense.error(h, ends);
            let error = (1..100)
                .map(|k| {
                    let s = k as f64 / 100.0;
                    let value = dense.value(s, h, ends);
                    let truth = exact(t0 + s * h);
                    (value[0] - truth[0]).abs() + (value[1] - truth[1]).abs()
                })
                .fold(0.0f64, f64::max);
            assert!(
                error < estimate,
                "h {h}: error {error:e} > estimate {estimate:e}"
            );
            if last_estimate.is_finite() {
                let ratio = last_estimate / estimate;
                assert!(
                    (20.0..45.0).contains(&ratio),
                    "h {h}: estimate ratio {ratio}"
                );
                assert!(
                    last_error / error > 40.0,
                    "h {h}: {last_error:e} → {error:e}"
                );
            }
            (last_estimate, last_error) = (estimate, error);
        }
    }

    /// The lightly damped oscillator over 0..10 with 401 outputs: the steps grow past the
    /// outputs' spacing at tolerances 1e−4 and 1e−6 (each step serves several outputs), and
    /// the worst output's error is within 10 × tol (the tolerance times the time elapsed)
    /// and within twice the worst of runs that end at t = 2, 5, 10 without interpolating:
    /// the interpolant adds little to the steps' own error.
    #[test]
    fn dense_outputs_meet_the_tolerance() {
        let t = [
            Triplet::new(0usize, 1usize, 1.0),
            Triplet::new(1, 0, -4.0),
            Triplet::new(1, 1, -0.4),
        ];
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(2, 2, &t).unwrap();
        let error = |o: &Output| {
            let wd = 3.96f64.sqrt();
            let (c, s, e) = ((wd * o.t).cos(), (wd * o.t).sin(), (-0.2 * o.t).exp());
            (o.y[0] - e * (c + 0.2 / wd * s)).abs() + (o.y[1] + e * 4.0 / wd * s).abs()
        };
        let times: Vec<f64> = (0..=400).map(|k| 0.025 * k as f64).collect();
        for tol in [1e-4, 1e-6, 1e-8] {
            let run = |times: &[f64]| {
                Esdirk::new(&a)
                    .scheme(Scheme::Esdirk4)
                    .tolerance(Tolerance {
                        relative: tol,
                        absolute: tol,
                    })
                    .run(&[1.0, 0.0], 0.0, times)
                    .unwrap()
            };
            let dense = run(&times);
            let worst = dense.outputs.iter().map(error).fold(0.0f64, f64::max);
            let ends = [2.0, 5.0, 10.0]
                .iter()
                .map(|&end| error(&run(&[end]).outputs[0]))
                .fold(0.0f64, f64::max);
            assert!(worst < 10.0 * tol, "tol {tol:e}: error {worst:e}");
            assert!(worst < 2.0 * ends, "tol {tol:e}: {worst:e} vs {ends:e}");
            assert!(
                tol < 1e-7 || dense.stats.accepted < times.len() / 2,
                "tol {tol:e}: {:?}",
                dense.stats
            );
        }
    }
}
