//! Exact integrals of a Gaussian over a cell bounded by segments and
//! circular arcs ([`geometry::arcs`](crate::geometry::arcs)): the cells of
//! vessels with different reaches β.
//!
//! The same reduction to the boundary as [`boundary`](super::boundary)
//! (read its doc first), with y = x − m, r = ‖y‖ and n the outward normal:
//! - moment: ∫ (x − m) g = −(1/2a) ∮ g n ds, near m as ∮ (g − e^λ) n ds
//!   (∮ n ds = 0 around the closed boundary, and the difference does not
//!   cancel for flat Gaussians);
//! - mass: ∮ (y·n)(1 − e^{−a r²}) / (2a r²) ds · e^λ near m, and where m is
//!   outside the cell with a·dist² ≥ 1 (`far`) the split form
//!   −(1/2a) ∮ (y·n) e^{λ − a r²} / r² ds, the "1" part being the angle the
//!   boundary turns about m, 0 for a point outside.
//!
//! Segments use [`boundary`]'s edge integrals. An arc's points relative
//! to m are its start plus the chord 2R sin(Δ/2) ⊥u(θ₀ + Δ/2), not
//! c − m + R u(θ): for near-equal reaches R reaches 1e10 m, and c − m and
//! R u, both that large, cancel to tens of metres and leave R's rounding
//! (1e-6 m) at every node. Along an arc of radius R,
//! θ ↦ r² = ‖c − m‖² + R² + 2R (c − m)·u(θ) is a trigonometric polynomial,
//! so both integrands are analytic in θ and Gauss–Legendre in θ converges
//! geometrically. With D = ‖c − m‖ and φ the angle from the circle's point
//! nearest m, r² = r_min² + 2RD (1 − cos φ): the exponent a r² has the
//! width 2/√(aRD) in φ at φ = 0 and changes by 6 over 3/(aRD |sin φ|),
//! where D |sin φ| = |y·u⊥| is the distance of m's foot on the tangent,
//! the straight edges' u. An arc is cut into pieces of at most π/4, that
//! width and that decay angle, and in the far form at most half the
//! distance of the poles of e^{−a r²}/r² (see `arc`), 12 nodes each: the
//! straight edges' rule in the variable that matters, whose error the
//! engine's tests bound at 1e-10 relative. Against a finer rule (2 instead
//! of 3 decay lengths) the integrals agree to 3.2e-13 of their size (the
//! tests), and against the independent slab reference of
//! `curved_reference` to 1.5e-12. (Pieces of at most 2/√a and 3/(a r)
//! would be far stricter, since r ≥ D |sin φ|, where a narrow Gaussian
//! sees a small circle from afar.)
//! Where r² stays beyond the cutoff over a piece (`skip_angle` proposes
//! how far, from the circle's geometry), the near form's integrals are
//! closed: the angle the piece turns about m, over 2a, and −∫ n ds; the
//! far form drops a piece whose e^{−a r²} is below e^{−50} of the cell's
//! nearest point's.
//! A term whose share is below the cut-off on the cell's bounding box is
//! dropped before any exact distance is taken.

use std::sync::LazyLock;

use super::boundary::{DECAY, exp_fast, exp_m1_fast, segment};
use super::gaussian::Gaussian;
use super::integrate::{Scaled, Tolerance};
use crate::geometry::arcs::Piece;
use crate::geometry::outline;
use crate::geometry::quadrature::gauss_legendre_01;
use crate::geometry::{Point, cross, dot, norm2};

const NODES: usize = 12;
static GL: LazyLock<([f64; NODES], [f64; NODES])> = LazyLock::new(|| {
    let (x, w) = gauss_legendre_01(NODES);
    (
        x.try_into().expect("NODES nodes"),
        w.try_into().expect("NODES weights"),
    )
});

/// Beyond a r² = CUTOFF the Gaussian is negligible (as in boundary).
const CUTOFF: f64 = 50.0;
/// Largest angle of one piece of an arc.
const MAX_ANGLE: f64 = std::f64::consts::FRAC_PI_4;

/// [∫ g, ∫ x₁ g, ∫ x₂ g] over the cell bounded by `pieces` (the cell on
/// the left of each). `far` must be set exactly when g's centre is outside
/// the cell with a·dist² ≥ 1 ([`is_far`]).
pub fn curved_integrals(pieces: &[Piece], g: &Gaussian, far: bool) -> [f64; 3] {
    // The far form drops what is e^{-CUTOFF} of the nearest piece's share.
    let near2 = if far {
        pieces
            .iter()
            .map(|p| p.distance2(g.center))
            .fold(f64::INFINITY, f64::min)
    } else {
        0.0
    };
    integrals_with(pieces, g, far, near2)
}

