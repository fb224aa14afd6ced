//! The posterior of the belief's coefficients (the model in the module
//! doc of [`crate::learning`]).

use nalgebra::{DMatrix, DVector};

use super::{Lattice, Sample};
use crate::coverage::density::MAX_DENSITY;
use crate::coverage::{InputError, RiskField, RiskObject, check_range};
use crate::geometry::Point;

/// Coefficients before the lattice's weights: the base, the prior's scale.
const FIXED: usize = 2;
/// The active set's rounds at most.
const ROUNDS: usize = 200;
/// A pinned coefficient whose gradient is below −this share of |b|'s
/// largest entry is freed again.
const SETTLED: f64 = 1e-9;
/// Lattice weights below this share of the largest are left out of the
/// density: they change no integral that matters and each costs the
/// engine a term.
const NEGLIGIBLE: f64 = 1e-6;
/// Huber's threshold: a sample whose residual is more than this many of
/// its own σ from the fit counts as c/|r| of a sample (a gross outlier of
/// 100 σ as 3 %).
const HUBER: f64 = 3.0;
/// Reweighting rounds at most (each one more fit).
const REWEIGHTS: usize = 10;

/// The prior's spreads τ: how far each coefficient may plausibly be from
/// its prior value (the density's units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Of the base φ0.
    pub base_sd: f64,
    /// Of the prior objects' scale (dimensionless; 1 keeps them).
    pub prior_scale_sd: f64,
    /// Of each lattice weight (prior value 0).
    pub weight_sd: f64,
}

impl Default for Params {
    /// 1 for the base and for the prior's scale, [`WEIGHT_SD`](super::WEIGHT_SD)
    /// for each lattice weight.
    fn default() -> Self {
        Params {
            base_sd: 1.0,
            prior_scale_sd: 1.0,
            weight_sd: super::WEIGHT_SD,
        }
    }
}

impl Params {
    /// Validates every spread finite and in (0, [`MAX_DENSITY`]].
    pub fn new(base_sd: f64, prior_scale_sd: f64, weight_sd: f64) -> Result<Self, InputError> {
        let check =
            |name: &str, v| check_range(|| format!("learning.{name}"), v, 0.0, false, MAX_DENSITY);
        check("base_sd", base_sd)?;
        check("prior_scale_sd", prior_scale_sd)?;
        check("weight_sd", weight_sd)?;
        Ok(Params {
            base_sd,
            prior_scale_sd,
            weight_sd,
        })
    }
}

/// Gathers samples and fits the belief to them.
#[derive(Debug, Clone)]
pub struct Learner {
    lattice: Lattice,
    prior: RiskField,
    params: Params,
    samples: Vec<Sample>,
}

/// The fitted belief: its coefficients and their posterior covariance.
#[derive(Debug, Clone)]
pub struct Belief {
    lattice: Lattice,
    prior: RiskField,
    /// θ: base, prior scale, lattice weights; all ≥ 0.
    mean: DVector<f64>,
    /// Σ, of the unconstrained posterior.
    covariance: DMatrix<f64>,
}

impl Learner {
    /// A learner with `prior` as its belief before any sample.
    pub fn new(lattice: Lattice, prior: RiskField, params: Params) -> Self {
        Learner {
            lattice,
            prior,
            params,
            samples: Vec::new(),
        }
    }

    /// Adds one sample (already judged plausible by the caller).
    pub fn add(&mut self, sample: Sample) {
        self.samples.push(sample);
    }

    /// How many samples it holds.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The belief given every sample so far. Robust to gross outliers
    /// (Huber's weights by iterated reweighting): a sample more than
    /// [`HUBER`] of its σ from the fit is weighted down to c/|r|, and the
    /// fit made again, [`REWEIGHTS`] times at most, until no weight changes.
    pub fn fit(&self) -> Belief {
        let mut sorted = self.samples.clone();
        sorted.sort_unstable_by_key(Sample::key);
        let mut weights = vec![1.0; sorted.len()];
        let (mut mean, mut covariance) = self.solve(&sorted, &weights);
        let mut f = Vec::new();
        for _ in 0..REWEIGHTS {
            let mut changed = false;
            for (s, w) in sorted.iter().zip(&mut weights) {
                self.features(s.position, &mut f);
                let fit: f64 = f.iter().map(|&(i, fi)| fi * mean[i]).sum();
                let r = ((s.value - fit) / s.sd).abs();
                let huber = if r > HUBER { HUBER / r } else { 1.0 };
                changed |= (huber - *w).abs() > 1e-3;
                *w = huber;
            }
            if !changed {
                break;
            }
            (mean, covariance) = self.solve(&sorted, &weights);
        }
        Belief {
            lattice: self.lattice.clone(),
            prior: self.prior.clone(),
            mean,
            covariance,
        }
    }

    /// The mean (θ ≥ 0) and the unconstrained covariance with each sorted
    /// sample weighted by `weights`.
    fn solve(&self, sorted: &[Sample], weights: &[f64]) -> (DVector<f64>, DMatrix<f64>) {
        let (a, b) = self.normal_equations(sorted, weights);
        // The prior's precision makes A positive definite.
        let chol = a.clone().cholesky().expect("A is positive definite");
        let free = chol.solve(&b);
        let covariance = chol.inverse();
        // Most fits need no coefficient pinned: the active set's first
        // round would only factorize A again.
        let mean = if free.iter().all(|&t| t >= 0.0) {
            free
        } else {
            nonnegative(&a, &b)
        };
        (mean, covariance)
    }

