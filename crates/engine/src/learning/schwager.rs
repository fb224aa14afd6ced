//! Schwager's adaptive coverage law (Schwager, Rus & Slotine,
//! "Decentralized, adaptive coverage control for networked robots", IJRR
//! 28(3), 2009) over the learner's own basis, as the baseline that
//! docs/learning.md ("Against Schwager's law and a grid Lloyd") measures
//! the Bayesian learner against.
//!
//! The paper's model: Φ(q) = K(q)ᵀ a with a ≥ a_min component by
//! component; here K = (1, the [`Lattice`]'s Gaussians), the base and the
//! weights of [`crate::learning`]'s belief. The estimate â follows the
//! paper's adaptation law with its projection,
//!
//! â̇ = Γ (â_pre − I_proj â_pre), â_pre = −F â − γ (Λ â − λ),
//!
//! - Λ = ∫ w K Kᵀ and λ = ∫ w K φ along the vessels' paths (here at their
//!   samples, each weighted by the seconds it stands for, w = 1: every
//!   sample counts as long as the run lasts);
//! - F â, the coupling term of the paper's Lyapunov design: the part of
//!   the coverage metric's rate of change that the estimate's error
//!   drives, cancelled so that V = −H + ½ ãᵀ Γ⁻¹ ã cannot grow. For this
//!   engine's metric H = Σ_i ∫_{V_i} f_i Φ ([`crate::coverage::evaluate`]) that is
//!   F â = Σ_i 2β_i ∫_{V_i} f_i(q) K(q) (q − p_i)ᵀ dq ṗ_i, computed by
//!   [`Quadrature`] (for Schwager's H = Σ ∫ ½‖q − p_i‖² φ it is the
//!   paper's F_i with ṗ_i = K(Ĉ_i − p_i));
//! - I_proj stops a component that sits at a_min from going lower.
//!
//! One estimate for the whole fleet, fed every vessel's samples: the
//! paper's consensus term, ζ Σ_j l_ij (â_i − â_j), drives the vessels'
//! estimates together, and one shared estimate is its limit (ζ → ∞),
//! which a coordinator that hears every sample can hold.
//!
//! Discretization: Λ grows with every sample, so the γΛ term is stiff;
//! a step is backward Euler in it and forward Euler in the rest, then the
//! projection onto â ≥ a_min (the discrete form of I_proj):
//! (I + Γγ dt Λ) â⁺ = â + Γ dt (−F â + γ λ), â⁺ ← max(â⁺, a_min).
//!
//! Invariants: â ≥ a_min always; pure and deterministic; nothing fails
//! once [`Gains::new`] has validated the gains.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use super::{Lattice, Sample};
use crate::coverage::density::MAX_DENSITY;
use crate::coverage::grid_lloyd::owner;
use crate::coverage::{Fleet, InputError, RiskField, RiskObject, check_range};
use crate::geometry::{Point, Region, dot};

/// The law's gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// Γ (a multiple of the identity): how fast â moves.
    pub adaptation: f64,
    /// γ: the weight of the data term against the coupling.
    pub data: f64,
    /// a_min > 0: the lower bound of every coefficient.
    pub a_min: f64,
}

/// The largest Γ and γ: beyond, Γγ dt Λ may overflow.
const MAX_GAIN: f64 = 1e6;

impl Gains {
    /// Validates 0 < Γ, γ ≤ 10⁶ and 0 < a_min ≤ [`MAX_DENSITY`].
    pub fn new(adaptation: f64, data: f64, a_min: f64) -> Result<Self, InputError> {
        check_range(
            || "schwager.adaptation".into(),
            adaptation,
            0.0,
            false,
            MAX_GAIN,
        )?;
        check_range(|| "schwager.data".into(), data, 0.0, false, MAX_GAIN)?;
        check_range(|| "schwager.a_min".into(), a_min, 0.0, false, MAX_DENSITY)?;
        Ok(Gains {
            adaptation,
            data,
            a_min,
        })
    }
}

