//! Held-out user programs (`tests/data/heldout_twelfth/`), written as a
//! user would and not among the examples: dot3 bump mapping with generated
//! normal maps (with a highlight, with Kilgard's filtered length and
//! self-shadowing, under a cube-map reflection, under a projected cookie,
//! lit by two lights, signed), a ground plane crossing the eye plane (lit,
//! bumped, under a cookie projected from a light whose eye plane it also
//! crosses) and a modulate-2× detail map. Each names its scene and the
//! targets it plans on in its header (`// scene:`, `// targets:`); on each
//! it renders alike on the CPU, wgpu and the independent reference within
//! `three_way`'s bound in f32, and in fixed9 on the combiner targets
//! within `three_way_generated::fixed9_verdict`'s. A header may name
//! targets that refuse the program on its scene (`// refused:`), as
//! `render` refuses it there: the refusal is asserted.

use std::path::Path;

use shadec::numerics::Precision;
use shadec::scene::Scene;

use crate::three_way::{render_three, scene, verdict};

/// A folder of held-out programs under `tests/data/`.
pub fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

/// A scene of this folder, else of `scenes/`, with the programs' own
/// `image(…)` files read from this folder as `render --shader` reads them
/// (`Scene::program_dir`); a file that is nowhere renders as its stand-in.
fn held_out_scene(folder: &Path, name: &str) -> Scene {
    let own = folder.join(name);
    let sc = match std::fs::read_to_string(&own) {
        Ok(text) => Scene::parse(&text, &own).unwrap(),
        Err(_) => scene(name),
    };
    Scene { program_dir: Some(folder.to_path_buf()), ..sc }
}

fn header<'a>(source: &'a str, key: &str) -> &'a str {
    optional_header(source, key).unwrap_or_else(|| panic!("no `// {key}` line"))
}

fn optional_header<'a>(source: &'a str, key: &str) -> Option<&'a str> {
    source.lines().find_map(|l| l.strip_prefix("// ").and_then(|l| l.strip_prefix(key))).map(str::trim)
}

/// `Err` unless `render` (the one verdict, `verdict::judge`, on the scene,
/// its approximations measured there) refuses `program` for `target`.
fn refused_on(program: &str, target: &str, sc: &Scene, folder: &Path) -> Result<(), String> {
    let profile = shadec::profile::Profile::resolve(target).map_err(|e| format!("{e:?}"))?;
    let assets = sc.build().map_err(|e| e.to_string())?;
    let front = shadec::driver::front(program);
    let Some(module) = &front.module else { return Err("the program does not lower".into()) };
    let plan = shadec::driver::PlanOptions {
        scene: Some(shadec::driver::ForScene::specialized(sc, &assets)),
        ..Default::default()
    };
    let judging =
        shadec::verdict::Judging { plan, images: Some(folder), stand_ins: true, rendered_on: Some(sc) };
    match shadec::verdict::judge(module, &front.program, &profile, program, &judging) {
        Ok(judged) => Err(format!(
            "the header says {target} refuses it, and it plans there ({} passes)",
            judged.planned.plan.passes.len()
        )),
        Err(refused) => {
            let codes: Vec<_> = refused.iter().map(|d| d.code).collect();
            eprintln!("refused on {target}, as its header says: {codes:?}");
            Ok(())
        }
    }
}

/// Renders the held-out program `name` of `folder` three ways on every
/// target its header names: f32 everywhere, fixed9 too on the combiner
/// targets.
pub fn renders_alike_in(folder: &Path, name: &str) -> Result<(), String> {
    renders_alike(folder, name, false)
}

/// [`renders_alike_in`], and where a GPU runs the tests (lavapipe in CI),
/// wgpu must run every plan too: a refusal of the wgpu scene runner fails.
pub fn renders_alike_everywhere_in(folder: &Path, name: &str) -> Result<(), String> {
    renders_alike(folder, name, true)
}