/// [`curved_integrals`] with the cell's squared distance from g's centre
/// already known (`near2`, used by the far form only).
fn integrals_with(pieces: &[Piece], g: &Gaussian, far: bool, near2: f64) -> [f64; 3] {
    integrals_rule(pieces, g, far, near2, (DECAY, MAX_ANGLE))
}

/// The integrals with arc pieces of at most `decay`/(aRD |sin φ|) radians
/// in the decaying part (see the module doc) and at most `max_angle`
/// (≤ MAX_ANGLE): the tests compare the rule against a finer one.
fn integrals_rule(
    pieces: &[Piece],
    g: &Gaussian,
    far: bool,
    near2: f64,
    (decay, max_angle): (f64, f64),
) -> [f64; 3] {
    let m = g.center;
    let mut mass = 0.0;
    let mut line = Point { x: 0.0, y: 0.0 };
    for piece in pieces {
        let (dm, dl) = match *piece {
            Piece::Segment { from, to } => segment(from - m, to - m, g, far),
            Piece::Arc {
                centre,
                radius,
                start,
                sweep,
            } => arc(
                centre - m,
                radius,
                start,
                sweep,
                &Form {
                    g,
                    far,
                    near2,
                    decay,
                    max_angle,
                },
            ),
        };
        mass += dm;
        line = line + dl;
    }
    let moment = line * (-0.5 / g.a);
    [mass, moment.x + m.x * mass, moment.y + m.y * mass]
}

/// A box holding every piece ([`Piece::bounding_box`]).
pub fn pieces_box(pieces: &[Piece]) -> (Point, Point) {
    pieces.iter().map(Piece::bounding_box).fold(
        (
            Point {
                x: f64::INFINITY,
                y: f64::INFINITY,
            },
            Point {
                x: f64::NEG_INFINITY,
                y: f64::NEG_INFINITY,
            },
        ),
        |(l, h), (pl, ph)| {
            (
                Point {
                    x: l.x.min(pl.x),
                    y: l.y.min(pl.y),
                },
                Point {
                    x: h.x.max(ph.x),
                    y: h.y.max(ph.y),
                },
            )
        },
    )
}

/// Integrates Σ_t exp(λ_t − a_t ‖x − m_t‖²) and its first moment over the
/// cell bounded by `pieces` (coordinates relative to the vessel), with the
/// scaling and cut-off of [`integrate`](super::integrate::integrate): the
/// same contract for curved cells. The tolerance only sets the cut-off:
/// curved cells always take the arc quadrature, in either mode. `bbox`
/// is the pieces' box ([`pieces_box`]), which the caller has already
/// taken for its window of risk objects.
pub fn integrate_pieces(
    pieces: &[Piece],
    bbox: (Point, Point),
    terms: &[Gaussian],
    tol: Tolerance,
) -> Scaled {
    let (lo, hi) = bbox;
    let empty = Scaled {
        mass: 0.0,
        moment: Point { x: 0.0, y: 0.0 },
        log_scale: 0.0,
    };
    if pieces.is_empty() || terms.is_empty() {
        return empty;
    }
    // An upper bound of every term's share, log_weight − a·dist² with dist
    // the cell's distance from the term's centre, first from a box around
    // the cell (a lower bound of that distance), and a lower bound from
    // the farthest point: terms whose upper bound is below the cut-off are
    // skipped before the exact distance, a walk over the pieces with an
    // atan2 per arc, is ever taken. Skipping them changes nothing: the
    // exact bound is lower still, and the scale s, the largest exact
    // bound, is at least `floor`, above the cut-off.
    let box2 = |m: Point| {
        let dx = (lo.x - m.x).max(m.x - hi.x).max(0.0);
        let dy = (lo.y - m.y).max(m.y - hi.y).max(0.0);
        dx * dx + dy * dy
    };
    let floor = terms
        .iter()
        .map(|t| {
            let far2 = pieces
                .iter()
                .map(|p| farthest2(p, t.center))
                .fold(0.0, f64::max);
            t.log_weight - t.a * far2
        })
        .fold(f64::NEG_INFINITY, f64::max);
    let cut = floor + (1e-3 * tol.relative / terms.len() as f64).ln();
    // Where each term that may count lies: inside, and the squared
    // distance to the boundary; `None` for a term skipped.
    let places: Vec<Option<(bool, f64)>> = terms
        .iter()
        .map(|t| {
            let m = t.center;
            if cut <= floor && t.log_weight - t.a * box2(m) < cut {
                return None;
            }
            let near2 = pieces
                .iter()
                .map(|p| p.distance2(m))
                .fold(f64::INFINITY, f64::min);
            Some((outline::contains(pieces, m), near2))
        })
        .collect();
    let bounds: Vec<f64> = terms
        .iter()
        .zip(&places)
        .map(|(t, place)| match *place {
            Some((inside, near2)) => t.log_weight - t.a * if inside { 0.0 } else { near2 },
            None => f64::NEG_INFINITY,
        })
        .collect();
    let s = bounds.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut sum = [0.0; 3];
    for ((t, &b), place) in terms.iter().zip(&bounds).zip(&places) {
        let Some((inside, near2)) = *place else {
            continue;
        };
        if b < cut {
            continue;
        }
        let g = Gaussian {
            log_weight: t.log_weight - s,
            ..*t
        };
        let far = !inside && t.a * near2 >= 1.0;
        let v = integrals_with(pieces, &g, far, if far { near2 } else { 0.0 });
        for (acc, x) in sum.iter_mut().zip(v) {
            *acc += x;
        }
    }
    Scaled {
        mass: sum[0],
        moment: Point {
            x: sum[1],
            y: sum[2],
        },
        log_scale: s,
    }
}

