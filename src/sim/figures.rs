//! The figures of a run, as PNG and SVG (plotters), the first four laid out
//! like the paper's: Fig. 1 observer errors, Fig. 2 tracking errors, Fig. 3
//! H(P) and the comparison with Lloyd, Fig. 4 the evolution of the
//! partition; and Fig. 5, the whole run on one map: trails, islands, final
//! cells and goals, with the safety watch's figures in the caption.
//!
//! Text is drawn with an embedded DejaVu Sans (`assets/fonts`), so figures
//! need no system fonts or font libraries.

use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::coord::cartesian::Cartesian2d;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};

use super::{Config, Run};
use crate::coverage::CellGeometry;

const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

fn register_font() -> Result<(), String> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| "the embedded font is invalid".to_string());
    });
    result
}

#[derive(Clone, Copy)]
enum Figure {
    Observer,
    Tracking,
    Metric,
    Evolution,
    Trails,
}

fn draw<DB: DrawingBackend>(
    which: Figure,
    area: &DrawingArea<DB, Shift>,
    config: &Config,
    run: &Run,
) -> Result<(), String> {
    match which {
        Figure::Observer => observer(area, config, run),
        Figure::Tracking => tracking(area, config, run),
        Figure::Metric => metric(area, config, run),
        Figure::Evolution => evolution(area, config, run),
        Figure::Trails => trails(area, config, run),
    }
}

/// Draws every figure into `out` as `NAME.png` and `NAME.svg`.
pub fn draw_all(out: &Path, config: &Config, run: &Run) -> Result<(), String> {
    register_font()?;
    let (lo, hi) = config.scenario.region.bounds();
    let aspect = ((hi.y - lo.y) / (hi.x - lo.x)).clamp(0.4, 1.6);
    let figures = [
        ("fig1-observer", (1200, 1000), Figure::Observer),
        ("fig2-tracking", (1400, 1000), Figure::Tracking),
        ("fig3-metric", (1400, 560), Figure::Metric),
        ("fig4-evolution", (1200, 1200), Figure::Evolution),
        (
            "fig5-trails",
            (1400, (1300.0 * aspect) as u32 + 100),
            Figure::Trails,
        ),
    ];
    for (name, size, which) in figures {
        let png = out.join(format!("{name}.png"));
        {
            let area = BitMapBackend::new(&png, size).into_drawing_area();
            draw(which, &area, config, run)?;
            area.present().map_err(|e| format!("{name}.png: {e}"))?;
        }
        let svg = out.join(format!("{name}.svg"));
        {
            let area = SVGBackend::new(&svg, size).into_drawing_area();
            draw(which, &area, config, run)?;
            area.present().map_err(|e| format!("{name}.svg: {e}"))?;
        }
    }
    Ok(())
}

/// One panel of named time series with its legend, as `STEM.png` and
/// `STEM.svg` (the learning study's figure).
pub fn draw_series(
    stem: &Path,
    title: &str,
    y_label: &str,
    t_max: f64,
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<(), String> {
    register_font()?;
    let size = (1200, 700);
    let png = stem.with_extension("png");
    {
        let area = BitMapBackend::new(&png, size).into_drawing_area();
        area.fill(&WHITE).map_err(err)?;
        panel(&area, title, y_label, t_max, series, true)?;
        area.present()
            .map_err(|e| format!("{}: {e}", png.display()))?;
    }
    let svg = stem.with_extension("svg");
    let area = SVGBackend::new(&svg, size).into_drawing_area();
    area.fill(&WHITE).map_err(err)?;
    panel(&area, title, y_label, t_max, series, true)?;
    area.present()
        .map_err(|e| format!("{}: {e}", svg.display()))
}

/// Draws Fig. 5 alone, as `STEM.png` and `STEM.svg`.
pub fn draw_trails(stem: &Path, config: &Config, run: &Run) -> Result<(), String> {
    register_font()?;
    let (lo, hi) = config.scenario.region.bounds();
    let aspect = ((hi.y - lo.y) / (hi.x - lo.x)).clamp(0.4, 1.6);
    let size = (1400, (1300.0 * aspect) as u32 + 100);
    let png = stem.with_extension("png");
    {
        let area = BitMapBackend::new(&png, size).into_drawing_area();
        trails(&area, config, run)?;
        area.present()
            .map_err(|e| format!("{}: {e}", png.display()))?;
    }
    let svg = stem.with_extension("svg");
    let area = SVGBackend::new(&svg, size).into_drawing_area();
    trails(&area, config, run)?;
    area.present()
        .map_err(|e| format!("{}: {e}", svg.display()))
}

fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// One panel of time series, one line per vessel.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    y_label: &str,
    t_max: f64,
    series: &[(String, Vec<(f64, f64)>)],
    legend: bool,
) -> Result<(), String> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (_, s) in series {
        for &(_, y) in s {
            if y.is_finite() {
                lo = lo.min(y);
                hi = hi.max(y);
            }
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        (lo, hi) = (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-6);
    // Enough decimals that neighbouring ticks differ (about ten of them).
    let decimals = (-((hi - lo + 2.0 * pad) / 10.0).log10().floor()).clamp(0.0, 12.0) as usize;
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, (lo - pad)..(hi + pad))
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc(y_label)
        .y_label_formatter(&|v| format!("{v:.decimals$}"))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    for (i, (name, points)) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        // A series is drawn in pieces between its non-finite points (the
        // breaks of `wrapped_with_breaks`); the first piece carries the
        // legend.
        for (k, piece) in segments(points).into_iter().enumerate() {
            let drawn = chart
                // 1 px: plotters-bitmap draws wide strokes of near-vertical
                // segments with spikes far outside the panel.
                .draw_series(LineSeries::new(
                    piece.iter().copied(),
                    color.stroke_width(1),
                ))
                .map_err(err)?;
            if k == 0 {
                drawn.label(name.clone()).legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], color.stroke_width(2))
                });
            }
        }
    }
    if legend {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(err)?;
    }
    Ok(())
}

