//! Cube maps from images (docs/language.md, "Cube maps from images"):
//! every layout binds the faces OpenGL's Table 3.19 names, the renderers
//! and the reference agree on a program that reads one, equirectangular
//! panoramas resample within a stated error, and what cannot make a cube
//! map is a located error of `check` and `compile`.
//!
//! The images are generated here, into temporary folders. A face texel
//! (x, y) of face f holds (f + ½)/6 in red, (x + ½)/n in green and
//! (y + ½)/n in blue: every face, texel and corner is distinguishable, and
//! a direction's expected texel follows from the test's own statement of
//! Table 3.19, not from the code under test.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use shadec::numerics::Precision;
use shadec::scene::bind::{self, TextureQuality};
use shadec::scene::Scene;
use shadec::textures::cube_image::{self, equirect_face, equirect_sample, CubeLayout};
use shadec::textures::{CubeFace, Filter, Level, TexelFormat, Texture, TextureCube, Wrap};

use crate::common::shadec_in;
use crate::three_way::{render_three, scene, verdict};

/// GL Table 3.19 (OpenGL 1.3, Section 3.8.6), written out here: the face
/// (0..6: +x −x +y −y +z −z) and (s, t) of direction `r`.
fn table_3_19(r: [f64; 3]) -> (usize, f64, f64) {
    let [rx, ry, rz] = r;
    let (ax, ay, az) = (rx.abs(), ry.abs(), rz.abs());
    let (face, sc, tc, ma) = if ax >= ay && ax >= az {
        if rx > 0.0 {
            (0, -rz, -ry, ax)
        } else {
            (1, rz, -ry, ax)
        }
    } else if ay >= az {
        if ry > 0.0 {
            (2, rx, rz, ay)
        } else {
            (3, rx, -rz, ay)
        }
    } else if rz > 0.0 {
        (4, rx, -ry, az)
    } else {
        (5, -rx, -ry, az)
    };
    (face, (sc / ma + 1.0) / 2.0, (tc / ma + 1.0) / 2.0)
}

/// The synthetic face texel (see the module docs), in 8-bit steps.
fn face_texel(f: usize, x: u32, y: u32, n: u32) -> [u8; 4] {
    let q = |v: f64| (v * 255.0).round() as u8;
    [q((f as f64 + 0.5) / 6.0), q((x as f64 + 0.5) / n as f64), q((y as f64 + 0.5) / n as f64), 255]
}

/// Where face f lies in each layout (column, row, turned 180°), as
/// docs/language.md states the common unfolded cube.
fn placement(layout: &str, f: usize) -> (u32, u32, bool) {
    let cross = [(2, 1), (0, 1), (1, 0), (1, 2), (1, 1)];
    match (layout, f) {
        ("hstrip", f) => (f as u32, 0, false),
        ("vstrip", f) => (0, f as u32, false),
        ("hcross", 5) => (3, 1, false),
        ("vcross", 5) => (1, 3, true),
        (_, f) => (cross[f].0, cross[f].1, false),
    }
}

/// Writes the synthetic cube of `n`² faces in `layout` (or six files
/// `env_px.png` … for "faces") into `dir`; returns the `image(…)` argument.
fn write_layout(dir: &Path, layout: &str, n: u32) -> String {
    if layout == "faces" {
        for (f, name) in ["px", "nx", "py", "ny", "pz", "nz"].iter().enumerate() {
            let img = image::RgbaImage::from_fn(n, n, |x, y| image::Rgba(face_texel(f, x, y, n)));
            img.save(dir.join(format!("env_{name}.png"))).unwrap();
        }
        return "\"env_{face}.png\"".into();
    }
    let (a, b) = match layout {
        "hcross" => (4, 3),
        "vcross" => (3, 4),
        "hstrip" => (6, 1),
        _ => (1, 6),
    };
    let mut img = image::RgbaImage::from_pixel(a * n, b * n, image::Rgba([7, 7, 7, 255]));
    for f in 0..6 {
        let (col, row, turned) = placement(layout, f);
        for y in 0..n {
            for x in 0..n {
                let (px, py) = if turned { (n - 1 - x, n - 1 - y) } else { (x, y) };
                img.put_pixel(col * n + px, row * n + py, image::Rgba(face_texel(f, x, y, n)));
            }
        }
    }
    let file = format!("env_{layout}.png");
    img.save(dir.join(&file)).unwrap();
    format!("\"{file}\"")
}