/// An upper bound of the squared distance from `q` to the piece's points.
fn farthest2(piece: &Piece, q: Point) -> f64 {
    match *piece {
        Piece::Segment { from, to } => norm2(from - q).max(norm2(to - q)),
        Piece::Arc { centre, radius, .. } => {
            let d = norm2(centre - q).sqrt() + radius;
            d * d
        }
    }
}

/// Whether `g`'s centre is outside the cell (`inside` says whether it is
/// in) with a·dist² ≥ 1: when [`curved_integrals`] takes the split form.
pub fn is_far(pieces: &[Piece], g: &Gaussian, inside: bool) -> bool {
    !inside
        && pieces
            .iter()
            .map(|p| p.distance2(g.center))
            .fold(f64::INFINITY, f64::min)
            * g.a
            >= 1.0
}

/// How an arc is integrated: the Gaussian, whether in the far form (and
/// the cell's squared distance then), and the pieces' decay lengths.
struct Form<'g> {
    g: &'g Gaussian,
    far: bool,
    near2: f64,
    decay: f64,
    max_angle: f64,
}

/// One arc, its centre `c` relative to g's centre: its share of the mass
/// and of ∮ g n ds (near: ∮ (g − e^λ) n ds). `near2` is the squared
/// distance of the cell's nearest point (far form only).
fn arc(c: Point, radius: f64, start: f64, sweep: f64, form: &Form) -> (f64, Point) {
    let Form {
        g,
        far,
        near2,
        decay: _,
        max_angle,
    } = *form;
    let a = g.a;
    let lambda = g.log_weight;
    let scale = lambda.exp();
    // The point `off` radians along the arc from its start, relative to
    // m: the start, then the chord 2R sin(Δ/2) ⊥u(θ₀ + Δ/2). Not
    // c + R u(θ): for a huge radius c and R u cancel to a point near m,
    // with an error of R's rounding everywhere along the arc.
    let (s0, c0) = start.sin_cos();
    let y_start = c + Point { x: c0, y: s0 } * radius;
    let at = |off: f64| {
        let (s, co) = (start + off).sin_cos();
        let (sh, ch) = (start + 0.5 * off).sin_cos();
        let chord = 2.0 * radius * (0.5 * off).sin();
        (
            Point { x: co, y: s },
            y_start + Point { x: -sh, y: ch } * chord,
        )
    };
    let mut mass = 0.0;
    let mut line = Point { x: 0.0, y: 0.0 };
    let total = sweep.abs();
    let dir = sweep.signum();
    let mut done = 0.0;
    // r² ≥ beyond (e^{−CUTOFF} of the cell's nearest point's share, or
    // of e^λ in the near form) is negligible.
    let beyond = near2 + CUTOFF / a;
    let rd = radius * norm2(c).sqrt();
    let width = max_angle.min(2.0 / (a * rd).sqrt());
    let circle = Circle {
        towards_m: Point { x: -c.x, y: -c.y },
        four_rd: 4.0 * rd,
        beyond,
        dir,
        max_angle,
    };
    // The piece's start and its direction u, carried from piece to piece
    // by the same rotations as the nodes (from the arc's start again after
    // a skip): no trigonometric call per piece. Over n pieces they drift
    // by ~n ulp, far below the rule's error, since no piece is shorter
    // than 1e-12 of the coordinates (below).
    let mut y0 = y_start;
    let (mut sp, mut cp) = (s0, c0);
    while done < total {
        let r0sq = norm2(y0);
        let r0 = r0sq.sqrt();
        let step = piece_length(y0, (cp, sp), r0, width, radius, form).min(total - done);
        // Where the piece's start is beyond the cutoff, skip as far as the
        // whole piece stays beyond it, not in steps of the Gaussian's
        // width: a circle of a huge radius past a narrow Gaussian would
        // otherwise take billions of steps (found by the fuzzer, twice).
        // A proposal that fails at its end is halved: where R and D are
        // huge its arithmetic can cancel, and halving still approaches the
        // cutoff geometrically.
        let mut skip = if r0sq > beyond {
            skip_angle(y0, Point { x: cp, y: sp }, r0sq, &circle).min(total - done)
        } else {
            0.0
        };
        let mut skipped = false;
        while skip > step {
            let (u1, p1) = at(dir * (done + skip));
            // The least r² over the skipped piece: at its end where r
            // falls (the skip stops at the nearest point), else at an end.
            if norm2(p1).min(r0sq) > beyond {
                if !far {
                    let (u0, p0) = at(dir * done);
                    // The angle the piece turns about m (< π: m is outside
                    // the hull of a piece no longer than π/4 along which r
                    // only rises, or only falls, or rises and then falls),
                    // and ∫ n ds = R (u⊥ change).
                    let turn = cross(p0, p1).atan2(dot(p0, p1));
                    mass += scale * turn / (2.0 * a);
                    line = line
                        - Point {
                            x: u1.y - u0.y,
                            y: u0.x - u1.x,
                        } * (radius * scale);
                }
                (y0, cp, sp) = (p1, u1.x, u1.y);
                done += skip;
                skipped = true;
                break;
            }
            skip *= 0.5;
        }
        if skipped {
            continue;
        }
        let [mi, lx, ly] = piece_sums(step * dir, (cp, sp), y0, radius, form);
        let li = Point { x: lx, y: ly };
        // ds = R dθ over a piece of `step` radians.
        let ds = radius * step;
        if far {
            mass -= mi * ds / (2.0 * a);
            line = line + li * ds;
        } else {
            mass += mi * ds * scale / (2.0 * a);
            line = line + li * (ds * scale);
        }
        // The next piece's start: this one's end, by its nodes' rotation.
        let (sh, ch) = small_sin_cos(0.5 * dir * step);
        let (hx, hy) = (ch * cp - sh * sp, sh * cp + ch * sp);
        let chord = 2.0 * radius * sh;
        y0 = Point {
            x: y0.x - hy * chord,
            y: y0.y + hx * chord,
        };
        (cp, sp) = (ch * hx - sh * hy, sh * hx + ch * hy);
        done += step;
    }
    (mass, line)
}

