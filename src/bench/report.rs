//! `bench/report.md`, the plots and the difference images.

use std::fmt::Write as _;
use std::path::Path;

use super::adaptive::{AdaptiveRow, SPACING};
use super::timing::Timing;
use super::{BenchError, BenchOptions, Measured};

/// Difference images show |variant − truth| per channel times this, so that
/// 1/255 of error is 8 levels (clamped at 255).
pub const DIFF_SCALE: f32 = 8.0;

/// What a bench run measured, and report.md written from it.
pub struct Report {
    pub options: BenchOptions,
    pub measured: Vec<Measured>,
    /// Variants `--max-error` refused: no lowering within the error.
    pub refused: Vec<String>,
    pub adaptive: Vec<AdaptiveRow>,
    /// `removal_report`s in Markdown.
    pub removed: String,
    /// The cost model's predictions checked against the papers.
    pub hardware: Option<Hardware>,
}

/// GeForce3 Phong, Section 5.4 and Kilgard on the cost model ([`super::timing`]).
pub struct Hardware {
    pub section_5_4: Vec<Timing>,
    pub kilgard: [Timing; 2],
}

fn io(e: impl std::fmt::Display) -> BenchError {
    BenchError::Io(e.to_string())
}

impl Report {
    /// Writes everything into `dir` (created if needed), each file atomically.
    pub fn write(&self, dir: &Path) -> Result<(), BenchError> {
        let diff_dir = dir.join("diff");
        std::fs::create_dir_all(&diff_dir)
            .map_err(|e| io(format!("{}: cannot create: {e}", diff_dir.display())))?;
        for m in &self.measured {
            let png = difference_png(m)?;
            crate::io::write_atomic(&diff_dir.join(format!("{}.png", m.variant.name)), &png).map_err(io)?;
        }
        if !self.measured.is_empty() {
            super::plot::speed_vs_error(&self.measured, &dir.join("speed_vs_error.png"))?;
        }
        if self.measured.iter().any(|m| m.predicted_ms.is_some()) {
            super::plot::predicted_vs_error(&self.measured, &dir.join("predicted_vs_error.png"))?;
        }
        if !self.adaptive.is_empty() {
            super::plot::adaptive(&self.adaptive, &dir.join("adaptive.png"))?;
        }
        crate::io::write_atomic(&dir.join("report.md"), self.markdown().as_bytes()).map_err(io)
    }

    /// How the times were taken: `the CPU renderer's (renderer::plan) wall
    /// time`, or the wgpu clock(s).
    fn clocks(&self) -> String {
        let mut clocks: Vec<&str> = self.measured.iter().map(|m| m.clock.name()).collect();
        clocks.sort_unstable();
        clocks.dedup();
        match clocks.as_slice() {
            [] | ["CPU wall time"] => "the CPU renderer's (`renderer::plan`) wall time".to_string(),
            _ => format!("wgpu's ({}; the adapter is named in the run's output)", clocks.join(", ")),
        }
    }

    /// The report's title, how it measured, and the refusals of `--max-error`.
    fn intro_section(&self) -> String {
        let o = &self.options;
        let mut md = String::new();
        let _ = writeln!(md, "# shadec bench\n");
        let _ = writeln!(
            md,
            "`shadec bench` at {}×{}, median of {} run{} after a warm-up, {} threads. Times are {} per frame \
             (median); errors are against each group's ground truth: the `exact` render \
             (f64, vectors renormalized after interpolation, true pow, no lookup tables) of the group's reference \
             program on the same scene. RMSE and max abs are over RGB in [0, 1]; PSNR in dB. Difference images: \
             `diff/VARIANT.png`, |variant − truth| × {DIFF_SCALE} per channel. Plot: `speed_vs_error.png`; `*` marks \
             each group's Pareto front among its approximations (no variant of the group both faster and more \
             accurate).\n",
            o.size.0,
            o.size.1,
            o.runs,
            if o.runs == 1 { "" } else { "s" },
            rayon::current_num_threads(),
            self.clocks()
        );
        if let Some(e) = o.max_error {
            let _ = writeln!(
                md,
                "With `--max-error {e}`: a variant the compiler lowers takes the lowering predicted fastest whose f32 \
                 render is within {e} of its program's meaning on the group's scene (docs/lowering.md).\n"
            );
            for r in &self.refused {
                let _ = writeln!(md, "- refused: {r}");
            }
            if !self.refused.is_empty() {
                md.push('\n');
            }
        }
        md
    }

