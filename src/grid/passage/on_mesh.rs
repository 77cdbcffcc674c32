//! The solve on one count of cells, in two phases: [`GridPassage::backward_at`] (the
//! stationary density on the set, the killed generator, its factorisation, the mean times T
//! and T₂), then [`Backward::finish`] (R(t) by the forward run and the slowest decay). Output
//! times set by the mean time from the start ([`GridPassage::times_in_means`]) are known
//! after the first phase, so the mean times are solved once.
//!
//! Within each phase the parts that share no data run side by side (two cores: the
//! stationary solve beside the factorisation and the backward solves; the decay's inverse
//! iterations beside the forward run); each part computes what it would alone, so the
//! numbers do not depend on the threads.

use std::time::Instant;

use super::killed::{self, Killed};
use super::{
    align, apply, bilinear, cell_of, decay, hermite_integral, DecayOutcome, GridPassage,
    PassageError, PassageReport, PassageSolution, CHECK, MIN_SAFE_MASS,
};
use crate::base::limits::memory_limit_bytes;
use crate::grid::assemble::assemble;
use crate::grid::domain;
use crate::grid::mesh::Mesh;
use crate::grid::nested::{cell_coords, nested_dissection};
use crate::grid::problem::Mechanical;
use crate::grid::Domain;
use crate::numerics::sparse::faer_lu::{FaerLu, Ordering};
use crate::numerics::sparse::Factorization;
use crate::numerics::timestep::{Esdirk, Scheme, Tolerance};

/// The first phase's results on one mesh: what the forward run and the decay start from.
pub(super) struct Backward {
    started: Instant,
    mesh: Mesh,
    /// Cells inside the set.
    safe_cells: usize,
    /// The stationary density restricted to the set (zero outside) and the set's mass.
    law: Option<(Vec<f64>, f64)>,
    k: Killed,
    lu: FaerLu,
    /// T and T₂ on the safe cells.
    t1: Vec<f64>,
    t2: Vec<f64>,
    /// The start's safe cell.
    start_safe: usize,
}

impl GridPassage<'_> {
    /// The first phase on `cells` of `problem` in `box_` (aligned here to the cells),
    /// settings checked; the stationary density when the model has a `stationary` one.
    pub(super) fn backward_at(
        &self,
        problem: &Mechanical,
        box_: Domain,
        cells: [usize; 2],
        stationary: bool,
    ) -> Result<Backward, PassageError> {
        let started = Instant::now();
        let [nx, nv] = cells;
        let box_ = align::aligned(box_, nx, problem, self.safe, self.model);
        let mesh = Mesh::new(box_, nx, nv, &problem.barriers, align::MESH_ALIGN);
        let d = mesh.domain();
        let [x, v] = self.start;
        if !(d.x[0] <= x && x <= d.x[1] && d.v[0] <= v && v <= d.v[1]) {
            return Err(PassageError::StartOutsideBox { x, v, domain: d });
        }
        let n = mesh.cells();
        let safe: Vec<bool> = (0..n)
            .map(|c| {
                let (i, j) = (c / nv, c % nv);
                self.safe.contains([mesh.xc(i), mesh.vc(j)])
            })
            .collect();
        let area = mesh.hx * mesh.hv;
        let safe_cells = safe.iter().filter(|s| **s).count();
        if !stationary {
            self.bounded(&mesh, &safe)?;
        }
        // One operator for the stationary solve and the killed generator.
        let op = assemble(&mesh, problem)?;
        let singular = |detail: String| PassageError::Singular { nx, nv, detail };
        // The stationary density on the same cells restricted to the set, and the set's
        // mass, beside the backward solves.
        let (law, backward) = rayon::join(
            || {
                stationary.then(|| {
                    let guess = [0.5 * (d.x[0] + d.x[1]), 0.0];
                    let p = domain::solve_pinned_op(&mesh, &op, guess);
                    crate::base::timeline::mark("passage: stationary solved");
                    p
                })
            },
            || -> Result<_, PassageError> {
                let k = killed::killed(&mesh, problem, &op, &safe)?;
                let m = k.cells.len();
                let lu =
                    FaerLu::factor(k.backward.as_ref(), Ordering::Colamd, memory_limit_bytes())
                        .map_err(|e| singular(e.to_string()))?;
                let t1 = lu
                    .checked_solve(k.backward.as_ref(), &vec![-1.0; m], CHECK)
                    .map_err(|e| singular(e.to_string()))?;
                let rhs: Vec<f64> = t1.iter().map(|t| -2.0 * t).collect();
                let t2 = lu
                    .checked_solve(k.backward.as_ref(), &rhs, CHECK)
                    .map_err(|e| singular(e.to_string()))?;
                crate::base::timeline::mark("passage: mean times solved");
                Ok((k, lu, t1, t2))
            },
        );
        // The stationary solve's failures first, as when it ran before the backward solves.
        let law = match law.transpose()? {
            None => None,
            Some(p) => {
                let inside: Vec<f64> = (0..n)
                    .map(|c| if safe[c] { p[c].max(0.0) } else { 0.0 })
                    .collect();
                let mass = inside.iter().sum::<f64>() * area;
                if mass.is_nan() || mass < MIN_SAFE_MASS || safe_cells == 0 {
                    return Err(PassageError::NoProbability {
                        safe: self.safe.text.clone(),
                        mass,
                        cells: safe_cells,
                    });
                }
                Some((inside, mass))
            }
        };
        let (k, lu, t1, t2) = backward?;
        let start_safe = k.index[cell_of(&mesh, self.start)];
        if start_safe == usize::MAX {
            // The start is inside the set but its cell's centre is not: the cells do not
            // resolve the set near the start.
            return Err(PassageError::StartOutside {
                x,
                v,
                safe: format!("{} (on the grid's cells)", self.safe.text),
            });
        }
        Ok(Backward {
            started,
            mesh,
            safe_cells,
            law,
            k,
            lu,
            t1,
            t2,
            start_safe,
        })
    }
}

