//! `shadec bench --program FILE --target T…`: the Pareto front of one
//! program on each target — every plan the compiler has
//! for it (as written where it plans, then each choice of lowering rules,
//! [`crate::accuracy::measure`]) with its passes, its frame predicted on
//! the target's cost model, and its error against the program's meaning on
//! the scene; the plans no other beats in both time and error are the
//! front. Written as `front.md` (a table per target) and `front.png`.

use std::fmt::Write as _;
use std::path::Path;

use super::plot::pareto_front;
use super::BenchError;
use crate::driver::{ForScene, PlanOptions};
use crate::profile::Profile;
use crate::scene::{Scene, SceneAssets};

/// One plan of the program on one target.
#[derive(Clone, Debug)]
pub struct FrontRow {
    pub target: String,
    /// Its rules (`as written` when nothing was lowered).
    pub rules: String,
    pub passes: usize,
    /// The frame predicted on the target (ms); without a cost model, the
    /// passes stand in for time.
    pub predicted_ms: Option<f64>,
    pub max_abs: f64,
    pub rmse: f64,
    pub on_front: bool,
}

impl FrontRow {
    /// The time axis: predicted ms, else passes.
    pub fn time(&self) -> f64 {
        self.predicted_ms.unwrap_or(self.passes as f64)
    }
}

/// A target the program has no plan for, with the compiler's refusal.
#[derive(Clone, Debug)]
pub struct Refused {
    pub target: String,
    pub diagnostics: Vec<crate::diag::Diagnostic>,
}

/// The rows of `source` on every profile in `targets`, measured on `scene`,
/// and the targets it has no plan for.
pub fn measure(
    source: &str,
    targets: &[Profile],
    scene: &Scene,
    assets: &SceneAssets,
) -> Result<(Vec<FrontRow>, Vec<Refused>), BenchError> {
    let front = crate::driver::front(source);
    let Some(module) = front.module.as_ref() else {
        let first =
            front.diagnostics.iter().find(|d| d.is_error()).map_or(String::new(), |d| d.message.clone());
        return Err(super::failed("the program", first));
    };
    let options = PlanOptions { scene: Some(ForScene::specialized(scene, assets)), ..Default::default() };
    let mut rows = Vec::new();
    let mut refused = Vec::new();
    for profile in targets {
        let measured =
            crate::accuracy::measure(module, &front.program, profile, source, &options, scene.lights.len())
                .map_err(|d| super::failed(&profile.name, d.first().map_or("", |d| d.message.as_str())))?;
        if measured.is_empty() {
            let diagnostics = crate::driver::plan(module, &front.program, profile, Some(source), &options)
                .err()
                .unwrap_or_default();
            refused.push(Refused { target: profile.name.clone(), diagnostics });
            continue;
        }
        let first = rows.len();
        for (_, c) in measured {
            rows.push(FrontRow {
                target: profile.name.clone(),
                rules: c.rules,
                passes: c.passes,
                predicted_ms: c.predicted_ms,
                max_abs: f64::from(c.error.max_abs),
                rmse: c.error.rmse,
                on_front: false,
            });
        }
        let points: Vec<(f64, f64)> = rows[first..].iter().map(|r| (r.time(), r.max_abs)).collect();
        for k in pareto_front(&points) {
            rows[first + k].on_front = true;
        }
    }
    Ok((rows, refused))
}

/// `front.md`: a table per target, fastest first.
pub fn report(program: &str, scene: &str, rows: &[FrontRow], refused: &[Refused]) -> String {
    let mut out = format!(
        "# Pareto front of `{program}`\n\nEvery plan the compiler has for the program on each target — as written \
         where it plans, then each choice of lowering rules — measured on `{scene}`: its error is the f32 render \
         against the f32 render of the program's meaning (largest channel difference and RMSE), its time the frame \
         the target's cost model predicts (passes where the target has none). `*`: on the front (no other plan is \
         both faster and more accurate).\n"
    );
    let mut targets: Vec<&str> = rows.iter().map(|r| r.target.as_str()).collect();
    targets.dedup();
    for target in targets {
        let _ = write!(
            out,
            "\n## {target}\n\n| | rules | passes | predicted ms | max abs (/255) | RMSE |\n|---|---|---|---|---|---|\n"
        );
        let mut mine: Vec<&FrontRow> = rows.iter().filter(|r| r.target == target).collect();
        mine.sort_by(|a, b| a.time().total_cmp(&b.time()));
        for r in mine {
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {:.1} | {:.5} |",
                if r.on_front { "*" } else { "" },
                r.rules,
                r.passes,
                r.predicted_ms.map_or("—".to_string(), |t| format!("{t:.3}")),
                r.max_abs * 255.0,
                r.rmse
            );
        }
    }
    for r in refused {
        let why = r.diagnostics.first().map_or(String::new(), |d| d.message.clone());
        let _ = write!(out, "\nRefused on {}: {why}\n", r.target);
    }
    out
}

/// Measures, then writes `front.md` and `front.png` into `out_dir`.
pub fn run(
    program_name: &str,
    source: &str,
    targets: &[Profile],
    scene: &Scene,
    out_dir: &Path,
) -> Result<(Vec<FrontRow>, Vec<Refused>), BenchError> {
    let assets = scene.build().map_err(|e| super::failed("the scene", e))?;
    let (rows, refused) = measure(source, targets, scene, &assets)?;
    std::fs::create_dir_all(out_dir).map_err(|e| BenchError::Io(format!("{}: {e}", out_dir.display())))?;
    let scene_name =
        scene.path.file_name().map_or("the built-in scene".into(), |f| f.to_string_lossy().into_owned());
    let text = report(program_name, &scene_name, &rows, &refused);
    crate::io::write_atomic(&out_dir.join("front.md"), text.as_bytes())
        .map_err(|e| BenchError::Io(e.to_string()))?;
    if !rows.is_empty() {
        super::plot::front(&rows, program_name, &out_dir.join("front.png"))?;
    }
    Ok((rows, refused))
}