/// How long the piece starting at `y0` (relative to m; its direction on
/// the circle (cp, sp), its distance from m `r0`) may be [rad]: no wider
/// than `width`, the exponent's width where the circle passes nearest m.
#[inline]
fn piece_length(
    y0: Point,
    (cp, sp): (f64, f64),
    r0: f64,
    width: f64,
    radius: f64,
    form: &Form,
) -> f64 {
    let (a, far, near2, decay, max_angle) =
        (form.g.a, form.far, form.near2, form.decay, form.max_angle);
    // The exponent along the circle is a r_min² + 2aRD (1 − cos φ), φ
    // from the point nearest m: pieces no wider than its width there,
    // 2/√(aRD), and no longer than 3/(aRD |sin φ|), over which it
    // changes by 6 — the straight edges' 2/√a and 3/(a u) with u the
    // distance from the foot, since D |sin φ| = |y·u⊥| plays u's part.
    // The rule 2/(R√a) and 3/(a r R) would be far
    // stricter (r ≥ D |sin φ|) where a narrow Gaussian sees a small
    // circle from afar: millions of pieces of 1e-12 rad (the floor)
    // on one arc.
    let mut step = width;
    let along = (cp * y0.y - sp * y0.x).abs();
    if along > 0.0 {
        step = step.min(decay / (a * radius * along));
    }
    if far {
        // No longer than half the distance d of the poles of
        // e^{−a r²}/r² (r = 0 in the complex angle) from the piece: d
        // is at least the cell's distance √near2 and, along a piece
        // no longer than r0/3, at least 2r0/3 (r may fall towards m
        // along an arc, unlike along the straight edges' pieces,
        // which start at their nearest point). Pieces as long as d
        // were measured 5e-12 off.
        step = step.min((0.5 * near2.sqrt()).max(r0 / 3.0) / radius);
    }
    // No piece shorter than 1e-12 of the distances at play: the start
    // of the next one is carried by adding the chord to coordinates as
    // large as r and R, and a chord below their resolution would leave
    // r where it was (found by the fuzzer: a narrow Gaussian 5e6 m
    // from an arc's corner, whose cutoff lies within 1e-8 m of it,
    // took 1e-12 rad steps that r² never saw). The integrand then
    // varies within a few ulp of the coordinates, where no rule can
    // resolve it; elsewhere the rule's pieces are far longer. Never
    // past max_angle, where a tiny circle lies far from m (the
    // fuzzer again).
    step.max(1e-12 * (1.0 + r0 / radius)).min(max_angle)
}