/// The estimate â and the data it has integrated.
#[derive(Debug, Clone)]
pub struct Adaptive {
    lattice: Lattice,
    gains: Gains,
    estimate: DVector<f64>,
    big_lambda: DMatrix<f64>,
    small_lambda: DVector<f64>,
    /// I + Γγ dt Λ factorized, for the dt it was made with; dropped when
    /// a sample changes Λ (samples come every few steps, steps every tick).
    factor: Option<(f64, Cholesky<f64, Dyn>)>,
}

/// Features at `q` by coefficient index: the base's 1, then the lattice's.
fn features(lattice: &Lattice, q: Point, out: &mut Vec<(usize, f64)>) {
    lattice.features(q, out);
    for (k, _) in out.iter_mut() {
        *k += 1;
    }
    out.insert(0, (0, 1.0));
}

impl Adaptive {
    /// â(0): the base at `base` (the prior's level) and every weight at
    /// a_min, each at least a_min; no data yet.
    pub fn new(lattice: Lattice, base: f64, gains: Gains) -> Self {
        let n = 1 + lattice.len();
        let mut estimate = DVector::from_element(n, gains.a_min);
        if base.is_finite() {
            estimate[0] = base.clamp(gains.a_min, MAX_DENSITY);
        }
        Adaptive {
            lattice,
            gains,
            estimate,
            big_lambda: DMatrix::zeros(n, n),
            small_lambda: DVector::zeros(n),
            factor: None,
        }
    }

    /// Integrates one sample into Λ and λ, weighted by the `seconds` it
    /// stands for (the paper's w dt); a weight that is not finite and
    /// positive is ignored.
    pub fn observe(&mut self, sample: &Sample, seconds: f64) {
        if !(seconds.is_finite() && seconds > 0.0) {
            return;
        }
        let mut f = Vec::new();
        features(&self.lattice, sample.position, &mut f);
        for &(i, fi) in &f {
            self.small_lambda[i] += seconds * fi * sample.value;
            for &(j, fj) in &f {
                self.big_lambda[(i, j)] += seconds * fi * fj;
            }
        }
        self.factor = None;
    }

    /// One step of the law over `dt` seconds with the coupling F â
    /// (`coupling`, one entry per coefficient: [`Quadrature::coupling`]).
    /// A dt that is not finite and positive, or a coupling of the wrong
    /// length, changes nothing.
    pub fn step(&mut self, coupling: &[f64], dt: f64) {
        let n = self.estimate.len();
        if !(dt.is_finite() && dt > 0.0) || coupling.len() != n {
            return;
        }
        let g = self.gains;
        let stale = self.factor.as_ref().is_none_or(|(at, _)| *at != dt);
        if stale {
            let c = g.adaptation * g.data * dt;
            let system = DMatrix::identity(n, n) + &self.big_lambda * c;
            self.factor = system.cholesky().map(|ch| (dt, ch));
        }
        // I + cΛ with Λ a sum of outer products is positive definite; only
        // a Λ overflowed to infinity could refuse, and then â stays put.
        let Some((_, chol)) = &self.factor else {
            return;
        };
        let rhs = DVector::from_iterator(
            n,
            (0..n).map(|i| {
                self.estimate[i] + g.adaptation * dt * (g.data * self.small_lambda[i] - coupling[i])
            }),
        );
        let next = chol.solve(&rhs);
        for i in 0..n {
            let v = next[i];
            self.estimate[i] = if v.is_finite() {
                v.clamp(g.a_min, MAX_DENSITY)
            } else {
                self.estimate[i]
            };
        }
    }

    /// â: the base, then the lattice's weights (all ≥ a_min).
    pub fn estimate(&self) -> &[f64] {
        self.estimate.as_slice()
    }

    /// Φ̂ = â · K as a base plus Gaussians, which the engine integrates
    /// exactly.
    pub fn density(&self) -> RiskField {
        let h = self.lattice.spacing();
        let objects = (0..self.lattice.len())
            .map(|k| RiskObject {
                center: self.lattice.center(k),
                alpha: self.estimate[k + 1],
                sigma: h,
            })
            .collect();
        RiskField::new(self.estimate[0], objects).expect("â is clamped into [a_min, MAX_DENSITY]")
    }
}