/// The cube map the binder makes of `texture Env : cube … = image(arg)`,
/// paths relative to `dir` (a scene there).
fn bind_cube(dir: &Path, arg: &str, notes: &mut Vec<String>) -> Result<TextureCube, String> {
    let source = format!("texture Env : cube rgba8 nearest clamp = image({arg});\nC δπx ← Env δπx;\n");
    let (program, _) = shadec::parser::parse(&source);
    let decls = bind::texture_decls(&shadec::ir::lower(&program).0, &BTreeMap::new());
    let mut scene = scene("kilgard_torus.ron");
    scene.path = dir.join("scene.ron");
    let bound =
        bind::load_textures(&decls, &scene, TextureQuality::Stored, notes).map_err(|e| e.to_string())?;
    match &bound["Env"].texture {
        Texture::Cube(c) => Ok(c.clone()),
        other => Err(format!("not a cube map: {other:?}")),
    }
}

/// Deterministic directions over the sphere (a Fibonacci lattice).
fn directions(count: usize) -> impl Iterator<Item = [f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count).map(move |i| {
        let y = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
        let r = (1.0 - y * y).sqrt();
        let phi = golden * i as f64;
        [r * phi.cos(), y, r * phi.sin()]
    })
}

/// Every layout puts each face where Table 3.19 looks for it, upright and
/// unmirrored: a nearest lookup in direction d returns the synthetic
/// texel of the face and (s, t) the table gives for d.
#[test]
fn every_layout_follows_gl_table_3_19() {
    let n = 8;
    for layout in ["hcross", "vcross", "hstrip", "vstrip", "faces"] {
        let dir = tempfile::tempdir().unwrap();
        let arg = write_layout(dir.path(), layout, n);
        let mut notes = Vec::new();
        let cube = bind_cube(dir.path(), &arg, &mut notes).unwrap();
        assert!(notes.is_empty(), "{layout}: {notes:?}");
        assert_eq!(cube.size(), n, "{layout}");
        let mut checked = 0;
        for d in directions(4000) {
            let (face, s, t) = table_3_19(d);
            let (fx, fy) = (s * n as f64, t * n as f64);
            // Directions on a texel boundary could go either way.
            if (fx - fx.round()).abs() < 1e-3 || (fy - fy.round()).abs() < 1e-3 {
                continue;
            }
            let (x, y) = ((fx as u32).min(n - 1), (fy as u32).min(n - 1));
            let want = face_texel(face, x, y, n);
            let got = cube.sample(d.map(|c| c as f32), Filter::Nearest, 0.0);
            let got = got.map(|c| (c * 255.0).round() as u8);
            assert_eq!(got, want, "{layout}: direction {d:?} is face {face} texel ({x}, {y})");
            checked += 1;
        }
        assert!(checked > 3500, "{layout}: {checked}");
        // The four corners of every face, through the table's inverse.
        for face in 0..6 {
            for (s, t) in [(0.01, 0.01), (0.99, 0.01), (0.01, 0.99), (0.99, 0.99)] {
                let d = corner_direction(face, s, t);
                assert_eq!(table_3_19(d).0, face);
                let got =
                    cube.sample(d.map(|c| c as f32), Filter::Nearest, 0.0).map(|c| (c * 255.0).round() as u8);
                let (x, y) = ((s * n as f64) as u32, (t * n as f64) as u32);
                assert_eq!(got, face_texel(face, x, y, n), "{layout}: face {face} corner ({s}, {t})");
            }
        }
    }
}

/// Table 3.19 inverted for the test: the direction of (s, t) on `face`.
fn corner_direction(face: usize, s: f64, t: f64) -> [f64; 3] {
    let (sc, tc) = (2.0 * s - 1.0, 2.0 * t - 1.0);
    [[1.0, -tc, -sc], [-1.0, -tc, sc], [sc, 1.0, tc], [sc, -1.0, -tc], [sc, -tc, 1.0], [-sc, -tc, -1.0]][face]
}