/// Values `t` on the safe cells (`index`: the mesh index → safe index) on all the mesh's
/// cells, zero outside the set.
fn on_all_cells(index: &[usize], t: &[f64]) -> Vec<f64> {
    index
        .iter()
        .map(|&s| if s == usize::MAX { 0.0 } else { t[s] })
        .collect()
}

impl Backward {
    /// E[T] from `start` (bilinear between cell centres), as [`Backward::finish`] reports it.
    pub(super) fn mean_at(&self, start: [f64; 2]) -> f64 {
        bilinear(&self.mesh, &on_all_cells(&self.k.index, &self.t1), start)
    }

    /// The second phase for `passage`: R(t) at `times` and the slowest decay.
    pub(super) fn finish(
        &self,
        passage: &GridPassage<'_>,
        times: &[f64],
    ) -> Result<PassageSolution, PassageError> {
        let (mesh, k, law, t1) = (&self.mesh, &self.k, &self.law, &self.t1);
        let start_safe = self.start_safe;
        let (nx, nv) = (mesh.nx, mesh.nv);
        let area = mesh.hx * mesh.hv;
        let m = k.cells.len();
        let forward_run = || -> Result<_, PassageError> {
            if times.is_empty() {
                return Ok((Vec::new(), Vec::new(), [0; 3]));
            }
            let mut p0 = vec![0.0; m];
            p0[start_safe] = 1.0 / area;
            let coords: Vec<[u32; 2]> = {
                let all = cell_coords(nx, nv, false);
                k.cells.iter().map(|&c| all[c]).collect()
            };
            let order = nested_dissection(k.forward.symbolic(), &coords, 1);
            let run = Esdirk::new(&k.forward)
                .scheme(Scheme::Esdirk4)
                .tolerance(Tolerance {
                    relative: passage.tolerance,
                    absolute: 0.0,
                })
                .weight(area)
                .order(order)
                .run(&p0, 0.0, times)?;
            let mut ky = vec![0.0; m];
            let (mut r, mut f) = (Vec::new(), Vec::new());
            for o in &run.outputs {
                apply(&k.forward, &o.y, &mut ky);
                r.push(o.y.iter().sum::<f64>() * area);
                f.push(-ky.iter().sum::<f64>() * area);
            }
            let s = &run.stats;
            Ok((r, f, [s.accepted, s.rejected, s.factorizations]))
        };
        // The inverse iteration for the quasi-stationary density starts from the stationary
        // one in the set, else from the uniform density on it.
        let slowest = || {
            if !passage.decay {
                return None;
            }
            let density: Vec<f64> = match &law {
                Some((inside, _)) => k.cells.iter().map(|&c| inside[c]).collect(),
                None => vec![1.0; m],
            };
            Some(decay::decay(
                &self.lu,
                &k.forward,
                &k.backward,
                density,
                t1,
                start_safe,
            ))
        };
        let (forward, slowest) = rayon::join(forward_run, slowest);
        let (reliability, pdf, steps) = forward?;
        let full = |t: &[f64]| on_all_cells(&k.index, t);
        let (decay, quasi_stationary) = match slowest {
            None => (DecayOutcome::NotComputed, None),
            Some(Ok((d, phi))) => {
                // φ sums to 1 over the cells: its cell averages are φ / area.
                let p: Vec<f64> = full(&phi).iter().map(|w| w / area).collect();
                let q = [mesh.marginal(&p, 0), mesh.marginal(&p, 1)];
                (DecayOutcome::Found(d), Some(q))
            }
            Some(Err(reason)) => (DecayOutcome::NotFound { reason }, None),
        };
        let (big1, big2) = (full(t1), full(&self.t2));
        let average = |t: &[f64]| {
            law.as_ref().map(|(inside, mass)| {
                inside.iter().zip(t).map(|(p, t)| p * t).sum::<f64>() * area / mass
            })
        };
        let integral = (!times.is_empty()).then(|| hermite_integral(times, &reliability, &pdf));
        Ok(PassageSolution {
            mean_at_start: bilinear(mesh, &big1, passage.start),
            second_at_start: bilinear(mesh, &big2, passage.start),
            mean_from_start_cell: t1[start_safe],
            mean_stationary: average(&big1),
            second_stationary: average(&big2),
            safe_mass: law.as_ref().map(|(_, mass)| *mass),
            times: times.to_vec(),
            reliability,
            pdf,
            integral_of_reliability: integral,
            decay,
            quasi_stationary,
            errors: None,
            report: PassageReport {
                cells: [nx, nv],
                domain: mesh.domain(),
                safe_cells: self.safe_cells,
                start: passage.start,
                safe: passage.safe.text.clone(),
                tolerance: passage.tolerance,
                steps,
                estimate_cells: None,
                total_ms: self.started.elapsed().as_secs_f64() * 1e3,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use crate::grid::{evenly_spaced, GridPassage};
    use crate::model::{load_model, Override};

    /// Times set by the mean time are those computed from the mean time of a run without
    /// them: one solve of the mean times gives what the two did, to the bit.
    #[test]
    fn times_in_means_are_the_times_of_the_mean() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/linear.sde");
        let model = load_model(&path)
            .unwrap()
            .with_safe("abs(z) < 1.5")
            .unwrap();
        let bound = model.bind(&[Override::number("c", 1.0)]).unwrap();
        let safe = model.safe().unwrap().bind(&bound).unwrap();
        let passage = GridPassage::new(&bound, &safe).cells(40, 60);
        let mean = passage.clone().estimate(false).run().unwrap().mean_at_start;
        let times = evenly_spaced(4.0 * mean, 21).unwrap();
        let given = passage.clone().times(times.clone()).run().unwrap();
        let set = passage.times_in_means(4.0, 21).run().unwrap();
        assert_eq!(set.times, times);
        assert_eq!(set.reliability, given.reliability);
        assert_eq!(set.pdf, given.pdf);
        assert_eq!(set.errors, given.errors);
        assert_eq!(
            [set.mean_at_start, set.second_at_start],
            [given.mean_at_start, given.second_at_start]
        );
        assert_eq!(set.decay, given.decay);
    }

    #[test]
    fn evenly_spaced_ends_at_the_end() {
        assert_eq!(evenly_spaced(2.0, 3), Some(vec![0.0, 1.0, 2.0]));
        assert_eq!(evenly_spaced(f64::NAN, 3), None);
        assert_eq!(evenly_spaced(0.0, 3), None);
        assert_eq!(evenly_spaced(1.0, 1), None);
    }
}