/// The runs of consecutive points with a finite value.
fn segments(points: &[(f64, f64)]) -> Vec<&[(f64, f64)]> {
    points
        .split(|p| !p.1.is_finite())
        .filter(|s| !s.is_empty())
        .collect()
}

/// An angle in (−π, π].
fn wrap(a: f64) -> f64 {
    use std::f64::consts::PI;
    let w = a - 2.0 * PI * ((a - PI) / (2.0 * PI)).ceil();
    // Rounding can leave a value a hair past either end.
    if w <= -PI { w + 2.0 * PI } else { w.min(PI) }
}

/// An angle's series wrapped to (−π, π], with a break (a point whose value
/// is NaN, at the later sample's time) wherever the wrapped value jumps by
/// more than π between samples: the jump is the wrap, not the angle
/// moving, and a line across it would span the whole panel.
fn wrapped_with_breaks(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(points.len());
    let mut previous: Option<f64> = None;
    for &(t, a) in points {
        let w = wrap(a);
        if let Some(p) = previous
            && (w - p).abs() > std::f64::consts::PI
        {
            out.push((t, f64::NAN));
        }
        previous = w.is_finite().then_some(w);
        out.push((t, w));
    }
    out
}

/// A count of episodes of the run, with those the starts put there after
/// it: `0 incursions (+2 at start)`.
fn episodes(what: &str, later: usize, at_start: usize) -> String {
    match at_start {
        0 => format!("{later} {what}"),
        n => format!("{later} {what} (+{n} at start)"),
    }
}

/// Per-vessel series of `f(tick, vessel sample)`.
fn per_vessel(
    config: &Config,
    run: &Run,
    f: impl Fn(&super::Tick, &super::VesselSample) -> f64,
) -> Vec<(String, Vec<(f64, f64)>)> {
    config
        .scenario
        .ids
        .iter()
        .enumerate()
        .map(|(i, id)| {
            let points = run
                .ticks
                .iter()
                .map(|t| (t.t, f(t, &t.vessels[i])))
                .collect();
            (id.clone(), points)
        })
        .collect()
}

fn observer<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    config: &Config,
    run: &Run,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let rows = root.split_evenly((3, 1));
    let names = ["τ_ue (N)", "τ_ve (N)", "τ_re (N m)"];
    for (c, area) in rows.iter().enumerate() {
        let series = per_vessel(config, run, |_, v| v.estimate[c] - v.tau_d[c]);
        let title = format!("Fig. 1{} observer error {}", ["a", "b", "c"][c], names[c]);
        panel(area, &title, names[c], config.duration, &series, c == 0)?;
    }
    Ok(())
}