    /// A = Σ ω f fᵀ/σ² + diag(τ⁻²) and b = Σ ω f y/σ² + diag(τ⁻²) θ₀, the
    /// samples (sorted in their own order, [`Sample::key`]) with their
    /// weights ω.
    fn normal_equations(&self, sorted: &[Sample], weights: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
        let n = FIXED + self.lattice.len();
        let mut a = DMatrix::zeros(n, n);
        let mut b = DVector::zeros(n);
        let p = self.params;
        let prior_mean = [self.prior.base(), 1.0];
        for (i, sd) in [p.base_sd, p.prior_scale_sd].into_iter().enumerate() {
            a[(i, i)] = sd.powi(-2);
            b[i] = prior_mean[i] * sd.powi(-2);
        }
        for k in FIXED..n {
            a[(k, k)] = p.weight_sd.powi(-2);
        }
        let mut f = Vec::new();
        for (s, omega) in sorted.iter().zip(weights) {
            self.features(s.position, &mut f);
            let w = omega * s.sd.powi(-2);
            for &(i, fi) in &f {
                b[i] += w * fi * s.value;
                for &(j, fj) in &f {
                    a[(i, j)] += w * fi * fj;
                }
            }
        }
        (a, b)
    }

    /// The non-zero features at `q`, by coefficient index.
    fn features(&self, q: Point, out: &mut Vec<(usize, f64)>) {
        features(&self.lattice, &self.prior, q, out);
    }
}

fn features(lattice: &Lattice, prior: &RiskField, q: Point, out: &mut Vec<(usize, f64)>) {
    lattice.features(q, out);
    for (k, _) in out.iter_mut() {
        *k += FIXED;
    }
    let objects = prior.value(q) - prior.base();
    if objects > 0.0 {
        out.insert(0, (1, objects));
    }
    out.insert(0, (0, 1.0));
}

/// The minimum of ½ θᵀAθ − bᵀθ over θ ≥ 0 (A positive definite), by an
/// active set: solve on the free coefficients, pin the ones that come out
/// negative at 0, free a pinned one whose gradient asks for more, until
/// neither happens ([`ROUNDS`] at most; each round is one Cholesky
/// factorization of the free block).
fn nonnegative(a: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    let n = b.len();
    let mut free = vec![true; n];
    let mut theta = DVector::zeros(n);
    for _ in 0..ROUNDS {
        let idx: Vec<usize> = (0..n).filter(|&i| free[i]).collect();
        theta.fill(0.0);
        if !idx.is_empty() {
            let sub = a.select_rows(&idx).select_columns(&idx);
            let rhs = DVector::from_iterator(idx.len(), idx.iter().map(|&i| b[i]));
            let solved = sub
                .cholesky()
                .expect("a principal block of A is positive definite")
                .solve(&rhs);
            for (k, &i) in idx.iter().enumerate() {
                theta[i] = solved[k];
            }
        }
        let negative: Vec<usize> = idx.iter().copied().filter(|&i| theta[i] < 0.0).collect();
        if !negative.is_empty() {
            for i in negative {
                free[i] = false;
                theta[i] = 0.0;
            }
            continue;
        }
        // KKT: a pinned coefficient must have a gradient Aθ − b ≥ 0.
        let gradient = a * &theta - b;
        let scale = b.amax().max(f64::MIN_POSITIVE);
        let wanting = (0..n)
            .filter(|&i| !free[i] && gradient[i] < -SETTLED * scale)
            .min_by(|&i, &j| gradient[i].total_cmp(&gradient[j]));
        match wanting {
            Some(i) => free[i] = true,
            None => break,
        }
    }
    theta
}

impl Belief {
    /// The density the fleet covers with optimism `kappa` ≥ 0: every
    /// coefficient raised by κ of its posterior standard deviations
    /// (κ = 0: the mean), as a base plus non-negative Gaussians.
    pub fn density(&self, kappa: f64) -> RiskField {
        let kappa = if kappa.is_finite() {
            kappa.max(0.0)
        } else {
            0.0
        };
        let theta: Vec<f64> = (0..self.mean.len())
            .map(|i| {
                (self.mean[i] + kappa * self.covariance[(i, i)].max(0.0).sqrt()).min(MAX_DENSITY)
            })
            .collect();
        let mut objects: Vec<RiskObject> = Vec::new();
        if theta[1] > 0.0 {
            objects.extend(self.prior.objects().iter().map(|o| RiskObject {
                alpha: (o.alpha * theta[1]).min(MAX_DENSITY),
                ..*o
            }));
            objects.retain(|o| o.alpha > 0.0);
        }
        let largest = theta[FIXED..].iter().copied().fold(0.0, f64::max);
        let h = self.lattice.spacing();
        objects.extend(
            theta[FIXED..]
                .iter()
                .enumerate()
                .filter(|&(_, &w)| w > NEGLIGIBLE * largest && w > 0.0)
                .map(|(k, &w)| RiskObject {
                    center: self.lattice.center(k),
                    alpha: w,
                    sigma: h,
                }),
        );
        RiskField::new(theta[0], objects).expect("coefficients are clamped into range")
    }

    /// The posterior standard deviation of Φ(q) (unconstrained posterior).
    pub fn sd_at(&self, q: Point) -> f64 {
        let mut f = Vec::new();
        features(&self.lattice, &self.prior, q, &mut f);
        let mut var = 0.0;
        for &(i, fi) in &f {
            for &(j, fj) in &f {
                var += fi * fj * self.covariance[(i, j)];
            }
        }
        var.max(0.0).sqrt()
    }

    /// The coefficients θ (base, prior scale, lattice weights).
    pub fn coefficients(&self) -> &[f64] {
        self.mean.as_slice()
    }
}