fn renders_alike(folder: &Path, name: &str, wgpu_must_run: bool) -> Result<(), String> {
    let source = std::fs::read_to_string(folder.join(format!("{name}.shd"))).unwrap();
    let sc = held_out_scene(folder, header(&source, "scene:"));
    let g = crate::common::gpu::gpu();
    let mut failures = Vec::new();
    for target in optional_header(&source, "refused:").unwrap_or_default().split_whitespace() {
        if let Err(e) = refused_on(&format!("target {target};\n{source}"), target, &sc, folder) {
            failures.push(format!("{name} on {target}: {e}"));
        }
    }
    for target in header(&source, "targets:").split_whitespace() {
        let program = format!("target {target};\n{source}");
        let mut runs = vec![Precision::F32];
        if target != "wgsl" {
            runs.push(Precision::Fixed9);
        }
        for precision in runs {
            let result = render_three(&program, target, &sc, precision, g.as_ref()).and_then(|p| {
                if let Some(why) = &p.gpu_refused {
                    eprintln!("{name} on {target} ({precision:?}): wgpu does not run it: {why}");
                    if wgpu_must_run {
                        return Err(format!("wgpu does not run it: {why}"));
                    }
                }
                // A picture worth comparing: a tenth of the frame covered,
                // a quarter of that lit (the programs' own images, a decal
                // or a cut-out, leave much of it dark).
                let compared = p.compared_mask();
                let covered = p.compared();
                let lit = (0..compared.len()).filter(|&i| compared[i] && p.oracle[4 * i..4 * i + 3].iter().any(|&c| c > 8)).count();
                eprintln!("{name} on {target} ({precision:?}): {covered} pixels compared ({lit} lit), {} left out as latitude", p.left_out);
                if covered * 10 < p.covered.len() || lit * 4 < covered {
                    return Err(format!("a picture not worth comparing: {covered} covered, {lit} lit, {} left out", p.left_out));
                }
                match precision {
                    Precision::Fixed9 => crate::three_way_generated::fixed9_verdict(&p, &mut 0),
                    _ => verdict(&p),
                }
            });
            if let Err(e) = result {
                failures.push(format!("{name} on {target} ({precision:?}): {e}"));
            }
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("\n"))
    }
}

/// The named tests of a folder of held-out programs under `tests/data/`,
/// one a program ([`renders_alike_in`]), and a test that every program of
/// the folder has one.
macro_rules! held_out_in {
    ($folder:literal: $($name:ident),* $(,)?) => {
        $crate::three_way_heldout::held_out_by!(renders_alike_in, $folder: $($name),*);
    };
}
pub(crate) use held_out_in;

/// [`held_out_in!`] whose programs wgpu must run as well
/// ([`renders_alike_everywhere_in`]).
macro_rules! held_out_everywhere_in {
    ($folder:literal: $($name:ident),* $(,)?) => {
        $crate::three_way_heldout::held_out_by!(renders_alike_everywhere_in, $folder: $($name),*);
    };
}
pub(crate) use held_out_everywhere_in;

/// The tests of both: `$runner` judges each program.
macro_rules! held_out_by {
    ($runner:ident, $folder:literal: $($name:ident),*) => {
        $(
            #[test]
            fn $name() {
                let folder = $crate::three_way_heldout::data($folder);
                $crate::three_way_heldout::$runner(&folder, stringify!($name)).unwrap_or_else(|e| panic!("{e}"));
            }
        )*

        /// Every program of the folder has its named test above.
        #[test]
        fn every_program_of_the_folder_has_a_test() {
            $crate::three_way_heldout::each_has_a_test($folder, &[$(stringify!($name)),*]);
        }
    };
}
pub(crate) use held_out_by;

/// The program `name` of a held-out `folder`, its images found from the
/// repository's root (as `verdict::check` reads a source, not a file).
pub fn program_in(folder: &str, name: &str) -> String {
    std::fs::read_to_string(data(folder).join(format!("{name}.shd")))
        .unwrap()
        .replace("../../../examples/", "examples/")
}

/// Asserts that every `.shd` program of `folder` (under `tests/data/`) is
/// among `named`.
pub fn each_has_a_test(folder: &str, named: &[&str]) {
    for entry in std::fs::read_dir(data(folder)).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "shd") {
            let stem = path.file_stem().unwrap().to_string_lossy().to_string();
            assert!(named.contains(&stem.as_str()), "{stem} has no test");
        }
    }
}

held_out_in!("heldout_twelfth":
    dot3_specular_normal_map,
    diffuse_bump_self_shadow,
    bumped_cube_environment,
    cookie_over_bumps,
    two_light_bump,
    signed_bumps_diffuse,
    ground_plane_lit,
    ground_plane_bumped,
    detail_map_modulate2x,
    ground_plane_cookie,
);