/// Each layout of the same faces binds the same cube, texel for texel,
/// and so do six file names given one by one.
#[test]
fn each_layout_binds_the_same_cube() {
    let n = 16;
    let dir = tempfile::tempdir().unwrap();
    let mut cubes = Vec::new();
    for layout in ["faces", "hcross", "vcross", "hstrip", "vstrip"] {
        let arg = write_layout(dir.path(), layout, n);
        cubes.push((layout, bind_cube(dir.path(), &arg, &mut Vec::new()).unwrap()));
    }
    let six = ["px", "nx", "py", "ny", "pz", "nz"].map(|f| format!("\"env_{f}.png\"")).join(", ");
    cubes.push(("six names", bind_cube(dir.path(), &six, &mut Vec::new()).unwrap()));
    // The layout named instead of deduced.
    let named = bind_cube(dir.path(), "\"env_vcross.png\", \"vcross\"", &mut Vec::new()).unwrap();
    cubes.push(("vcross named", named));
    for (layout, cube) in &cubes[1..] {
        assert_eq!(cube, &cubes[0].1, "{layout} differs from six face files");
    }
}

/// A direction's colour in the synthetic smooth environment: each channel
/// a smooth function on the sphere.
fn smooth(d: [f64; 3]) -> [f64; 3] {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let [x, y, z] = d.map(|c| c / len);
    [0.5 + 0.5 * x, 0.5 + 0.5 * y, 0.5 + 0.25 * z + 0.25 * (2.0 * x * y)]
}

/// The direction through (u, v) of an equirectangular image, as
/// docs/language.md states it (−Z at the centre, +X to its right, +Y at the
/// top): φ = 2π(u − ½), θ = πv, d = (sin θ sin φ, cos θ, −sin θ cos φ).
fn equirect_direction(u: f64, v: f64) -> [f64; 3] {
    let (phi, theta) = (std::f64::consts::TAU * (u - 0.5), std::f64::consts::PI * v);
    [theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos()]
}

/// An equirectangular `w`×`w/2` image of `f`, each pixel f at its centre's direction.
fn equirect_level(w: u32, f: &dyn Fn([f64; 3]) -> [f64; 3]) -> Level {
    let h = w / 2;
    let texels = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = f(equirect_direction((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64));
            [c[0] as f32, c[1] as f32, c[2] as f32, 1.0]
        })
        .collect();
    Level::new(w, h, texels)
}

/// Equirectangular resampling, measured. A 256×128 panorama of a smooth
/// environment is resampled to faces of 64² (width/4), each texel the
/// panorama's bilinear sample through its centre; looked up bilinearly in
/// 20 000 directions, the cube differs from the direct bilinear lookup in
/// the panorama by at most 0.004 (about 1/255; measured 0.0032) and on
/// average 0.0001 (measured 0.00005), in f32 texels; the cube differs
/// from the environment itself by at most 0.005 (measured 0.0032).
/// Orientation: the panorama's pixels are placed by the test's own
/// (u, v) → direction formula, so a mirrored or rotated resampling fails.
#[test]
fn equirectangular_resampling_error_is_bounded() {
    let image = equirect_level(256, &smooth);
    let size = CubeLayout::Equirectangular.face_size(256);
    assert_eq!(size, 64);
    let faces = CubeFace::ALL.map(|f| {
        shadec::textures::Texture2D::new(TexelFormat::F32, Wrap::ClampToEdge, equirect_face(&image, f, size))
    });
    let cube = TextureCube { faces };
    let (mut max_resampling, mut sum, mut max_truth, mut count) = (0f64, 0f64, 0f64, 0);
    for d in directions(20_000) {
        let via_cube = cube.sample(d.map(|c| c as f32), Filter::Bilinear, 0.0);
        let direct = equirect_sample(&image, d);
        let truth = smooth(d);
        for c in 0..3 {
            let e = (f64::from(via_cube[c]) - f64::from(direct[c])).abs();
            max_resampling = max_resampling.max(e);
            sum += e;
            max_truth = max_truth.max((f64::from(via_cube[c]) - truth[c]).abs());
        }
        count += 3;
    }
    let mean = sum / count as f64;
    eprintln!("equirect 256×128 → 6×64²: max {max_resampling:.5}, mean {mean:.6} against the direct lookup; max {max_truth:.5} against the environment");
    assert!(max_resampling <= 0.004, "max {max_resampling}");
    assert!(mean <= 0.0001, "mean {mean}");
    assert!(max_truth <= 0.005, "against the environment: {max_truth}");
}