/// Quadrature points over a region, each with the basis K at it, for the
/// coupling term: the cells change every tick, the points and K do not.
#[derive(Debug, Clone)]
pub struct Quadrature {
    points: Vec<Point>,
    /// The area each point stands for [m²].
    area: f64,
    /// Point i's features are `entries[starts[i]..starts[i + 1]]`.
    starts: Vec<usize>,
    entries: Vec<(u32, f64)>,
    len: usize,
}

/// At most this many quadrature points: K at each costs ~120 entries.
const MAX_POINTS: f64 = 10_000.0;

impl Quadrature {
    /// The centres of a square grid over `region`'s box that lie in the
    /// region, of spacing a quarter of the lattice's (a Gaussian of spread
    /// h is then integrated to well under 1 %), coarser when the region
    /// would need more than 10 000 points.
    pub fn over(region: &Region, lattice: &Lattice) -> Self {
        let (min, max) = region.bounds();
        let (w, h) = (max.x - min.x, max.y - min.y);
        let step = (lattice.spacing() / 4.0).max((w * h / MAX_POINTS).sqrt());
        let (columns, rows) = ((w / step).ceil() as usize, (h / step).ceil() as usize);
        let mut points = Vec::new();
        let mut starts = vec![0];
        let mut entries = Vec::new();
        let mut f = Vec::new();
        for j in 0..rows {
            for i in 0..columns {
                let q = Point {
                    x: min.x + (i as f64 + 0.5) * step,
                    y: min.y + (j as f64 + 0.5) * step,
                };
                if !region.contains(q) {
                    continue;
                }
                features(lattice, q, &mut f);
                points.push(q);
                entries.extend(f.iter().map(|&(k, v)| (k as u32, v)));
                starts.push(entries.len());
            }
        }
        Quadrature {
            points,
            area: step * step,
            starts,
            entries,
            len: 1 + lattice.len(),
        }
    }

