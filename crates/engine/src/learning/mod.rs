//! Learning the risk density Φ from point samples (docs/learning.md).
//!
//! The fleet's belief is a density the coverage engine integrates exactly,
//! as it does a mission's risk: a base plus non-negative Gaussians. Its
//! coefficients θ are
//! - the base φ0,
//! - one scale s ≥ 0 of the prior's objects (the mission's risk objects,
//!   when it has any: s = 1 keeps them, s = 0 drops them),
//! - one weight w_k ≥ 0 per Gaussian of a square [`Lattice`] over the
//!   region's bounding box (spacing h, each of spread h),
//!
//! so Φ(q) = θ · f(q) with features f(q) = (1, Σ_j α_j g_j(q), g_1(q), …).
//! A sample is y = Φ(x) + ε with ε ~ N(0, σ²) of its own σ; the prior is
//! θ ~ N(θ₀, diag(τ²)) with θ₀ = (the prior's φ0, 1, 0, …). The belief's
//! mean is the posterior mode under θ ≥ 0 (a small quadratic programme,
//! solved by an active set), and
//! its uncertainty that of the unconstrained Gaussian posterior,
//! Σ = A⁻¹ with A = Σ f fᵀ / σ² + diag(τ⁻²). Gross outliers are weighted
//! down by Huber's weights (iterated reweighting; a sample r of its σ from
//! the fit counts as min(1, 3/|r|) of one).
//!
//! Why this shape: a belief that stays a mixture of Gaussians keeps the
//! engine exact and fast (no grid, [`crate::coverage`]), the weights are
//! linear in the samples so Bayes is closed-form, and non-negativity keeps
//! Φ ≥ 0 whatever the noise. The optimistic belief, for exploration, adds
//! κ posterior standard deviations to every coefficient (still
//! non-negative Gaussians); κ = 0 is the mean.
//!
//! Invariants: pure and deterministic; the fit depends on the set of
//! samples, not their order (they are sorted before they are summed), so
//! two learners that heard the same samples hold the same belief, bit for
//! bit; samples are validated by [`Sample::new`], and a fit cannot fail.
//!
//! Beside the learner, the baselines docs/learning.md measures it
//! against: [`Adaptive`], Schwager's adaptive law over the same lattice,
//! and [`GridMap`], a map gridded straight from the samples (for
//! [`crate::coverage::grid_lloyd`]).
//!
//! Cost: each sample touches the Gaussians within 5 h of it (about 80);
//! a fit is O(N · 80² + K³) for N samples and K Gaussians (K = 441 on the
//! paper's 100 m square at h = 5 m).

mod fit;
mod grid_map;
mod lattice;
mod schwager;
#[cfg(test)]
mod tests;

pub use fit::{Belief, Learner, Params};
pub use grid_map::GridMap;
pub use lattice::Lattice;
pub use schwager::{Adaptive, Gains, Quadrature};

use crate::coverage::density::MAX_DENSITY;
use crate::coverage::{InputError, check_range};
use crate::geometry::Point;
use crate::geometry::region::MAX_COORDINATE;

/// How a fleet learns, wherever it learns (a coordinator's `[learning]`, a
/// peer fleet's `--learn`): the optimism it covers with and how it fades,
/// how often it fits, and its lattice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LearnSettings {
    /// Optimism: posterior standard deviations added (0: the mean) when
    /// learning starts.
    pub kappa: f64,
    /// The optimism's time constant [mission s]: κ fades as
    /// κ · exp(−age / fade) with the age of the oldest sample held
    /// ([`LearnSettings::kappa_at`]).
    pub fade: f64,
    /// Mission seconds between fits.
    pub refit: f64,
    /// The lattice's spacing and each Gaussian's spread [m].
    pub lattice: f64,
    /// The prior's spread of each lattice weight ([`Params::weight_sd`]):
    /// smaller keeps the first fits of a few samples from putting weight
    /// where no sample has been, and shrinks the optimism's reach.
    pub weight_sd: f64,
}

/// The optimism's time constant unless set [mission s]: about half the
/// time a vessel of the paper's scenario takes to cross its 100 m square
/// (docs/learning.md, "Optimism that fades").
pub const FADE: f64 = 30.0;

/// The prior's spread of each lattice weight unless set (the density's
/// units; docs/learning.md, "The model").
pub const WEIGHT_SD: f64 = 5.0;

impl Default for LearnSettings {
    /// The mean (optimism fading over [`FADE`] when set), a fit every 5
    /// mission seconds, a 10 m lattice, weights of spread [`WEIGHT_SD`].
    fn default() -> Self {
        LearnSettings {
            kappa: 0.0,
            fade: FADE,
            refit: 5.0,
            lattice: 10.0,
            weight_sd: WEIGHT_SD,
        }
    }
}

