//! A simulated vessel's sensor of the risk field (docs/learning.md): it
//! reads a hidden truth at the hull's true position, at a fixed rate of
//! mission time, with seeded Gaussian noise. The truth is the world's, not
//! the fleet's: only the readings leave the hull.
//!
//! Invariants: a vessel's readings depend only on its seed, its id and the
//! positions it is read at; every reading is a valid sample (finite, σ > 0).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::coverage::RiskField;
use crate::geometry::Point;

/// What every simulated sensor of a process measures, and how.
#[derive(Debug, Clone)]
pub struct SensorConfig {
    /// The field measured.
    pub truth: RiskField,
    /// Readings per second of mission time [Hz].
    pub rate: f64,
    /// The noise's standard deviation, in the field's units (> 0).
    pub sd: f64,
}

/// Why a sensor could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SensorError {
    #[error("the truth's scenario")]
    Scenario(#[from] crate::mission::scenario::ScenarioError),
    #[error("the scenario has no `truth` to measure")]
    NoTruth,
    #[error("the sample rate must be in (0, 10] Hz")]
    Rate,
    #[error("the sample noise must be a share of the truth's range in (0, 1]")]
    Noise,
}

impl SensorConfig {
    /// Sensors of the `truth` of scenario document `text`, `rate` readings
    /// a second, their noise σ `noise` of the truth's range over the
    /// scenario's region (a flat truth: of its level).
    pub fn of_scenario(text: &str, rate: f64, noise: f64) -> Result<SensorConfig, SensorError> {
        if !(rate > 0.0 && rate <= 10.0) {
            return Err(SensorError::Rate);
        }
        if !(noise > 0.0 && noise <= 1.0) {
            return Err(SensorError::Noise);
        }
        let doc = crate::mission::scenario::parse_document(text)?;
        let scenario = crate::mission::scenario::Scenario::from_document(&doc)?;
        let truth = scenario.truth.ok_or(SensorError::NoTruth)?;
        let (min, max) = scenario.region.bounds();
        let range = truth.range_over(min, max);
        let scale = if range > 0.0 {
            range
        } else {
            truth.value(min).abs().max(1e-9)
        };
        Ok(SensorConfig {
            truth,
            rate,
            sd: noise * scale,
        })
    }
}

/// One vessel's sensor.
#[derive(Debug, Clone)]
pub struct Sensor {
    config: SensorConfig,
    rng: ChaCha8Rng,
    next: f64,
}

impl Sensor {
    /// The sensor of vessel `id`, its noise seeded by `seed` and the id.
    pub fn new(config: &SensorConfig, seed: u64, id: &str) -> Sensor {
        let mixed = id
            .bytes()
            .fold(seed ^ 0x5e_a5e0, |h, b| h.rotate_left(7) ^ u64::from(b));
        Sensor {
            config: config.clone(),
            rng: ChaCha8Rng::seed_from_u64(mixed),
            next: 0.0,
        }
    }

    /// At mission time `t` with the hull at `at`: a reading `(value, σ)`
    /// when one is due.
    pub fn read(&mut self, t: f64, at: Point) -> Option<(f64, f64)> {
        if t + 1e-9 < self.next {
            return None;
        }
        self.next = (self.next + 1.0 / self.config.rate).max(t);
        // Box–Muller.
        let (u1, u2): (f64, f64) = (self.rng.random::<f64>().max(1e-300), self.rng.random());
        let noise = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        Some((
            self.config.truth.value(at) + self.config.sd * noise,
            self.config.sd,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readings_come_at_the_rate_with_the_noise_given() {
        let truth = RiskField::new(2.0, vec![]).unwrap();
        let config = SensorConfig {
            truth,
            rate: 2.0,
            sd: 0.5,
        };
        let mut s = Sensor::new(&config, 1, "usv-1");
        let q = Point { x: 1.0, y: 1.0 };
        let readings: Vec<f64> = (0..20_000)
            .filter_map(|k| s.read(f64::from(k) * 0.05, q).map(|r| r.0))
            .collect();
        assert_eq!(readings.len(), 2_000, "2 Hz over 1000 s");
        let mean = readings.iter().sum::<f64>() / 2000.0;
        let var = readings.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / 1999.0;
        assert!((mean - 2.0).abs() < 0.05, "mean {mean}");
        assert!((var.sqrt() - 0.5).abs() < 0.03, "sd {}", var.sqrt());
        let mut again = Sensor::new(&config, 1, "usv-1");
        assert_eq!(again.read(0.0, q).unwrap().0, readings[0]);
    }
}