    /// One table per group of variants, each followed by what its fixed9
    /// rows ran.
    fn measured_section(&self) -> String {
        let mut md = String::new();
        let front = super::plot::group_fronts(&self.measured);
        let mut group = "";
        // What each fixed9 row ran, written under its group's table.
        let mut fixed9_notes: Vec<String> = Vec::new();
        let flush = |md: &mut String, notes: &mut Vec<String>| {
            if !notes.is_empty() {
                let _ = writeln!(md, "\nWhat the fixed9 rows ran, per pass:\n");
                for n in notes.drain(..) {
                    let _ = writeln!(md, "- {n}");
                }
            }
        };
        for (i, m) in self.measured.iter().enumerate() {
            if m.group != group {
                flush(&mut md, &mut fixed9_notes);
                group = m.group;
                let _ = writeln!(md, "\n## {group}\n");
                let _ = writeln!(md, "| variant | program | target | mode | passes | ms/frame | max abs (/255) | RMSE | PSNR (dB) | approximates |");
                let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
            }
            let psnr =
                if m.error.psnr.is_infinite() { "∞".to_string() } else { format!("{:.2}", m.error.psnr) };
            let _ = writeln!(
                md,
                "| {}{} | `{}` | {} | {} | {} | {:.2} | {:.1} | {:.5} | {} | {} |",
                m.variant.name,
                if front.contains(&i) { " *" } else { "" },
                m.variant.program.name,
                m.variant.target,
                m.variant.mode.name(),
                m.passes,
                m.time.as_secs_f64() * 1e3,
                m.error.max_abs * 255.0,
                m.error.rmse,
                psnr,
                m.variant.approximates
            );
            if m.variant.mode == crate::numerics::Precision::Fixed9 {
                let passes: Vec<String> = m
                    .shading
                    .iter()
                    .enumerate()
                    .map(|(k, s)| format!("pass {}: {}", k + 1, s.describe()))
                    .collect();
                fixed9_notes.push(format!("`{}` — {}", m.variant.name, passes.join("; ")));
            }
        }
        flush(&mut md, &mut fixed9_notes);
        md
    }

    /// The Adaptive Sample Shading table (none when it was not measured).
    fn adaptive_section(&self) -> String {
        let mut md = String::new();
        if self.adaptive.is_empty() {
            return md;
        }
        let _ = writeln!(
            md,
            "\n## Adaptive sample shading (Adaptive Sample Shading, Section 2.1)\n\nThe native multi-light Phong stage with per-polygon \
             light relevance (Adaptive Sample Shading, Section 2.2) in full, against adaptive shading with regular samples every {SPACING} \
             pixels; both timed in this run. The paper shades 19.25 % of the pixels of its 4-light sphere and 5.12 % of its \
             cube scene at threshold 8.5 %, with no visible difference.\n"
        );
        let _ = writeln!(md, "| scene | threshold | pixels shaded | paper | full (ms) | adaptive (ms) | speed-up | max abs (/255) | PSNR (dB) |");
        let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|");
        for r in &self.adaptive {
            let psnr = if r.psnr.is_infinite() { "∞".to_string() } else { format!("{:.2}", r.psnr) };
            let _ = writeln!(
                md,
                "| {} | {:.1} % | {:.2} % | {} | {:.2} | {:.2} | {:.2}× | {:.1} | {} |",
                r.scene,
                100.0 * r.threshold,
                100.0 * r.fraction_shaded,
                r.paper_fraction.map_or(String::new(), |p| format!("{:.2} %", 100.0 * p)),
                r.full_time.as_secs_f64() * 1e3,
                r.adaptive_time.as_secs_f64() * 1e3,
                r.speedup(),
                r.max_abs * 255.0,
                psnr
            );
        }
        let _ = writeln!(md, "\nPlot: `adaptive.png`.");
        md
    }

    /// The whole report.md: how it measured, the groups' tables, adaptive
    /// shading, predicted speed on the hardware and removed work.
    pub fn markdown(&self) -> String {
        let mut md = self.intro_section();
        md += &self.measured_section();
        md += &self.adaptive_section();
        md += &self.predicted_section();
        if !self.removed.is_empty() {
            let _ = writeln!(md, "\n## Removed work (scene-driven specialization)\n\n{}", self.removed);
        }
        md
    }
}