/// A 2:1 PNG read through `image("sky.png")` is resampled as the
/// equirectangular layout (faces of width/4), and `"equirect"` names it.
#[test]
fn an_equirectangular_image_binds_as_a_cube() {
    let dir = tempfile::tempdir().unwrap();
    let level = equirect_level(128, &smooth);
    let img = image::RgbaImage::from_fn(128, 64, |x, y| {
        image::Rgba(level.texel(x, y).map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8))
    });
    img.save(dir.path().join("sky.png")).unwrap();
    for arg in ["\"sky.png\"", "\"sky.png\", \"equirect\""] {
        let cube = bind_cube(dir.path(), arg, &mut Vec::new()).unwrap();
        assert_eq!(cube.size(), 32);
        for d in directions(500) {
            let got = cube.sample(d.map(|c| c as f32), Filter::Bilinear, 0.0);
            let want = smooth(d);
            for c in 0..3 {
                assert!((f64::from(got[c]) - want[c]).abs() < 0.03, "{arg}: {d:?}: {got:?} against {want:?}");
            }
        }
    }
}

/// The environment of [`a_cube_map_from_an_image_renders`]: faces of
/// `n`² in a horizontal or vertical cross, each texel the smooth
/// environment at its centre's direction (continuous across face edges),
/// or a 4n × 2n equirectangular panorama of it.
fn write_environment(dir: &Path, file: &str, layout: &str, n: u32) {
    if layout == "equirect" {
        let level = equirect_level(4 * n, &smooth);
        let img = image::RgbaImage::from_fn(4 * n, 2 * n, |x, y| {
            image::Rgba(level.texel(x, y).map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8))
        });
        return img.save(dir.join(file)).unwrap();
    }
    let (a, b) = if layout == "hcross" { (4, 3) } else { (3, 4) };
    let mut img = image::RgbaImage::from_pixel(a * n, b * n, image::Rgba([0, 0, 0, 255]));
    for f in 0..6 {
        let (col, row, turned) = placement(layout, f);
        for y in 0..n {
            for x in 0..n {
                let (s, t) = ((x as f64 + 0.5) / n as f64, (y as f64 + 0.5) / n as f64);
                let c = smooth(corner_direction(f, s, t));
                let (px, py) = if turned { (n - 1 - x, n - 1 - y) } else { (x, y) };
                let q = |v: f64| (v * 255.0).round() as u8;
                img.put_pixel(col * n + px, row * n + py, image::Rgba([q(c[0]), q(c[1]), q(c[2]), 255]));
            }
        }
    }
    img.save(dir.join(file)).unwrap();
}

