//! The learner held to the paper's map, to its own invariants (order,
//! non-negativity, the prior) and to what its uncertainty says.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::coverage::{RiskField, RiskObject};

fn p(x: f64, y: f64) -> Point {
    Point { x, y }
}

/// The paper's risk map, as a truth to learn.
fn paper_truth() -> RiskField {
    let o = |x, y, alpha| RiskObject {
        center: p(x, y),
        alpha,
        sigma: 10.0,
    };
    RiskField::new(
        0.1,
        vec![o(25.0, 70.0, 10.0), o(70.0, 75.0, 13.0), o(60.0, 25.0, 8.0)],
    )
    .unwrap()
}

fn lattice() -> Lattice {
    Lattice::over(p(0.0, 0.0), p(100.0, 100.0), 5.0).unwrap()
}

fn flat_prior() -> RiskField {
    RiskField::new(0.1, vec![]).unwrap()
}

fn params() -> Params {
    Params::new(1.0, 1.0, 5.0).unwrap()
}

/// Samples of `truth` every `step` metres over the square, with seeded
/// normal noise of σ = `sd`.
fn survey(truth: &RiskField, step: f64, sd: f64, seed: u64) -> Vec<Sample> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    let n = (100.0 / step) as usize;
    for j in 0..=n {
        for i in 0..=n {
            let q = p(i as f64 * step, j as f64 * step);
            // Box–Muller.
            let (u1, u2): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
            let noise = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            out.push(Sample::new(q, truth.value(q) + sd * noise, sd).unwrap());
        }
    }
    out
}

/// RMS and largest error of `belief` against `truth` on a 1 m grid,
/// relative to the truth's range there.
fn errors(belief: &RiskField, truth: &RiskField) -> (f64, f64) {
    let (mut sum, mut max, mut n) = (0.0, 0.0f64, 0.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for j in 0..=100 {
        for i in 0..=100 {
            let q = p(f64::from(i), f64::from(j));
            let t = truth.value(q);
            let e = belief.value(q) - t;
            sum += e * e;
            max = max.max(e.abs());
            n += 1.0;
            lo = lo.min(t);
            hi = hi.max(t);
        }
    }
    ((sum / n).sqrt() / (hi - lo), max / (hi - lo))
}

fn learner(samples: &[Sample]) -> Learner {
    let mut l = Learner::new(lattice(), flat_prior(), params());
    for s in samples {
        l.add(*s);
    }
    l
}

/// A survey every 4 m recovers the paper's map: exactly enough without
/// noise that the lattice's own error is small, and with 5 % noise (σ
/// 0.65 against a range of 13) to within what about five samples per
/// Gaussian can average out (0.65 / √5 ≈ 2 % of the range).
#[test]
fn a_survey_recovers_the_paper_map() {
    let truth = paper_truth();
    let exact = learner(&survey(&truth, 4.0, 1e-3, 1)).fit().density(0.0);
    let (rms, max) = errors(&exact, &truth);
    eprintln!("exact rms {rms:.4}, max {max:.4} of the range");
    assert!(
        rms < 0.005 && max < 0.03,
        "exact: rms {rms:.4}, max {max:.4} of the range"
    );
    let noisy = learner(&survey(&truth, 4.0, 0.65, 1)).fit().density(0.0);
    let (rms, max) = errors(&noisy, &truth);
    eprintln!("noisy rms {rms:.4}, max {max:.4} of the range");
    assert!(
        rms < 0.03 && max < 0.12,
        "noisy: rms {rms:.4}, max {max:.4} of the range"
    );
}

#[test]
fn the_belief_does_not_depend_on_the_order_of_the_samples() {
    let samples = survey(&paper_truth(), 10.0, 0.65, 2);
    let mut reversed = samples.clone();
    reversed.reverse();
    let (a, b) = (learner(&samples).fit(), learner(&reversed).fit());
    let bits = |b: &Belief| {
        b.coefficients()
            .iter()
            .map(|t| t.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&a), bits(&b));
}

#[test]
fn noise_around_nothing_never_makes_a_negative_density() {
    let nothing = RiskField::new(0.0, vec![]).unwrap();
    let samples = survey(&nothing, 5.0, 1.0, 3);
    assert!(samples.iter().any(|s| s.value < -1.0));
    let belief = learner(&samples).fit();
    assert!(belief.coefficients().iter().all(|&t| t >= 0.0));
    let field = belief.density(0.0);
    assert!(field.base() >= 0.0 && field.objects().iter().all(|o| o.alpha > 0.0));
}

#[test]
fn without_samples_the_belief_is_the_prior() {
    let prior = paper_truth();
    let belief = Learner::new(lattice(), prior.clone(), params()).fit();
    let field = belief.density(0.0);
    let (rms, max) = errors(&field, &prior);
    assert!(rms < 1e-9 && max < 1e-9, "{rms} {max}");
}

#[test]
fn unexplored_water_is_uncertain_and_optimism_raises_it() {
    let truth = paper_truth();
    // Samples of the western half only.
    let west: Vec<Sample> = survey(&truth, 4.0, 0.65, 4)
        .into_iter()
        .filter(|s| s.position.x <= 50.0)
        .collect();
    let belief = learner(&west).fit();
    let (known, unknown) = (p(20.0, 50.0), p(85.0, 50.0));
    assert!(belief.sd_at(unknown) > 5.0 * belief.sd_at(known));
    let (mean, bold) = (belief.density(0.0), belief.density(2.0));
    assert!(bold.value(unknown) - mean.value(unknown) > bold.value(known) - mean.value(known));
}

#[test]
fn a_wrong_prior_is_scaled_away() {
    // The prior believes in an object where the truth has none.
    let prior = RiskField::new(
        0.1,
        vec![RiskObject {
            center: p(50.0, 50.0),
            alpha: 10.0,
            sigma: 10.0,
        }],
    )
    .unwrap();
    let flat = RiskField::new(0.1, vec![]).unwrap();
    let mut l = Learner::new(lattice(), prior, params());
    for s in survey(&flat, 4.0, 0.05, 5) {
        l.add(s);
    }
    let belief = l.fit();
    assert!(
        belief.coefficients()[1] < 0.05,
        "{:?}",
        &belief.coefficients()[..2]
    );
    let field = belief.density(0.0);
    let centre = field.value(p(50.0, 50.0));
    assert!((centre - 0.1).abs() < 0.05, "{centre}");
}

#[test]
fn samples_and_lattices_are_validated() {
    assert!(Sample::new(p(0.0, 0.0), f64::NAN, 1.0).is_err());
    assert!(Sample::new(p(0.0, 0.0), 1.0, 0.0).is_err());
    assert!(Sample::new(p(2e7, 0.0), 1.0, 1.0).is_err());
    assert!(Lattice::over(p(0.0, 0.0), p(1000.0, 1000.0), 1.0).is_err());
    assert!(Lattice::over(p(0.0, 0.0), p(100.0, 100.0), 0.0).is_err());
    assert_eq!(lattice().len(), 21 * 21);
}
