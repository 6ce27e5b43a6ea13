//! The plots of `shadec bench`, drawn by plotters into an RGB buffer and
//! encoded as PNG by `image` (written atomically). Text uses the embedded
//! DejaVu Sans Mono (`assets/fonts/`, its licence beside it), so no system
//! font is needed.

use std::path::Path;
use std::sync::Once;

use plotters::prelude::*;

use super::adaptive::AdaptiveRow;
use super::{BenchError, Measured};

const FONT: &str = "sans-serif";
const W: u32 = 1000;
const H: u32 = 700;

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is embedded: it parses, or the build is broken.
        let _ = plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            include_bytes!("../../assets/fonts/DejaVuSansMono.ttf"),
        );
    });
}

fn plot_error(e: impl std::fmt::Display) -> BenchError {
    BenchError::Io(format!("drawing a plot: {e}"))
}

fn save(buf: &[u8], path: &Path) -> Result<(), BenchError> {
    let mut bytes = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut bytes);
    image::ImageEncoder::write_image(encoder, buf, W, H, image::ExtendedColorType::Rgb8)
        .map_err(plot_error)?;
    crate::io::write_atomic(path, &bytes).map_err(|e| BenchError::Io(e.to_string()))
}

/// The smallest RMSE plotted: an exact variant (0) sits on this floor.
pub const RMSE_FLOOR: f64 = 1e-6;

/// The variants on the Pareto front: none is both faster and more accurate.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| {
            !points.iter().enumerate().any(|(j, q)| {
                j != i && q.0 <= points[i].0 && q.1 <= points[i].1 && (q.0 < points[i].0 || q.1 < points[i].1)
            })
        })
        .collect();
    front.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0));
    front
}

/// The indices of the variants on their group's Pareto front. The exact
/// variants are the groups' references (zero error by definition) and are
/// left out: the front is the trade-off among the approximations.
pub fn group_fronts(measured: &[Measured]) -> Vec<usize> {
    fronts(measured, TimeAxis::Cpu)
}

/// The time a variant's error is set against: the CPU renderer's measured
/// frame, or the frame its target's cost model predicts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeAxis {
    Cpu,
    Predicted,
}

impl TimeAxis {
    /// The variant's time on this axis (ms); `None` without a prediction.
    pub fn ms(self, m: &Measured) -> Option<f64> {
        match self {
            TimeAxis::Cpu => Some(m.time.as_secs_f64() * 1e3),
            TimeAxis::Predicted => m.predicted_ms,
        }
    }

    fn caption(self) -> &'static str {
        match self {
            TimeAxis::Cpu => "shadec bench: error against time per frame",
            TimeAxis::Predicted => "shadec bench: error against the predicted frame on the target",
        }
    }

    fn description(self) -> &'static str {
        match self {
            TimeAxis::Cpu => "ms per frame (median, measured)",
            TimeAxis::Predicted => "ms per frame predicted on the target (cost model)",
        }
    }
}

/// The Pareto front of each group on `axis` (with the predicted time: of
/// each group and target): the variants no other of the
/// same set beats in both time and RMSE. Exact renders are references, not
/// approximations, and stay off.
pub fn fronts(measured: &[Measured], axis: TimeAxis) -> Vec<usize> {
    let mut on_front = Vec::new();
    for (group, target) in measured.iter().map(|m| (m.group, m.variant.target)) {
        let members: Vec<usize> = (0..measured.len())
            .filter(|&i| {
                let m = &measured[i];
                m.group == group
                    && (axis == TimeAxis::Cpu || m.variant.target == target)
                    && m.variant.mode != crate::numerics::Precision::Exact
                    && axis.ms(m).is_some()
            })
            .collect();
        let pts: Vec<(f64, f64)> = members
            .iter()
            .map(|&i| (axis.ms(&measured[i]).unwrap_or_default(), measured[i].error.rmse))
            .collect();
        for k in pareto_front(&pts) {
            if !on_front.contains(&members[k]) {
                on_front.push(members[k]);
            }
        }
    }
    on_front.sort();
    on_front
}