fn tracking<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    config: &Config,
    run: &Run,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let cells = root.split_evenly((2, 2));
    let mut psi = per_vessel(config, run, |_, v| v.command.psi_e);
    for (_, points) in &mut psi {
        *points = wrapped_with_breaks(points);
    }
    let dist = per_vessel(config, run, |_, v| v.command.e);
    let ue = per_vessel(config, run, |_, v| v.peak_error.0);
    let re = per_vessel(config, run, |_, v| v.peak_error.1);
    let mode = config.guidance.mode.name();
    panel(
        &cells[0],
        &format!("Fig. 2a heading error ψ_e, wrapped to (−π, π] ({mode})"),
        "ψ_e (rad)",
        config.duration,
        &psi,
        true,
    )?;
    panel(
        &cells[1],
        "Fig. 2b distance to centroid E",
        "E (m)",
        config.duration,
        &dist,
        false,
    )?;
    panel(
        &cells[2],
        "Fig. 2c surge error u − u_ref (largest per tick)",
        "u_e (m/s)",
        config.duration,
        &ue,
        false,
    )?;
    panel(
        &cells[3],
        "Fig. 2d yaw-rate error r − r_ref (largest per tick)",
        "r_e (rad/s)",
        config.duration,
        &re,
        false,
    )?;
    Ok(())
}

/// H = ∫ max_i f_i Φ dq: Φ and f_i are pure numbers, so H is an area
/// weighted by them.
const H_LABEL: &str = "H(P) (m², weighted by f Φ)";

fn metric<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    config: &Config,
    run: &Run,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let halves = root.split_evenly((1, 2));
    let ours: Vec<(f64, f64)> = run.ticks.iter().map(|t| (t.t, t.h)).collect();
    let lloyd: Vec<(f64, f64)> = run.ticks.iter().map(|t| (t.t, t.lloyd_h)).collect();
    let mode = config.guidance.mode.name();
    panel(
        &halves[0],
        &format!("Fig. 3a H(P), USVs ({mode} guidance)"),
        H_LABEL,
        config.duration,
        &[(format!("USVs, {mode}"), ours.clone())],
        false,
    )?;
    panel(
        &halves[1],
        "Fig. 3b USVs vs Lloyd (ṗ = k (C − p))",
        H_LABEL,
        config.duration,
        &[
            (format!("USVs, {mode}"), ours),
            (format!("Lloyd, k = {}", config.lloyd_gain), lloyd),
        ],
        true,
    )
}

fn evolution<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    config: &Config,
    run: &Run,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let region = &config.scenario.region;
    let risk = &config.scenario.risk;
    let (lo, hi) = region.bounds();
    let margin = 0.05 * (hi.x - lo.x).max(hi.y - lo.y);
    let (x0, x1, y0, y1) = (lo.x - margin, hi.x + margin, lo.y - margin, hi.y + margin);
    // Φ on a grid, for the heat map and its scale.
    let n = 90;
    let (dx, dy) = ((hi.x - lo.x) / n as f64, (hi.y - lo.y) / n as f64);
    let mut phi = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let q = crate::geometry::Point {
                x: lo.x + (i as f64 + 0.5) * dx,
                y: lo.y + (j as f64 + 0.5) * dy,
            };
            phi.push((q, region.contains(q).then(|| risk.value(q))));
        }
    }
    let pmax = phi.iter().filter_map(|p| p.1).fold(0.0, f64::max);
    let pmin = phi.iter().filter_map(|p| p.1).fold(f64::INFINITY, f64::min);

    let panels = root.split_evenly((2, 2));
    for (area, snap) in panels.iter().zip(&run.snapshots) {
        let mut chart = ChartBuilder::on(area)
            .caption(format!("Fig. 4 t = {:.0} s", snap.t), ("sans-serif", 22))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x (m)")
            .y_desc("y (m)")
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(err)?;
        chart
            .draw_series(phi.iter().filter_map(|(q, v)| {
                v.map(|v| {
                    // A uniform map has no range to scale: its one value
                    // takes the colour map's middle.
                    let shade = if pmax > pmin {
                        (v - pmin) / (pmax - pmin)
                    } else {
                        0.5
                    };
                    let c = ViridisRGB.get_color(shade as f32);
                    Rectangle::new(
                        [
                            (q.x - dx / 2.0, q.y - dy / 2.0),
                            (q.x + dx / 2.0, q.y + dy / 2.0),
                        ],
                        c.filled(),
                    )
                })
            }))
            .map_err(err)?;
        outline_and_cells(&mut chart, region, &snap.cells)?;
        // Trails, vessels (diamonds) and centroids (crosses).
        let upto: Vec<&super::Tick> = run
            .ticks
            .iter()
            .take_while(|t| t.t <= snap.t + 1e-9)
            .collect();
        positions(
            &mut chart,
            config.scenario.ids.len(),
            &upto,
            0.012 * (x1 - x0),
        )?;
    }
    Ok(())
}

