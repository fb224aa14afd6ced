//! The one integrand of every cell integral: a weighted isotropic Gaussian,
//! exp(λ − a ‖x − m‖²). A risk object times a vessel's actuator is one (the
//! product of two Gaussians is a Gaussian), and so is the base risk times
//! the actuator; [`integrate`](super::integrate) and
//! [`boundary`](super::boundary) both integrate it, so it lives below both.
//!
//! The weight is kept as its logarithm λ: weights of far vessels underflow
//! long before their integrals stop mattering relative to each other.

use crate::geometry::Point;

/// exp(λ − a ‖x − m‖²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gaussian {
    /// λ, the logarithm of the weight.
    pub log_weight: f64,
    /// The decay a > 0 [1/m²].
    pub a: f64,
    /// The centre m [m], in the coordinates of the integral (centred on
    /// the vessel).
    pub center: Point,
}