/// Error (RMSE against the group's truth) against time per frame, log-log,
/// one colour per group, the Pareto front joined and its points labelled.
pub fn speed_vs_error(measured: &[Measured], path: &Path) -> Result<(), BenchError> {
    error_against(measured, TimeAxis::Cpu, path)
}

/// Error against the predicted frame on each variant's target,
/// the front of each group and target joined: `predicted_vs_error.png`.
pub fn predicted_vs_error(measured: &[Measured], path: &Path) -> Result<(), BenchError> {
    let predicted: Vec<Measured> = measured.iter().filter(|m| m.predicted_ms.is_some()).cloned().collect();
    error_against(&predicted, TimeAxis::Predicted, path)
}

/// The groups of the measured variants, in the order they first appear.
fn groups_of(measured: &[Measured]) -> Vec<&str> {
    measured.iter().fold(Vec::new(), |mut g, m| {
        if !g.contains(&m.group) {
            g.push(m.group);
        }
        g
    })
}

/// Each point's label: its variant, `*` on its group's Pareto front.
fn point_labels(measured: &[Measured], fronts: &[usize]) -> Vec<String> {
    measured
        .iter()
        .enumerate()
        .map(
            |(i, m)| {
                if fronts.contains(&i) {
                    format!("{} *", m.variant.name)
                } else {
                    m.variant.name.to_string()
                }
            },
        )
        .collect()
}

fn error_against(measured: &[Measured], axis: TimeAxis, path: &Path) -> Result<(), BenchError> {
    register_font();
    let points: Vec<(f64, f64)> =
        measured.iter().map(|m| (axis.ms(m).unwrap_or_default(), m.error.rmse.max(RMSE_FLOOR))).collect();
    let fronts = fronts(measured, axis);
    let (x0, x1) = bounds(points.iter().map(|p| p.0));
    let (y0, y1) = bounds(points.iter().map(|p| p.1));
    // Room above the points for the legend.
    let y1 = y1 * 50.0;
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(axis.caption(), (FONT, 24))
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc(axis.description())
            .y_desc(format!("RMSE against exact (floor {RMSE_FLOOR:e})"))
            .x_labels(8)
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style((FONT, 14))
            .draw()
            .map_err(plot_error)?;
        let groups = groups_of(measured);
        for (gi, group) in groups.iter().enumerate() {
            let colour = Palette99::pick(gi).to_rgba();
            let pts: Vec<(f64, f64)> =
                measured.iter().zip(&points).filter(|(m, _)| m.group == *group).map(|(_, p)| *p).collect();
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 6, colour.filled())))
                .map_err(plot_error)?
                .label(group.to_string())
                .legend(move |(x, y)| Circle::new((x + 8, y), 6, colour.filled()));
        }
        for (gi, group) in groups.iter().enumerate() {
            let colour = Palette99::pick(gi).to_rgba();
            let mut targets: Vec<&str> = measured.iter().map(|m| m.variant.target).collect();
            targets.sort_unstable();
            targets.dedup();
            if axis == TimeAxis::Cpu {
                targets.truncate(1);
            }
            for (ti, target) in targets.iter().enumerate() {
                let mut front: Vec<(f64, f64)> = (0..measured.len())
                    .filter(|i| measured[*i].group == *group && fronts.contains(i))
                    .filter(|i| axis == TimeAxis::Cpu || measured[*i].variant.target == *target)
                    .map(|i| points[i])
                    .collect();
                front.sort_by(|a, b| a.0.total_cmp(&b.0));
                let series =
                    chart.draw_series(LineSeries::new(front, colour.stroke_width(2))).map_err(plot_error)?;
                if gi == 0 && ti == 0 {
                    series
                        .label("Pareto front of each group (*)")
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.stroke_width(2)));
                }
            }
        }
        let labels = point_labels(measured, &fronts);
        let anchors: Vec<(i32, i32)> = points.iter().map(|p| chart.backend_coord(p)).collect();
        draw_labels(&root, &labels, &anchors, plot_box(&chart), 13)?;
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 13))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    save(&buf, path)
}