impl LearnSettings {
    /// The optimism to cover with when the oldest sample held is `age`
    /// mission seconds old: κ · exp(−age / fade), κ at first and the mean
    /// once the fleet has had time to look. An optimism that stays
    /// leaves water no vessel will visit attractive for ever (vessels at
    /// rest sample only where they rest), so the fleet spreads as over a
    /// flat map; one that fades explores first and then covers what it
    /// found. A negative or non-finite age counts as 0; `fade` is
    /// validated finite and > 0 where it is read.
    ///
    /// ```
    /// use seacover_engine::learning::LearnSettings;
    /// let s = LearnSettings { kappa: 1.0, fade: 30.0, ..LearnSettings::default() };
    /// assert_eq!(s.kappa_at(0.0), 1.0);
    /// assert!((s.kappa_at(30.0) - (-1.0f64).exp()).abs() < 1e-15);
    /// assert!(s.kappa_at(600.0) < 1e-8);
    /// ```
    pub fn kappa_at(&self, age: f64) -> f64 {
        let age = if age.is_finite() { age.max(0.0) } else { 0.0 };
        if self.kappa == 0.0 {
            return 0.0;
        }
        self.kappa * (-age / self.fade.max(f64::MIN_POSITIVE)).exp()
    }

    /// Checks every setting's range, wherever the settings were read:
    /// `name` turns a setting's name (`kappa`, `fade`, `refit`, `lattice`,
    /// `weight_sd`) into what the reader calls it (`--kappa`,
    /// `learning.kappa`). The lattice's fit to the region is
    /// [`Lattice::over`]'s to check.
    ///
    /// ```
    /// use seacover_engine::learning::LearnSettings;
    /// let s = LearnSettings { fade: 0.0, ..LearnSettings::default() };
    /// let e = s.validate(|f| format!("--{f}")).unwrap_err();
    /// assert_eq!(e.to_string(), "--fade: must be in (0, 1e6] s");
    /// ```
    pub fn validate(&self, name: impl Fn(&str) -> String) -> Result<(), InputError> {
        let check = |field: &str, ok: bool, reason: &str| {
            if ok {
                Ok(())
            } else {
                Err(InputError::invalid(name(field), reason))
            }
        };
        check(
            "kappa",
            (0.0..=10.0).contains(&self.kappa),
            "must be in [0, 10]",
        )?;
        check(
            "fade",
            self.fade > 0.0 && self.fade <= 1e6,
            "must be in (0, 1e6] s",
        )?;
        check(
            "refit",
            (0.1..=3600.0).contains(&self.refit),
            "must be in [0.1, 3600] s",
        )?;
        check(
            "lattice",
            self.lattice.is_finite() && self.lattice > 0.0,
            "must be a length > 0 m",
        )?;
        check(
            "weight_sd",
            self.weight_sd > 0.0 && self.weight_sd <= MAX_DENSITY,
            "must be in (0, 1e12]",
        )
    }

    /// The fit's prior spreads: [`Params::default`] with these settings'
    /// `weight_sd`.
    pub fn params(&self) -> Params {
        Params {
            weight_sd: self.weight_sd,
            ..Params::default()
        }
    }
}

/// One measurement of the field: where, what, and how uncertain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Where it was taken, in the region's plane [m].
    pub position: Point,
    /// The value measured (the density's units).
    pub value: f64,
    /// Its standard deviation σ > 0 (the same units).
    pub sd: f64,
}

impl Sample {
    /// Validates a finite position within the coordinates a fleet may
    /// have, a finite value within ±[`MAX_DENSITY`] and 0 < σ ≤
    /// [`MAX_DENSITY`]; errors name the field (`sample.sd`).
    pub fn new(position: Point, value: f64, sd: f64) -> Result<Self, InputError> {
        let c = MAX_COORDINATE;
        check_range(|| "sample.x".into(), position.x, -c, true, c)?;
        check_range(|| "sample.y".into(), position.y, -c, true, c)?;
        check_range(
            || "sample.value".into(),
            value,
            -MAX_DENSITY,
            true,
            MAX_DENSITY,
        )?;
        check_range(|| "sample.sd".into(), sd, 0.0, false, MAX_DENSITY)?;
        Ok(Sample {
            position,
            value,
            sd,
        })
    }

    /// A total order on samples (by their bits), so that sums over a set
    /// of samples do not depend on the order they arrived in.
    fn key(&self) -> [u64; 4] {
        [
            self.position.x.to_bits(),
            self.position.y.to_bits(),
            self.value.to_bits(),
            self.sd.to_bits(),
        ]
    }
}