/// Fig. 5: the whole run on one map.
fn trails<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    config: &Config,
    run: &Run,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(err)?;
    let region = &config.scenario.region;
    let (lo, hi) = region.bounds();
    let margin = 0.03 * (hi.x - lo.x).max(hi.y - lo.y);
    let (x0, x1, y0, y1) = (lo.x - margin, hi.x + margin, lo.y - margin, hi.y + margin);
    let r = &run.safety;
    let last = run.ticks.last().ok_or("a run has ticks")?;
    let caption = format!(
        "{} vessels, {:.0} s, filter {}: {}, {}, closest pair {:.1} m, closest to shore {:.1} m, interventions {:.1} %",
        config.scenario.ids.len(),
        last.t,
        if config.safety.filter { "on" } else { "off" },
        episodes("collisions", r.collisions, r.collisions_at_start),
        episodes("incursions", r.incursions, r.incursions_at_start),
        r.min_pair_distance,
        r.min_shore_clearance,
        100.0 * r.intervention_rate(),
    );
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 20))
        .margin(14)
        .x_label_area_size(36)
        .y_label_area_size(48)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(err)?;
    land_and_water(&mut chart, region, (x0, x1, y0, y1))?;
    // Final cells.
    if let Some(snap) = run.snapshots.last() {
        for cell in &snap.cells {
            for piece in cell.pieces(region).0 {
                let pts: Vec<(f64, f64)> = piece.exterior().coords().map(|c| (c.x, c.y)).collect();
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        pts,
                        RGBColor(90, 110, 140).stroke_width(1),
                    )))
                    .map_err(err)?;
            }
        }
    }
    tracks(&mut chart, config, run, last, 1300.0 / (x1 - x0))?;
    Ok(())
}

/// A chart on the local plane.
type Plane<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A closed ring's points, the first repeated at the end.
fn ring(r: &[crate::geometry::Point]) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = r.iter().map(|p| (p.x, p.y)).collect();
    pts.push(pts[0]);
    pts
}

/// Fig. 4's region outline, its islands and the cells.
fn outline_and_cells<DB: DrawingBackend>(
    chart: &mut Plane<'_, DB>,
    region: &crate::geometry::Region,
    cells: &[CellGeometry],
) -> Result<(), String> {
    chart
        .draw_series(std::iter::once(PathElement::new(
            ring(region.shell()),
            BLACK.stroke_width(2),
        )))
        .map_err(err)?;
    for h in region.holes() {
        chart
            .draw_series(std::iter::once(Polygon::new(
                ring(h),
                BLACK.mix(0.6).filled(),
            )))
            .map_err(err)?;
    }
    for cell in cells {
        if matches!(cell, CellGeometry::Empty) {
            continue;
        }
        for piece in cell.pieces(region).0 {
            let pts: Vec<(f64, f64)> = piece.exterior().coords().map(|c| (c.x, c.y)).collect();
            chart
                .draw_series(std::iter::once(PathElement::new(
                    pts,
                    WHITE.stroke_width(2),
                )))
                .map_err(err)?;
        }
    }
    Ok(())
}

/// Fig. 4's trails over `upto`, each vessel's last position (a diamond of
/// half-width `s`) and its centroid (a cross).
fn positions<DB: DrawingBackend>(
    chart: &mut Plane<'_, DB>,
    n: usize,
    upto: &[&super::Tick],
    s: f64,
) -> Result<(), String> {
    for i in 0..n {
        let color = Palette99::pick(i).to_rgba();
        let trail: Vec<(f64, f64)> = upto
            .iter()
            .map(|t| (t.vessels[i].state.x, t.vessels[i].state.y))
            .collect();
        chart
            .draw_series(std::iter::once(PathElement::new(
                trail,
                color.stroke_width(2),
            )))
            .map_err(err)?;
        if let Some(last) = upto.last() {
            let v = &last.vessels[i];
            let (x, y) = (v.state.x, v.state.y);
            chart
                .draw_series(std::iter::once(Polygon::new(
                    vec![(x + s, y), (x, y + s), (x - s, y), (x, y - s)],
                    color.filled(),
                )))
                .map_err(err)?;
            chart
                .draw_series(std::iter::once(Cross::new(
                    (v.centroid.x, v.centroid.y),
                    5,
                    WHITE.stroke_width(2),
                )))
                .map_err(err)?;
        }
    }
    Ok(())
}