/// One program's plans on each target (`bench --program`): largest error against the predicted frame, log-log, one colour per
/// target, each target's front joined and its points labelled with their
/// rules. A target without a cost model (wgsl) is in the table only —
/// unless no target has one, when passes stand in for time.
pub fn front(rows: &[super::front::FrontRow], program: &str, path: &Path) -> Result<(), BenchError> {
    register_font();
    let any_predicted = rows.iter().any(|r| r.predicted_ms.is_some());
    let rows: Vec<super::front::FrontRow> =
        rows.iter().filter(|r| !any_predicted || r.predicted_ms.is_some()).cloned().collect();
    let points: Vec<(f64, f64)> =
        rows.iter().map(|r| (r.time().max(1e-6), r.max_abs.max(RMSE_FLOOR))).collect();
    let (x0, x1) = bounds(points.iter().map(|p| p.0));
    let (y0, y1) = bounds(points.iter().map(|p| p.1));
    // Room for the labels right of the points and the legend above them.
    let (x1, y1) = (x1 * 6.0, y1 * 20.0);
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("{program}: error against the predicted frame"), (FONT, 22))
            .margin(20)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc(if any_predicted {
                "ms per frame predicted on the target (cost model)"
            } else {
                "passes"
            })
            .y_desc(format!("max abs error against the meaning (floor {RMSE_FLOOR:e})"))
            .x_labels(8)
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .label_style((FONT, 14))
            .draw()
            .map_err(plot_error)?;
        let mut targets: Vec<&str> = rows.iter().map(|r| r.target.as_str()).collect();
        targets.dedup();
        for (ti, target) in targets.iter().enumerate() {
            let colour = Palette99::pick(ti).to_rgba();
            let mine: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].target == *target).collect();
            chart
                .draw_series(mine.iter().map(|&i| Circle::new(points[i], 6, colour.filled())))
                .map_err(plot_error)?
                .label(target.to_string())
                .legend(move |(x, y)| Circle::new((x + 8, y), 6, colour.filled()));
            let mut on: Vec<(f64, f64)> =
                mine.iter().filter(|&&i| rows[i].on_front).map(|&i| points[i]).collect();
            on.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart.draw_series(LineSeries::new(on, colour.stroke_width(2))).map_err(plot_error)?;
        }
        let labels: Vec<String> =
            rows.iter().map(|r| format!("{}{}", r.rules, if r.on_front { " *" } else { "" })).collect();
        let anchors: Vec<(i32, i32)> = points.iter().map(|p| chart.backend_coord(p)).collect();
        draw_labels(&root, &labels, &anchors, plot_box(&chart), 12)?;
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 13))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    save(&buf, path)
}

/// Adaptive shading: share of pixels shaded and PSNR against the threshold,
/// one line per scene.
pub fn adaptive(rows: &[AdaptiveRow], path: &Path) -> Result<(), BenchError> {
    register_font();
    let mut buf = vec![0u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let (upper, lower) = root.split_vertically(H / 2);
        let scenes: Vec<&str> = rows.iter().fold(Vec::new(), |mut s, r| {
            if !s.contains(&r.scene) {
                s.push(r.scene);
            }
            s
        });
        let t1 = rows.iter().map(|r| 100.0 * r.threshold as f64).fold(1.0, f64::max) * 1.05;
        for (area, title, value, legend) in [
            (
                &upper,
                "pixels shaded (%) against the threshold (%)",
                (|r: &AdaptiveRow| 100.0 * r.fraction_shaded) as fn(&AdaptiveRow) -> f64,
                SeriesLabelPosition::UpperRight,
            ),
            (
                &lower,
                "PSNR against full shading (dB) against the threshold (%)",
                |r: &AdaptiveRow| r.psnr.min(120.0),
                SeriesLabelPosition::LowerLeft,
            ),
        ] {
            let y1 = rows.iter().map(value).fold(1.0, f64::max) * 1.1;
            let mut chart = ChartBuilder::on(area)
                .caption(title, (FONT, 18))
                .margin(15)
                .x_label_area_size(35)
                .y_label_area_size(60)
                .build_cartesian_2d(0.0..t1, 0.0..y1)
                .map_err(plot_error)?;
            chart.configure_mesh().label_style((FONT, 13)).draw().map_err(plot_error)?;
            for (si, scene) in scenes.iter().enumerate() {
                let colour = Palette99::pick(si).to_rgba();
                let pts: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| r.scene == *scene)
                    .map(|r| (100.0 * r.threshold as f64, value(r)))
                    .collect();
                chart
                    .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                    .map_err(plot_error)?
                    .label(scene.to_string())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
                    });
                chart
                    .draw_series(pts.iter().map(|p| Circle::new(*p, 4, colour.filled())))
                    .map_err(plot_error)?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font((FONT, 12))
                .position(legend)
                .draw()
                .map_err(plot_error)?;
        }
        root.present().map_err(plot_error)?;
    }
    save(&buf, path)
}