/// One piece's Gauss–Legendre sums [Σ w r⁻² y·n e, Σ w e nₓ, Σ w e n_y]
/// (the far form's e = e^{λ − a r²}, the near form's e^{−a r²} − 1): the
/// piece runs `signed` radians (its sign the arc's direction) from `y0`,
/// relative to m, whose direction on the circle is (cp, sp).
#[inline]
fn piece_sums(signed: f64, (cp, sp): (f64, f64), y0: Point, radius: f64, form: &Form) -> [f64; 3] {
    let (a, lambda, far) = (form.g.a, form.g.log_weight, form.far);
    let dir = signed.signum();
    let (x, w) = &*GL;
    // Each node from the piece's start by rotations: u(θ_p + δ/2) and
    // u(θ_p + δ) from one sin_cos(δ/2), the point the piece's start
    // plus the chord 2R sin(δ/2) ⊥u(θ_p + δ/2), as `at` does from the
    // arc's start (one trigonometric call per node instead of three).
    // Node by node into arrays, without branches (the form is the
    // same for the whole piece), so that the twelve evaluate together
    // in vector registers, as the straight edges' nodes do.
    let mut yn = [0.0; NODES];
    let mut nx = [0.0; NODES];
    let mut ny = [0.0; NODES];
    let mut r2s = [0.0; NODES];
    for k in 0..NODES {
        let (sh, ch) = small_sin_cos(0.5 * signed * x[k]);
        let (hx, hy) = (ch * cp - sh * sp, sh * cp + ch * sp);
        let (ux, uy) = (ch * hx - sh * hy, sh * hx + ch * hy);
        let chord = 2.0 * radius * sh;
        let (yx, yy) = (y0.x - hy * chord, y0.y + hx * chord);
        r2s[k] = yx * yx + yy * yy;
        yn[k] = dir * (yx * ux + yy * uy);
        nx[k] = ux * dir;
        ny[k] = uy * dir;
    }
    let mut e = [0.0; NODES];
    let mut per_r2 = [0.0; NODES];
    if far {
        for k in 0..NODES {
            e[k] = exp_fast(lambda - a * r2s[k]);
            per_r2[k] = yn[k] * e[k] / r2s[k];
        }
    } else {
        for k in 0..NODES {
            e[k] = exp_m1_fast(-a * r2s[k]);
            per_r2[k] = yn[k] * if r2s[k] > 0.0 { -e[k] / r2s[k] } else { a };
        }
    }
    weighted_sums(w, [&per_r2, &e, &e], [None, Some(&nx), Some(&ny)])
}

/// An arc's circle as seen from g's centre m, for [`skip_angle`].
struct Circle {
    /// m − centre: the direction of the circle's point nearest m.
    towards_m: Point,
    /// 4 R D, D = ‖m − centre‖.
    four_rd: f64,
    /// The squared distance beyond which the Gaussian is negligible.
    beyond: f64,
    /// The arc's sense of travel (±1).
    dir: f64,
    max_angle: f64,
}