/// Fig. 5's ground: land everywhere, water inside the shell, land again on
/// the islands, their shores outlined.
fn land_and_water<DB: DrawingBackend>(
    chart: &mut Plane<'_, DB>,
    region: &crate::geometry::Region,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
) -> Result<(), String> {
    let land = RGBColor(214, 196, 150);
    let water = RGBColor(222, 236, 248);
    // Land everywhere, water inside the shell, land again on the islands.
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(x0, y0), (x1, y1)],
            land.filled(),
        )))
        .map_err(err)?;
    chart
        .draw_series(std::iter::once(Polygon::new(
            ring(region.shell()),
            water.filled(),
        )))
        .map_err(err)?;
    for h in region.holes() {
        chart
            .draw_series(std::iter::once(Polygon::new(ring(h), land.filled())))
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                ring(h),
                BLACK.stroke_width(2),
            )))
            .map_err(err)?;
    }
    chart
        .draw_series(std::iter::once(PathElement::new(
            ring(region.shell()),
            BLACK.stroke_width(2),
        )))
        .map_err(err)?;
    Ok(())
}

/// Fig. 5's vessels: trails, starts (small circles), the hull disc at the
/// end (`px_per_m` to size it) and the goals (×).
fn tracks<DB: DrawingBackend>(
    chart: &mut Plane<'_, DB>,
    config: &Config,
    run: &Run,
    last: &super::Tick,
    px_per_m: f64,
) -> Result<(), String> {
    for i in 0..config.scenario.ids.len() {
        let color = Palette99::pick(i).to_rgba();
        let trail: Vec<(f64, f64)> = run
            .ticks
            .iter()
            .map(|t| (t.vessels[i].state.x, t.vessels[i].state.y))
            .collect();
        chart
            .draw_series(std::iter::once(PathElement::new(
                trail.clone(),
                color.stroke_width(2),
            )))
            .map_err(err)?;
        let start = trail[0];
        chart
            .draw_series(std::iter::once(Circle::new(
                start,
                4,
                color.stroke_width(2),
            )))
            .map_err(err)?;
        let v = &last.vessels[i];
        let hull = ((config.hull_radius * px_per_m).round() as i32).max(3);
        chart
            .draw_series(std::iter::once(Circle::new(
                (v.state.x, v.state.y),
                hull,
                color.filled(),
            )))
            .map_err(err)?;
        chart
            .draw_series(std::iter::once(Cross::new(
                (v.goal.x, v.goal.y),
                5,
                BLACK.stroke_width(2),
            )))
            .map_err(err)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn angles_wrap_into_the_half_open_interval() {
        for (a, w) in [
            (0.0, 0.0),
            (PI, PI),
            (-PI, PI),
            (3.0 * PI, PI),
            (1.5 * PI, -0.5 * PI),
            (-1.5 * PI, 0.5 * PI),
            (7.0, 7.0 - 2.0 * PI),
        ] {
            assert!((wrap(a) - w).abs() < 1e-12, "wrap({a}) = {}", wrap(a));
        }
    }

    #[test]
    fn a_wrapping_angle_is_drawn_in_pieces_without_the_jumps() {
        // A heading error turning steadily through ±π three times, 0.4 rad
        // a sample, then stepping by less than π, a real change that stays
        // joined.
        let raw: Vec<(f64, f64)> = (0..40)
            .map(|k| (k as f64, 2.5 + 0.4 * k as f64))
            .chain([(40.0, 0.3), (41.0, -0.3)])
            .collect();
        let points = wrapped_with_breaks(&raw);
        let pieces = segments(&points);
        // Every drawn value is wrapped, and no piece has a step above π.
        for piece in &pieces {
            for w in piece.windows(2) {
                assert!((w[1].1 - w[0].1).abs() <= PI, "{w:?}");
            }
            for &(_, v) in *piece {
                assert!(v > -PI && v <= PI, "{v}");
            }
        }
        // Independently: the breaks are where the unwrapped angle
        // 2.5 + 0.4 k crosses an odd multiple of π between samples (π
        // between k = 1 and 2, 3π between 17 and 18, 5π between 33 and
        // 34); the later drop from 18.1 (wrapped −0.75) to 0.3 is 1.05 and
        // stays joined.
        let starts: Vec<f64> = pieces.iter().map(|p| p[0].0).collect();
        assert_eq!(starts, [0.0, 2.0, 18.0, 34.0]);
        assert_eq!(pieces.iter().map(|p| p.len()).sum::<usize>(), raw.len());
        // The time of each sample is kept.
        let times: Vec<f64> = pieces.iter().flat_map(|p| p.iter().map(|q| q.0)).collect();
        let expected: Vec<f64> = raw.iter().map(|q| q.0).collect();
        assert_eq!(times, expected);
    }

    #[test]
    fn counts_name_what_the_starts_put_there() {
        assert_eq!(episodes("incursions", 0, 0), "0 incursions");
        assert_eq!(episodes("incursions", 1, 2), "1 incursions (+2 at start)");
    }
}