/// A box in pixels: left, top, right, bottom (exclusive).
type PixelBox = (i32, i32, i32, i32);

/// The chart's plotting area in pixels of the root drawing area.
fn plot_box<DB: DrawingBackend, X: Ranged, Y: Ranged>(
    chart: &ChartContext<'_, DB, Cartesian2d<X, Y>>,
) -> PixelBox {
    let (x, y) = chart.plotting_area().get_pixel_range();
    (x.start, y.start, x.end, y.end)
}

/// The marker radius the points are drawn with, kept clear of labels.
const MARKER: i32 = 6;

/// Draws each label next to its point where it overlaps no other label and
/// no marker ([`place_labels`]), with a thin leader line when it had to move
/// away from its point.
fn draw_labels(
    root: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    labels: &[String],
    anchors: &[(i32, i32)],
    area: PixelBox,
    size: u32,
) -> Result<(), BenchError> {
    let sizes: Vec<(i32, i32)> = labels.iter().map(|l| text_size(l, size)).collect();
    let placed = place_labels(anchors, &sizes, area);
    for ((label, &(ax, ay)), &(x, y)) in labels.iter().zip(anchors).zip(&placed) {
        let (w, h) = text_size(label, size);
        // The nearest point of the label's box to its point.
        let (nx, ny) = (ax.clamp(x, x + w), ay.clamp(y, y + h));
        if (nx - ax).pow(2) + (ny - ay).pow(2) > (3 * MARKER).pow(2) {
            root.draw(&PathElement::new(vec![(ax, ay), (nx, ny)], BLACK.mix(0.4).stroke_width(1)))
                .map_err(plot_error)?;
        }
        root.draw(&Text::new(label.clone(), (x, y), (FONT, size))).map_err(plot_error)?;
    }
    Ok(())
}

/// The box a label takes in the embedded monospace font: DejaVu Sans
/// Mono's advance is 0.602 em; a little more keeps a gap between labels.
fn text_size(label: &str, size: u32) -> (i32, i32) {
    let size = size as i32;
    ((label.chars().count() as i32 * size * 64 + 99) / 100 + 2, size + 2)
}