/// A program reading an environment cube map from an image (a chrome
/// torus: the reflection vector looked up per pixel) renders on wgsl and
/// on a register-combiner target, and the CPU renderer, wgpu and the
/// independent reference (which reads the layouts with its own code)
/// agree. It failed at `render` ("a cube map from an image file is not
/// supported").
#[test]
fn a_cube_map_from_an_image_renders() {
    let dir = tempfile::tempdir().unwrap();
    let g = crate::common::gpu::gpu();
    let cases = [
        ("hcross", "wgsl", Precision::F32),
        ("vcross", "wgsl", Precision::F32),
        ("equirect", "wgsl", Precision::F32),
        ("hcross", "geforce3", Precision::Fixed9),
        ("vcross", "geforce256", Precision::Fixed9),
    ];
    for (layout, target, precision) in cases {
        let file = dir.path().join(format!("env_{layout}.png"));
        write_environment(dir.path(), file.file_name().unwrap().to_str().unwrap(), layout, 32);
        let source = format!(
            "vector R : reflection;\ntexture Env : cube rgb8 bilinear clamp = image(\"{}\");\nframebuffer C : rgba8, depth;\nC δπx ← Env δ R s x;\n",
            file.display()
        );
        let p = render_three(&source, target, &scene("kilgard_torus.ron"), precision, g.as_ref())
            .unwrap_or_else(|e| panic!("{layout} on {target}: {e}"));
        assert!(p.gpu_refused.is_none(), "{layout} on {target}: {:?}", p.gpu_refused);
        verdict(&p).unwrap_or_else(|e| panic!("{layout} on {target}: {e}"));
        assert!(p.covered.iter().filter(|c| **c).count() > 200);
        // Not the stand-in of a missing file: the image's 32² faces.
        let mut notes = Vec::new();
        let cube = bind_cube(dir.path(), &format!("\"{}\"", file.display()), &mut notes).unwrap();
        assert!(notes.is_empty() && cube.size() == 32, "{notes:?}");
    }
}

/// A missing cube map image renders with the procedural sky, with a note,
/// on the CPU binder and the reference alike; `check` reports it, located,
/// as it reports any missing image, unless `--stand-ins` asks for the sky.
#[test]
fn a_missing_cube_image_renders_the_sky_stand_in() {
    let dir = tempfile::tempdir().unwrap();
    let mut notes = Vec::new();
    let cube = bind_cube(dir.path(), "\"nowhere.png\"", &mut notes).unwrap();
    assert_eq!(cube.size(), shadec::scene::cube_image::STAND_IN_FACE);
    assert!(notes.iter().any(|n| n.contains("nowhere.png") && n.contains("procedural sky")), "{notes:?}");
    let source = "vector R : reflection;\ntexture Env : cube rgb8 bilinear clamp = image(\"nowhere.png\");\nframebuffer C : rgba8, depth;\nC δπx ← Env δ R s x;\n";
    let p = render_three(source, "wgsl", &scene("kilgard_torus.ron"), Precision::F32, None).unwrap();
    verdict(&p).unwrap();
    std::fs::write(dir.path().join("p.shd"), source).unwrap();
    let r = shadec_in(dir.path(), &["check", "--format", "short", "p.shd"]);
    assert_eq!(r.code, 1, "{}{}", r.stdout, r.stderr);
    assert!(r.stdout.contains("p.shd:2:") && r.stdout.contains("error[missing-image]"), "{}", r.stdout);
    let r = shadec_in(dir.path(), &["check", "--stand-ins", "p.shd"]);
    assert_eq!(r.code, 0, "{}{}", r.stdout, r.stderr);
    // Six face files: each one that is missing is named.
    let six = source.replace("nowhere.png", "sky_{face}.png");
    std::fs::write(dir.path().join("six.shd"), six).unwrap();
    for face in ["px", "nx", "py", "ny", "pz"] {
        grey(dir.path(), &format!("sky_{face}.png"), 8, 8);
    }
    let r = shadec_in(dir.path(), &["check", "--format", "short", "six.shd"]);
    assert_eq!(r.code, 1, "{}{}", r.stdout, r.stderr);
    assert!(r.stdout.contains("sky_nz.png") && !r.stdout.contains("sky_px.png"), "{}", r.stdout);
    grey(dir.path(), "sky_nz.png", 8, 8);
    let r = shadec_in(dir.path(), &["check", "six.shd"]);
    assert_eq!(r.code, 0, "{}{}", r.stdout, r.stderr);
}

/// Writes `name` as a `w`×`h` grey PNG into `dir`.
fn grey(dir: &Path, name: &str, w: u32, h: u32) {
    image::RgbaImage::from_pixel(w, h, image::Rgba([128, 128, 128, 255])).save(dir.join(name)).unwrap();
}