    /// The coupling F â = Σ_i 2β_i ∫_{V_i} f_i K (q − p_i)ᵀ dq ṗ_i into
    /// `out` (one entry per coefficient), with V_i the points where f_i is
    /// the largest (the generalized Voronoi cell; a tie goes to the first
    /// vessel) and `velocities` the vessels' ṗ_i in the fleet's order (a
    /// missing one counts as still).
    pub fn coupling(&self, fleet: &Fleet, velocities: &[Point], out: &mut Vec<f64>) {
        out.clear();
        out.resize(self.len, 0.0);
        let vessels = fleet.vessels();
        for (n, &q) in self.points.iter().enumerate() {
            let (i, log_f) = owner(fleet, q);
            let Some(&velocity) = velocities.get(i) else {
                continue;
            };
            let v = &vessels[i];
            let along = dot(q - v.position, velocity);
            let weight = 2.0 * v.beta * log_f.exp() * along * self.area;
            if weight == 0.0 {
                continue;
            }
            for &(k, value) in &self.entries[self.starts[n]..self.starts[n + 1]] {
                out[k as usize] += weight * value;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::{Options, Vessel, evaluate};

    fn p(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    fn square(side: f64) -> Region {
        let ring = vec![p(0.0, 0.0), p(side, 0.0), p(side, side), p(0.0, side)];
        Region::new(ring, vec![]).unwrap()
    }

    /// Deterministic points spread over [0, side)² (a Halton sequence).
    fn halton(n: usize, side: f64) -> Vec<Point> {
        let radical = |mut i: usize, base: usize| {
            let (mut f, mut r) = (1.0, 0.0);
            while i > 0 {
                f /= base as f64;
                r += f * (i % base) as f64;
                i /= base;
            }
            r
        };
        (1..=n)
            .map(|i| p(side * radical(i, 2), side * radical(i, 3)))
            .collect()
    }

    /// Persistent excitation (samples spread over the whole square) and
    /// no coupling: the estimate converges to the true coefficients, and
    /// never leaves â ≥ a_min on the way. Neighbouring Gaussians of the
    /// lattice overlap (0.78 of each other's peak at one spacing), so Λ's
    /// smallest eigenvalues are small and a high Γγ is what converges in
    /// 100 s.
    #[test]
    fn the_estimate_converges_to_the_true_weights() {
        let lattice = Lattice::over(p(0.0, 0.0), p(40.0, 40.0), 10.0).unwrap();
        let gains = Gains::new(1000.0, 1.0, 0.01).unwrap();
        let truth: Vec<f64> = (0..=lattice.len())
            .map(|k| 0.01 + ((k * 7919) % 13) as f64)
            .collect();
        let mut law = Adaptive::new(lattice.clone(), 0.1, gains);
        let mut f = Vec::new();
        for q in halton(800, 40.0) {
            features(&lattice, q, &mut f);
            let value = f.iter().map(|&(k, v)| v * truth[k]).sum();
            law.observe(&Sample::new(q, value, 1.0).unwrap(), 1.0);
        }
        let error = |law: &Adaptive| {
            law.estimate()
                .iter()
                .zip(&truth)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        let zero = vec![0.0; truth.len()];
        let start = error(&law);
        for _ in 0..1000 {
            law.step(&zero, 0.1);
            assert!(law.estimate().iter().all(|&a| a >= 0.01));
        }
        let end = error(&law);
        assert!(start > 5.0, "{start}");
        assert!(end < 1e-3, "from {start} to {end}");
    }

    /// Noisy samples of a field that is zero almost everywhere push
    /// coefficients below a_min; the projection holds them there.
    #[test]
    fn the_projection_keeps_every_coefficient_at_or_above_a_min() {
        let lattice = Lattice::over(p(0.0, 0.0), p(40.0, 40.0), 10.0).unwrap();
        let mut law = Adaptive::new(lattice, 0.1, Gains::new(10.0, 1.0, 0.05).unwrap());
        for (n, q) in halton(400, 40.0).into_iter().enumerate() {
            let value = if n % 2 == 0 { -1.0 } else { 0.5 };
            law.observe(&Sample::new(q, value, 1.0).unwrap(), 1.0);
        }
        let zero = vec![0.0; law.estimate().len()];
        for _ in 0..100 {
            law.step(&zero, 0.1);
        }
        assert!(law.estimate().iter().all(|&a| a >= 0.05));
        assert!(law.estimate().contains(&0.05));
        assert_eq!(law.density().objects().len(), 25);
    }

    /// The quadrature's coupling against the engine's exact integrals:
    /// for basis function k, 2β ∫_{V_i} f_i K_k (q − p_i) dq · ṗ_i is
    /// 2β M (C − p_i) · ṗ_i with M, C the mass and centroid of cell i under
    /// the density K_k alone.
    #[test]
    fn the_coupling_is_the_exact_integral_over_each_cell() {
        let region = square(100.0);
        let lattice = Lattice::over(p(0.0, 0.0), p(100.0, 100.0), 10.0).unwrap();
        let quadrature = Quadrature::over(&region, &lattice);
        assert_eq!(quadrature.points.len(), 1600);
        let vessel = |x, y, k| Vessel {
            position: p(x, y),
            k,
            beta: 0.001,
        };
        let fleet = Fleet::new(vec![vessel(30.0, 40.0, 0.5), vessel(70.0, 65.0, 0.8)]).unwrap();
        let velocities = [p(0.0, 0.0), p(1.2, -0.7)];
        let mut got = Vec::new();
        quadrature.coupling(&fleet, &velocities, &mut got);
        let exact = |risk: RiskField| {
            let cell = &evaluate(&region, &risk, &fleet, &Options::default()).cells[1];
            let p1 = fleet.vessels()[1].position;
            2.0 * 0.001 * cell.mass * dot(cell.centroid - p1, velocities[1])
        };
        let mut want = vec![exact(RiskField::new(1.0, vec![]).unwrap())];
        for k in 0..lattice.len() {
            let object = RiskObject {
                center: lattice.center(k),
                alpha: 1.0,
                sigma: 10.0,
            };
            want.push(exact(RiskField::new(0.0, vec![object]).unwrap()));
        }
        let scale = want.iter().map(|w| w.abs()).fold(0.0, f64::max);
        let worst = got
            .iter()
            .zip(&want)
            .map(|(g, w)| (g - w).abs())
            .fold(0.0, f64::max);
        assert!(scale > 1.0, "{scale}");
        assert!(worst < 0.01 * scale, "worst {worst} of {scale}");
    }
}