/// How far (radians, ≤ max_angle) an arc may be followed from a point `y`
/// (relative to m, r² = `r2` > beyond) with direction `u` from the centre
/// before it may come within the cutoff; a proposal, which the caller
/// checks at the piece's end.
///
/// Along the circle r² = r_min² + 4RD sin²(φ/2), φ the angle from the
/// point nearest m. Where r rises (d r²/dθ ∝ y·u⊥ in the sense of travel)
/// it keeps rising to the farthest point and falls after it, so over a
/// piece of at most π/4 its least value is at an end. Where r falls, the
/// nearest point lies τ ahead and r² = beyond is reached τ* ahead, with
/// sin²((τ − τ*)/2) = sin²(τ/2) − (r² − beyond)/(4RD); half of τ* is
/// proposed (all of τ when the nearest point is beyond the cutoff, so the
/// skip never passes it), since the subtraction can cancel when R and D
/// are huge: the next proposal, from a nearer point, is better. The
/// distance's lower bound r − R·angle used before this fell short of τ*
/// by the factor τ/2 near a tangent and crawled there in steps ∝ τ².
fn skip_angle(y: Point, u: Point, r2: f64, circle: &Circle) -> f64 {
    let along = circle.dir * (u.x * y.y - u.y * y.x);
    if along >= 0.0 {
        return circle.max_angle;
    }
    let m = circle.towards_m;
    let tau = circle.dir * cross(u, m).atan2(dot(u, m));
    if tau <= 0.0 {
        return 0.0;
    }
    let half = (0.5 * tau).sin();
    let rest = half * half - (r2 - circle.beyond) / circle.four_rd;
    let skip = if rest <= 0.0 {
        tau
    } else {
        0.5 * (tau - 2.0 * rest.sqrt().min(1.0).asin())
    };
    skip.min(circle.max_angle)
}

/// [Σ w p₀ f₀, Σ w p₁ f₁, Σ w p₂ f₂] (an absent f is 1) in a fixed order,
/// two interleaved partial sums each, so that the compiler may keep them
/// in vector registers.
#[inline(always)]
fn weighted_sums(
    w: &[f64; NODES],
    p: [&[f64; NODES]; 3],
    f: [Option<&[f64; NODES]>; 3],
) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (i, o) in out.iter_mut().enumerate() {
        let mut acc = [0.0; 2];
        for k in (0..NODES).step_by(2) {
            for j in 0..2 {
                let v = w[k + j] * p[i][k + j];
                acc[j] += f[i].map_or(v, |f| v * f[k + j]);
            }
        }
        *o = acc[0] + acc[1];
    }
    out
}

/// (sin t, cos t) for |t| ≤ MAX_ANGLE / 2 = π/8, the half-angles of a
/// piece's nodes: their Taylor polynomials to t¹⁵ and t¹⁶, whose next
/// terms are below 1e-21 relative there (|t|¹⁷/17! against |t|), so the
/// result is the polynomial's rounding, within 2 ulp of the library's
/// (the test below). Inline, and without the library's argument
/// reduction, which these angles do not need: the library's `sin_cos` was
/// a tenth of a mixed-β evaluation.
#[inline(always)]
fn small_sin_cos(t: f64) -> (f64, f64) {
    debug_assert!(t.abs() <= MAX_ANGLE / 2.0 + 1e-12);
    let t2 = t * t;
    let mut p = -1.0 / 1_307_674_368_000.0;
    for c in [
        1.0 / 6_227_020_800.0,
        -1.0 / 39_916_800.0,
        1.0 / 362_880.0,
        -1.0 / 5_040.0,
        1.0 / 120.0,
        -1.0 / 6.0,
    ] {
        p = p * t2 + c;
    }
    let mut q = 1.0 / 20_922_789_888_000.0;
    for c in [
        -1.0 / 87_178_291_200.0,
        1.0 / 479_001_600.0,
        -1.0 / 3_628_800.0,
        1.0 / 40_320.0,
        -1.0 / 720.0,
        1.0 / 24.0,
        -0.5,
    ] {
        q = q * t2 + c;
    }
    (t + t * t2 * p, 1.0 + t2 * q)
}

#[cfg(test)]
mod tests;