/// What cannot make a cube map is an error of `check` and `compile` at the
/// declaration (file:line:col), with a help that names what would.
#[test]
fn unrenderable_cube_images_are_located_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    grey(d, "square.png", 100, 100);
    grey(d, "cross.png", 64, 48);
    for f in ["px", "nx", "py", "ny", "pz"] {
        grey(d, &format!("uneq_{f}.png"), 16, 16);
        grey(d, &format!("flat_{f}.png"), 16, 16);
    }
    grey(d, "uneq_nz.png", 32, 32);
    grey(d, "flat_nz.png", 16, 8);
    std::fs::write(d.join("broken.png"), b"not a png at all").unwrap();
    let cases: [(&str, &[&str]); 6] = [
        (
            "image(\"square.png\")",
            &["square.png is 100×100, which is no cube-map layout", "horizontal cross (4:3)"],
        ),
        ("image(\"cross.png\", \"vcross\")", &["not the 3:4 shape of the `vcross` layout", "`hcross`"]),
        ("image(\"cross.png\", \"diagonal\")", &["`diagonal` is not a cube-map layout", "`hcross` (4:3)"]),
        (
            "image(\"uneq_{face}.png\")",
            &["the faces differ in size", "uneq_nz.png is 32×32", "square face images of one size"],
        ),
        ("image(\"flat_{face}.png\")", &["flat_nz.png is 16×8: a cube face is square", "square face images"]),
        ("image(\"broken.png\")", &["broken.png: cannot decode image", "PNG, JPEG and Radiance HDR"]),
    ];
    for (source, expected) in cases {
        let program = format!("vector R : reflection;\n\ntexture Env : cube rgb8 bilinear clamp = {source};\nC δπx ← Env δ R s x;\n");
        std::fs::write(d.join("p.shd"), &program).unwrap();
        // Line 3: the declaration (its `image(…)`, or the argument at fault).
        let at = "p.shd:3:";
        let commands = [
            &["check", "p.shd"][..],
            &["compile", "p.shd", "--emit", "plan"],
            &["render", "--shader", "p.shd", "-o", "out.png"],
        ];
        for command in commands {
            let r = shadec_in(d, command);
            assert_eq!(r.code, 1, "{command:?} {source}: {}{}", r.stdout, r.stderr);
            assert!(r.stderr.contains(at), "{command:?} {source}: not located at {at}:\n{}", r.stderr);
            for e in expected {
                assert!(r.stderr.contains(e), "{command:?} {source}: `{e}` missing:\n{}", r.stderr);
            }
            assert!(r.stderr.contains("help:"), "{}", r.stderr);
        }
    }
}

/// A scene texture of the declaration's name replaces its image: the
/// image is not read, and `compile --scene` plans.
#[test]
fn a_scene_texture_replaces_an_unrenderable_cube_image() {
    let dir = tempfile::tempdir().unwrap();
    grey(dir.path(), "square.png", 100, 100);
    let program = "vector R : reflection;\ntexture Env : cube rgb8 bilinear clamp = image(\"square.png\");\nC δπx ← Env δ R s x;\n";
    std::fs::write(dir.path().join("p.shd"), program).unwrap();
    let base =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/kilgard_torus.ron"))
            .unwrap();
    std::fs::write(
        dir.path().join("s.ron"),
        with_texture(&base, "\"Env\": NormalizeCube(size: 8, bits: Eight)"),
    )
    .unwrap();
    let r = shadec_in(dir.path(), &["compile", "p.shd", "--scene", "s.ron", "--emit", "plan"]);
    assert_eq!(r.code, 0, "{}{}", r.stdout, r.stderr);
    let r = shadec_in(dir.path(), &["compile", "p.shd", "--emit", "plan"]);
    assert_eq!(r.code, 1, "without the scene the image is read: {}", r.stderr);
}

/// The rendering of one such error, as `check` prints it.
#[test]
fn unrenderable_cube_image_diagnostic_snapshot() {
    let dir = tempfile::tempdir().unwrap();
    grey(dir.path(), "square.png", 100, 100);
    let program = "vector R : reflection;\ntexture Env : cube rgb8 bilinear clamp = image(\"square.png\");\nC δπx ← Env δ R s x;\n";
    std::fs::write(dir.path().join("p.shd"), program).unwrap();
    let r = shadec_in(dir.path(), &["check", "p.shd"]);
    assert_eq!(r.code, 1);
    insta::assert_snapshot!("cube_image_unknown_shape", r.stderr);
}