impl Report {
    /// Speed on the hardware: each group's variants on targets
    /// with a cost model ranked by predicted time, with the CPU's time and
    /// the error beside; then the papers' own timings against the model.
    fn predicted_section(&self) -> String {
        let mut md = String::new();
        let _ = writeln!(
            md,
            "\n## Predicted on the hardware (cost model)\n\nThe frame time each plan's target would take \
             (`docs/cost-model.md`: fill, vertex, setup and memory per pass) on the group's scene at the bench size, \
             fastest first, beside the measured time and the error measured above; `*` marks the Pareto front \
             of each group and target (no variant for the same target both predicted faster and more accurate; \
             plot: `predicted_vs_error.png`). Variants planned for `wgsl` have no cost model and are left out.\n"
        );
        let mut groups: Vec<&str> = self.measured.iter().map(|m| m.group).collect();
        groups.dedup();
        let front = super::plot::fronts(&self.measured, super::plot::TimeAxis::Predicted);
        for group in groups {
            let mut rows: Vec<(usize, &Measured)> = self
                .measured
                .iter()
                .enumerate()
                .filter(|(_, m)| m.group == group && m.predicted_ms.is_some())
                .collect();
            if rows.is_empty() {
                continue;
            }
            rows.sort_by(|(_, a), (_, b)| {
                a.predicted_ms.unwrap_or_default().total_cmp(&b.predicted_ms.unwrap_or_default())
            });
            let _ = writeln!(md, "**{group}**\n");
            let _ = writeln!(
                md,
                "| rank | variant | target | passes | predicted ms | measured ms | RMSE | max abs (/255) |"
            );
            let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
            for (k, (i, m)) in rows.iter().enumerate() {
                let _ = writeln!(
                    md,
                    "| {} | {}{} | {} | {} | {:.3} | {:.2} | {:.5} | {:.1} |",
                    k + 1,
                    m.variant.name,
                    if front.contains(i) { " *" } else { "" },
                    m.variant.target,
                    m.passes,
                    m.predicted_ms.unwrap_or_default(),
                    m.time.as_secs_f64() * 1e3,
                    m.error.rmse,
                    m.error.max_abs * 255.0
                );
            }
            let _ = writeln!(md);
        }
        if let Some(h) = &self.hardware {
            md += &hardware_tables(h);
        }
        md
    }
}

/// GeForce3 Phong, Section 5.4's table and Kilgard's passes, predicted.
fn hardware_tables(h: &Hardware) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "**GeForce3 Phong, Section 5.4** — GeForce3, a screen-filling mesh of 20 000 triangles \
         (`scenes/screen_mesh_20k.ron`, 1280×1024); speed relative to Gouraud shading:\n"
    );
    let _ = writeln!(md, "| shader | program | passes | predicted ms | predicted speed | paper |");
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    if let Some(gouraud) = h.section_5_4.first() {
        for t in &h.section_5_4 {
            let _ = writeln!(
                md,
                "| {} | `{}` | {} | {:.3} | {:.0} % | {} |",
                t.technique,
                t.program,
                t.passes,
                t.predicted_ms,
                100.0 * t.speed_against(gouraud),
                t.paper
            );
        }
    }
    let [g256, g3] = &h.kilgard;
    let _ = writeln!(
        md,
        "\n**Kilgard 2000**, the bump-mapped torus at 640×480: {} passes on {} predicted {:.3} ms, {} pass on {} \
         {:.3} ms ({:.1}×).\n",
        g256.passes,
        g256.target,
        g256.predicted_ms,
        g3.passes,
        g3.target,
        g3.predicted_ms,
        g256.predicted_ms / g3.predicted_ms
    );
    md
}

/// |variant − truth| × [`DIFF_SCALE`] as an opaque RGB PNG.
fn difference_png(m: &Measured) -> Result<Vec<u8>, BenchError> {
    let (a, b) = (m.image.to_rgba_f32(), m.truth.to_rgba_f32());
    let mut rgb = Vec::with_capacity(a.len() * 3);
    for (p, q) in a.iter().zip(&b) {
        for c in 0..3 {
            let d = (p[c].clamp(0.0, 1.0) - q[c].clamp(0.0, 1.0)).abs() * DIFF_SCALE;
            rgb.push((d * 255.0).round().clamp(0.0, 255.0) as u8);
        }
    }
    let mut bytes = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut bytes);
    image::ImageEncoder::write_image(
        encoder,
        &rgb,
        m.image.width(),
        m.image.height(),
        image::ExtendedColorType::Rgb8,
    )
    .map_err(io)?;
    Ok(bytes)
}
