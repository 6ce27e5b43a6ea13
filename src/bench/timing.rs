//! GeForce3 Phong, Section 5.4's render-time comparison, rebuilt on the cost
//! model: the four shaders the paper times on a GeForce3 — a
//! screen-filling mesh of 20 000 triangles — planned by the compiler and
//! predicted on `scenes/screen_mesh_20k.ron`, each speed relative to
//! Gouraud shading beside the paper's; and Kilgard's bump mapping (Kilgard 2000)
//! in three passes on a GeForce 256 against one on a GeForce3.

use crate::driver::{ForScene, PlanOptions};
use crate::pipeline::PassPlan;
use crate::profile::Profile;
use crate::scene::Scene;

use super::variants::{BenchScene, Program, KILGARD, TORUS};
use super::{failed, BenchError};

/// The timing scene of GeForce3 Phong, Section 5.4.
pub const SCREEN_MESH: BenchScene =
    BenchScene { name: "scenes/screen_mesh_20k.ron", ron: include_str!("../../scenes/screen_mesh_20k.ron") };

macro_rules! example {
    ($file:literal) => {
        Program { name: concat!("examples/", $file), source: include_str!(concat!("../../examples/", $file)) }
    };
}

/// One shader of the comparison, as the paper states its speed.
#[derive(Clone, Copy, Debug)]
pub struct PaperShader {
    pub technique: &'static str,
    pub program: Program,
    /// The paper's figure, relative to Gouraud shading.
    pub paper: &'static str,
}

/// The four shaders of GeForce3 Phong, Section 5.4, Gouraud first.
pub fn section_5_4_shaders() -> [PaperShader; 4] {
    [
        PaperShader { technique: "Gouraud", program: example!("gouraud.shd"), paper: "100 %" },
        PaperShader {
            technique: "Phong, register-combiner normalization",
            program: example!("phong_exponent_squaring.shd"),
            paper: "80 %",
        },
        PaperShader {
            technique: "Phong, 16-bit cube map + texture-shader dot product (planned by squaring: no table stage generated yet)",
            program: example!("phong_exponent_lookup.shd"),
            paper: "about 50 %",
        },
        PaperShader {
            technique: "decal + bump mapping, register-combiner normalization",
            program: Program {
                name: "src/bench/programs/decal_bump_taylor.shd",
                source: include_str!("programs/decal_bump_taylor.shd"),
            },
            paper: "slightly less than 50 %",
        },
    ]
}

/// One predicted plan.
#[derive(Clone, Debug)]
pub struct Timing {
    pub technique: &'static str,
    pub program: &'static str,
    pub target: &'static str,
    pub passes: usize,
    /// The frame (ms) the target's cost model predicts.
    pub predicted_ms: f64,
    /// What limits each pass (`fill`, `vertex`, …).
    pub bounds: Vec<String>,
    /// The paper's figure, where it gives one.
    pub paper: &'static str,
}

impl Timing {
    /// Speed relative to `base` (1 = as fast).
    pub fn speed_against(&self, base: &Timing) -> f64 {
        base.predicted_ms / self.predicted_ms
    }
}

/// Plans `program` for `target` on `scene` and reads its prediction.
pub fn predict(
    program: Program,
    target: &'static str,
    scene: BenchScene,
) -> Result<(PassPlan, f64), BenchError> {
    let what = format!("{} on {target}", program.name);
    let scene = Scene::parse(scene.ron, std::path::Path::new(scene.name)).map_err(|e| failed(&what, e))?;
    let assets = scene.build().map_err(|e| failed(&what, e))?;
    let profile = Profile::resolve(target).map_err(|e| failed(&what, e))?;
    let options = PlanOptions { scene: Some(ForScene::specialized(&scene, &assets)), ..Default::default() };
    let compiled = crate::driver::compile(program.source, &profile, &options)
        .map_err(|d| failed(&what, d.first().map(|d| d.message.clone()).unwrap_or_default()))?;
    let plan = compiled.planned.plan;
    let total = plan.predicted.as_ref().map(|p| p.total_us / 1000.0);
    let total = total.ok_or_else(|| failed(&what, "the target has no cost model"))?;
    Ok((plan, total))
}

fn timing(
    technique: &'static str,
    program: Program,
    target: &'static str,
    scene: BenchScene,
    paper: &'static str,
) -> Result<Timing, BenchError> {
    let (plan, predicted_ms) = predict(program, target, scene)?;
    Ok(Timing {
        technique,
        program: program.name,
        target,
        passes: plan.passes.len(),
        predicted_ms,
        bounds: plan.passes.iter().filter_map(|p| p.predicted.as_ref().map(|t| t.bound.clone())).collect(),
        paper,
    })
}

/// GeForce3 Phong, Section 5.4 on geforce3, Gouraud first.
pub fn section_5_4() -> Result<Vec<Timing>, BenchError> {
    section_5_4_shaders()
        .into_iter()
        .map(|s| timing(s.technique, s.program, "geforce3", SCREEN_MESH, s.paper))
        .collect()
}

/// Kilgard's bump mapping on the torus: three passes on geforce256, one on geforce3.
pub fn kilgard() -> Result<[Timing; 2], BenchError> {
    let on = |target| timing("Kilgard's bump mapping", KILGARD, target, TORUS, "");
    Ok([on("geforce256")?, on("geforce3")?])
}