/// A scene's `CubeImage(…)` and `CubeFaces(…)` textures, and a plain
/// `File(…)` given to a `cube` declaration, bind the same cube as the
/// program's own `image(…)`.
#[test]
fn scene_textures_give_cube_maps_from_images() {
    let dir = tempfile::tempdir().unwrap();
    let n = 8;
    write_layout(dir.path(), "faces", n);
    write_layout(dir.path(), "hcross", n);
    let expected = bind_cube(dir.path(), "\"env_{face}.png\"", &mut Vec::new()).unwrap();
    let base =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/kilgard_torus.ron"))
            .unwrap();
    let faces = ["px", "nx", "py", "ny", "pz", "nz"].map(|f| format!("\"env_{f}.png\"")).join(", ");
    for texture in [
        "CubeImage(path: \"env_hcross.png\")".to_string(),
        "CubeImage(path: \"env_hcross.png\", layout: Some(HorizontalCross))".to_string(),
        "CubeImage(path: \"env_{face}.png\")".to_string(),
        format!("CubeFaces(faces: [{faces}])"),
        "File(path: \"env_hcross.png\")".to_string(),
    ] {
        let text = with_texture(&base, &format!("\"Env\": {texture}"));
        let path: PathBuf = dir.path().join("scene.ron");
        let scene = Scene::parse(&text, &path).unwrap_or_else(|e| panic!("{texture}: {e}"));
        let source = "texture Env : cube rgba8 nearest clamp = image(\"absent.png\");\nC δπx ← Env δπx;\n";
        let (program, _) = shadec::parser::parse(source);
        let decls = bind::texture_decls(&shadec::ir::lower(&program).0, &BTreeMap::new());
        let mut notes = Vec::new();
        let bound = bind::load_textures(&decls, &scene, TextureQuality::Stored, &mut notes).unwrap();
        assert!(notes.is_empty(), "{texture}: {notes:?}");
        let Texture::Cube(cube) = &bound["Env"].texture else { panic!("{texture}: not a cube") };
        assert_eq!(cube, &expected, "{texture}");
    }
    // A scene cube image of no layout is the scene's error, named.
    grey(dir.path(), "square.png", 10, 10);
    let text = with_texture(&base, "\"Env\": CubeImage(path: \"square.png\")");
    let scene = Scene::parse(&text, &dir.path().join("scene.ron")).unwrap();
    let err = scene.build().unwrap_err().to_string();
    assert!(err.contains("texture 'Env'") && err.contains("no cube-map layout"), "{err}");
    let text = with_texture(&base, "\"Env\": CubeFaces(faces: [\"a.png\"])");
    let err = Scene::parse(&text, &dir.path().join("scene.ron")).unwrap_err().to_string();
    assert!(err.contains("1 face files; give six"), "{err}");
}

/// The scene text with one more entry in its `textures:` map.
fn with_texture(scene: &str, entry: &str) -> String {
    if let Some(i) = scene.find("textures: {") {
        let at = i + "textures: {".len();
        format!("{}\n        {entry},{}", &scene[..at], &scene[at..])
    } else {
        let end = scene.rfind(')').unwrap();
        format!("{}    textures: {{ {entry} }},\n{}", &scene[..end], &scene[end..])
    }
}

/// The layout module's own statement: a face texel is copied, not
/// filtered, and the turned −Z of the vertical cross comes back upright.
#[test]
fn the_vertical_cross_turns_minus_z() {
    let n = 4;
    let dir = tempfile::tempdir().unwrap();
    write_layout(dir.path(), "vcross", n);
    let cube =
        cube_image::load_cube_image(&dir.path().join("env_vcross.png"), None, TexelFormat::Rgba8).unwrap();
    let nz = &cube.faces[CubeFace::NegZ as usize].levels[0];
    for (x, y) in [(0, 0), (3, 0), (0, 3), (3, 3)] {
        let got = nz.texel(x, y).map(|c| (c * 255.0).round() as u8);
        assert_eq!(got, face_texel(5, x, y, n), "texel ({x}, {y})");
    }
}