/// Top-left corners for labels of `sizes`, one beside each of `anchors`
/// (pixels), inside `area`: for each label in turn, the first of a ring of
/// candidate positions, nearest first, whose box overlaps no label placed
/// before it and no marker; where every candidate collides, the one with
/// the least overlap. Points in a crowd get their labels fanned out around
/// them instead of printed on top of each other.
pub fn place_labels(anchors: &[(i32, i32)], sizes: &[(i32, i32)], area: PixelBox) -> Vec<(i32, i32)> {
    let overlap = |a: PixelBox, b: PixelBox| -> i64 {
        let w = (a.2.min(b.2) - a.0.max(b.0)).max(0) as i64;
        let h = (a.3.min(b.3) - a.1.max(b.1)).max(0) as i64;
        w * h
    };
    let markers: Vec<PixelBox> =
        anchors.iter().map(|&(x, y)| (x - MARKER, y - MARKER, x + MARKER + 1, y + MARKER + 1)).collect();
    let mut placed: Vec<PixelBox> = Vec::with_capacity(anchors.len());
    let mut corners = Vec::with_capacity(anchors.len());
    for (&(ax, ay), &(w, h)) in anchors.iter().zip(sizes) {
        let gap = MARKER + 3;
        let mut best: Option<((i32, i32), i64)> = None;
        // Rings of growing distance; on each, right, left, above and below
        // first, then the diagonals, then points between.
        'rings: for ring in 0..12 {
            let d = ring * (h + 2);
            let candidates = [
                (ax + gap + d, ay - h / 2),
                (ax - gap - d - w, ay - h / 2),
                (ax - w / 2, ay - gap - d - h),
                (ax - w / 2, ay + gap + d),
                (ax + gap + d, ay - gap - d - h),
                (ax + gap + d, ay + gap + d),
                (ax - gap - d - w, ay - gap - d - h),
                (ax - gap - d - w, ay + gap + d),
                (ax + gap, ay - h / 2 - d - h),
                (ax + gap, ay - h / 2 + d + h),
                (ax - gap - w, ay - h / 2 - d - h),
                (ax - gap - w, ay - h / 2 + d + h),
            ];
            for (x, y) in candidates {
                // Inside the plotting area, or pushed back into it.
                let x = x.clamp(area.0, (area.2 - w).max(area.0));
                let y = y.clamp(area.1, (area.3 - h).max(area.1));
                let b = (x, y, x + w, y + h);
                let cost: i64 = placed.iter().chain(&markers).map(|&o| overlap(b, o)).sum();
                if best.is_none_or(|(_, c)| cost < c) {
                    best = Some(((x, y), cost));
                }
                if cost == 0 {
                    break 'rings;
                }
            }
        }
        let ((x, y), _) = best.unwrap_or(((ax, ay), 0));
        placed.push((x, y, x + w, y + h));
        corners.push((x, y));
    }
    corners
}

/// A log-scale range around the values, a little wider.
fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() || hi <= 0.0 {
        return (1e-3, 1.0);
    }
    (lo / 2.0, hi * 2.0)
}

#[cfg(test)]
mod tests {
    use super::{pareto_front, place_labels, MARKER};

    /// A crowd of points, all within a few pixels (what the bench's Phong
    /// variants are on the plot): every label gets a box of its own, off
    /// every marker, inside the area.
    #[test]
    fn labels_of_a_crowd_do_not_overlap() {
        let anchors: Vec<(i32, i32)> = (0..9).map(|i| (400 + 3 * (i % 3), 300 + 4 * (i / 3))).collect();
        let sizes: Vec<(i32, i32)> = (0..9).map(|i| (60 + 10 * i, 15)).collect();
        let area = (100, 50, 900, 650);
        let corners = place_labels(&anchors, &sizes, area);
        let boxes: Vec<(i32, i32, i32, i32)> =
            corners.iter().zip(&sizes).map(|(&(x, y), &(w, h))| (x, y, x + w, y + h)).collect();
        let meets = |a: (i32, i32, i32, i32), b: (i32, i32, i32, i32)| {
            a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
        };
        for (i, &a) in boxes.iter().enumerate() {
            assert!(
                a.0 >= area.0 && a.1 >= area.1 && a.2 <= area.2 && a.3 <= area.3,
                "label {i} leaves the area"
            );
            for (j, &b) in boxes.iter().enumerate().skip(i + 1) {
                assert!(!meets(a, b), "labels {i} and {j} overlap: {a:?} {b:?}");
            }
            for &(x, y) in &anchors {
                assert!(
                    !meets(a, (x - MARKER, y - MARKER, x + MARKER + 1, y + MARKER + 1)),
                    "label {i} covers a point"
                );
            }
        }
    }

    /// A lone point keeps its label right beside it.
    #[test]
    fn a_lone_label_sits_next_to_its_point() {
        let corners = place_labels(&[(300, 300)], &[(80, 15)], (0, 0, 1000, 700));
        let (x, y) = corners[0];
        assert!(x > 300 && x < 300 + 3 * MARKER && (y - 300).abs() <= 15, "{corners:?}");
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_points() {
        // (time, error): b dominates c; a is fastest, d most accurate.
        let pts = [(1.0, 0.5), (2.0, 0.1), (3.0, 0.2), (4.0, 0.01)];
        assert_eq!(pareto_front(&pts), [0, 1, 3]);
    }
}
