//! The program's textures for the reference: each declaration's source read
//! from the program text, its texels made or loaded here — a normalization
//! cube map from Kilgard 2000's Appendix D, an exponent table from its
//! definition, an image file (or the brick stand-in of a missing one), a
//! dual-paraboloid face of the environment's stand-in —
//! and its filtering from the declaration's attributes. A scene texture of
//! the same name replaces the program's, as docs/scenes.md says.

use super::normal_map::{self, Storage};
use super::program::Tex;
use super::sampling::{self, Cube, Image, Level, Paraboloid};
use super::Unsupported;
use crate::ir::Module;
use crate::parser::ast::{self, ExprKind, FuncKind, ItemKind, TextureFormat, TextureKind};
use crate::scene::{Scene, SceneAssets};
use crate::textures::{self as data, Filter, TexelFormat, Texture, Wrap};

/// Every texture of `module`, by id.
pub fn bind(
    module: &Module,
    program: &ast::Program,
    scene: &Scene,
    assets: &SceneAssets,
) -> Result<Vec<Tex>, Unsupported> {
    let decls: Vec<&ast::TextureDecl> = program
        .items
        .iter()
        .filter_map(|i| match &i.kind {
            ItemKind::Texture(t) => Some(t),
            _ => None,
        })
        .collect();
    let mut out = Vec::new();
    for t in &module.textures {
        let decl = decls.iter().find(|d| d.names.iter().any(|n| n.key() == t.name));
        let s = t.sampling;
        let tex = match (assets.textures.get(&t.name), decl) {
            // A scene's image file for a cube declaration is read as a cube map.
            (Some(Texture::Flat(image)), _) if t.kind == TextureKind::Cube => {
                let store = store_format(t.format);
                cube_from_image(level(&image.levels[0]), None, store, s.filter)
                    .unwrap_or_else(|why| Tex::Missing(format!("a cube map from the scene's image: {why}")))
            }
            // The papers' generators a scene names are built here too.
            (Some(given), _) => scene_generated(scene, &t.name, s)?
                .unwrap_or_else(|| from_data(given, s.filter, s.wrap, s.mipmap, store_format(t.format))),
            (None, Some(d)) => from_source(d, t.kind, t.format, s.filter, s.wrap, s.mipmap, scene)?,
            (None, None) => Tex::Missing(format!("the texture `{}` the compiler added", t.name)),
        };
        out.push(tex);
    }
    Ok(out)
}

/// A scene texture that is one of the papers' generators (Kilgard 2000's
/// normal map, Appendices E-F, and normalization cube, Appendix D), built
/// here from its description rather than taken from the scene binder.
fn scene_generated(scene: &Scene, name: &str, s: crate::ir::Sampling) -> Result<Option<Tex>, Unsupported> {
    use crate::scene::{HeightDesc, TextureDesc};
    use crate::textures::generators::{CubeBits, HeightField, NormalMapFormat};
    Ok(match scene.textures.get(name) {
        Some(TextureDesc::NormalMap { height, scale, format: nf }) => {
            let hf = match height {
                HeightDesc::File(file) => data::load_height_field(&scene.resolve(file))
                    .map_err(|e| Unsupported::new(format!("an unreadable height field: {e}")))?,
                HeightDesc::Dimples { size, cells } => HeightField::dimples(*size, *cells),
            };
            let storage = if *nf == NormalMapFormat::F32 { Storage::Float } else { Storage::Bytes };
            let levels = normal_map::levels(&hf, f64::from(*scale), storage, s.mipmap);
            Some(Tex::Flat(Image { levels, wrap: s.wrap, filter: s.filter }))
        }
        Some(TextureDesc::DualParaboloid { size, sun, format }) => {
            Some(Tex::Paraboloid(Box::new(paraboloid(*size, sun.to_array(), *format, s.filter))))
        }
        // Stored as the scene says (its bits), whatever the program declares.
        Some(TextureDesc::NormalizeCube { size, bits }) => {
            let sixteen = *bits == CubeBits::Sixteen;
            Some(Tex::Cube(normalize_cube(*size, sixteen, TextureFormat::Rgba8, s.filter)))
        }
        _ => None,
    })
}

/// A scene's `DualParaboloid(size, sun, format)`: each face's texel the
/// environment in the direction through its centre (Heidrich & Seidel
/// 1999, Section 4.1; [`Paraboloid::direction`]), stored in `format`; the
/// front face's alpha 1 inside the unit circle and 0 outside, the back
/// face's 1. The environment is the scene's procedural sky, data as an
/// image's texels are (`generators::sky`). Level 0 only: a lookup by
/// direction has no derivatives.
fn paraboloid(size: u32, sun: [f32; 3], format: TexelFormat, filter: Filter) -> Paraboloid {
    let size = size.clamp(1, 4096);
    let face = |front: bool| {
        let mut texels = Vec::with_capacity((size * size) as usize);
        for j in 0..size {
            for i in 0..size {
                let centre = |k: u32| 2.0 * (f64::from(k) + 0.5) / f64::from(size) - 1.0;
                let (x, y) = (centre(i), centre(j));
                let d = Paraboloid::direction(front, x, y).map(|c| c as f32);
                let sky = data::generators::sky(d, sun);
                let alpha = if !front || x * x + y * y <= 1.0 { 1.0 } else { 0.0 };
                let texel = [f64::from(sky[0]), f64::from(sky[1]), f64::from(sky[2]), alpha];
                texels.push(texel.map(|c| sampling::quantize(format, c)));
            }
        }
        let level = Level { width: size, height: size, texels };
        Image { levels: vec![level], wrap: Wrap::ClampToEdge, filter }
    };
    Paraboloid { front: face(true), back: face(false) }
}

/// How a declared format stores texels (8-bit formats as k/255, signed as
/// k/127, 16-bit as k/65535, float as is).
pub(super) fn store_format(f: TextureFormat) -> TexelFormat {
    match f {
        TextureFormat::Signed8 => TexelFormat::Signed8,
        TextureFormat::Rgba16 | TextureFormat::Signed16 => TexelFormat::Rgba16,
        TextureFormat::Rgba16f | TextureFormat::Rgba32f => TexelFormat::F32,
        _ => TexelFormat::Rgba8,
    }
}

fn level(l: &data::Level) -> Level {
    Level { width: l.width, height: l.height, texels: l.texels.iter().map(|t| t.map(f64::from)).collect() }
}

fn image(levels: Vec<Level>, filter: Filter, wrap: Wrap, mipmap: bool, format: TexelFormat) -> Image {
    let levels = match (mipmap, levels.len()) {
        (true, 1) => levels.into_iter().flat_map(|base| sampling::mip_chain(base, format)).collect(),
        (false, _) => levels.into_iter().take(1).collect(),
        _ => levels,
    };
    Image { levels, wrap, filter }
}

fn from_data(t: &Texture, filter: Filter, wrap: Wrap, mipmap: bool, format: TexelFormat) -> Tex {
    match t {
        Texture::Flat(t) => {
            Tex::Flat(image(t.levels.iter().map(level).collect(), filter, wrap, mipmap, format))
        }
        Texture::Cube(c) => Tex::Cube(Cube {
            faces: c
                .faces
                .iter()
                .map(|f| image(vec![level(&f.levels[0])], filter, Wrap::ClampToEdge, false, format))
                .collect(),
        }),
        Texture::DualParaboloid(_) => Tex::Missing("dual-paraboloid environment maps".into()),
    }
}

fn literal_args(e: &ast::Expr) -> Vec<&ast::Expr> {
    match &e.kind {
        ExprKind::Tuple(items) => items.iter().collect(),
        _ => vec![e],
    }
}

fn number(e: &ast::Expr) -> Option<f64> {
    match &e.kind {
        ExprKind::Number(v) => Some(*v),
        _ => None,
    }
}

#[allow(clippy::too_many_arguments)]
fn from_source(
    d: &ast::TextureDecl,
    kind: TextureKind,
    format: TextureFormat,
    filter: Filter,
    wrap: Wrap,
    mipmap: bool,
    scene: &Scene,
) -> Result<Tex, Unsupported> {
    let Some(src) = &d.source else {
        return Ok(Tex::Missing("textures rendered by a statement".into()));
    };
    let ExprKind::Apply { func: ast::Func { kind: FuncKind::Name(name), .. }, arg } = &src.kind else {
        return Ok(Tex::Missing("a texture source other than a call".into()));
    };
    let args = literal_args(arg);
    let store = store_format(format);
    Ok(match (name.key().as_str(), kind) {
        ("image", TextureKind::Tex2d | TextureKind::Tex1d) => {
            let ExprKind::String(file) = &args[0].kind else {
                return Ok(Tex::Missing("image() without a file name".into()));
            };
            let base = match data::load_image(&scene.resolve_program_file(file), store, wrap) {
                Ok(t) => level(&t.levels[0]),
                Err(data::TextureError::NotFound { .. }) => {
                    let mut l = level(&data::generators::brick_stand_in(256));
                    for t in &mut l.texels {
                        *t = t.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() / 255.0);
                    }
                    l
                }
                Err(e) => return Err(Unsupported::new(format!("an unreadable image: {e}"))),
            };
            Tex::Flat(image(vec![base], filter, wrap, mipmap, store))
        }
        ("image", TextureKind::Cube) => cube_image(&args, store, filter, scene)?,
        ("normalize_cube", TextureKind::Cube) => {
            let size = args.first().and_then(|a| number(a)).unwrap_or(32.0).clamp(1.0, 4096.0) as u32;
            let bits = args.get(1).and_then(|a| number(a)).unwrap_or(8.0);
            Tex::Cube(normalize_cube(size, bits >= 16.0, format, filter))
        }
        ("exponent_table", TextureKind::Tex1d) => {
            let n = args.first().and_then(|a| number(a)).unwrap_or(1.0).max(0.0);
            let size = data::generators::EXPONENT_TABLE_SIZE;
            let texels = (0..size)
                .map(|i| {
                    let v = quantize(store, ((f64::from(i) + 0.5) / f64::from(size)).powf(n));
                    [v, v, v, 1.0]
                })
                .collect();
            Tex::Flat(Image {
                levels: vec![Level { width: size, height: 1, texels }],
                wrap: Wrap::ClampToEdge,
                filter,
            })
        }
        ("dual_paraboloid", TextureKind::Tex2d) => {
            // One face of the environment's stand-in (the scene binder's
            // data, as an image file's texels are), with the generator's own
            // mipmaps, weighted by solid angle (Heidrich & Seidel 1999, Section 4.2).
            let face = args.get(1).and_then(|a| number(a)).unwrap_or(0.0);
            let dp = data::generators::dual_paraboloid_stand_in(store);
            let t = if face == 0.0 { dp.front } else { dp.back };
            Tex::Flat(image(t.levels.iter().map(level).collect(), filter, wrap, mipmap, store))
        }
        ("normal_map", TextureKind::Tex2d) => {
            let hf = height_field(args.first().copied(), scene)?;
            let scale = args.get(1).and_then(|a| number(a)).unwrap_or(4.0);
            let storage = if store == TexelFormat::F32 { Storage::Float } else { Storage::Bytes };
            Tex::Flat(Image { levels: normal_map::levels(&hf, scale, storage, mipmap), wrap, filter })
        }
        ("bumps", TextureKind::Tex2d) => {
            let cells = args.first().and_then(|a| number(a)).unwrap_or(16.0).max(1.0);
            let hf = data::generators::HeightField::dimples(256, cells as u32);
            let sixteen = format == TextureFormat::Signed16;
            let storage = if store == TexelFormat::F32 || sixteen { Storage::Float } else { Storage::Bytes };
            let mut levels = normal_map::levels(&hf, 4.0, storage, mipmap);
            if matches!(format, TextureFormat::Signed8 | TextureFormat::Signed16) {
                normal_map::expanded(&mut levels, sixteen);
            }
            Tex::Flat(Image { levels, wrap, filter })
        }
        ("bake", _) => Tex::Missing("a bake() whose statement was not seen".into()),
        (other, _) => {
            Tex::Missing(format!("the texture source `{other}(…)` for a {} texture", kind_name(kind)))
        }
    })
}

/// The height field of `normal_map(height("file"), …)` (or of a bare file
/// name): the image's luminance, read as data; golf-ball dimples (256², 16
/// cells) where the file is missing or no file is named, as the language
/// documents the stand-in.
fn height_field(
    arg: Option<&ast::Expr>,
    scene: &Scene,
) -> Result<data::generators::HeightField, Unsupported> {
    let file = match arg.map(|a| &a.kind) {
        Some(ExprKind::String(f)) => Some(f),
        Some(ExprKind::Apply { arg, .. }) => match &arg.kind {
            ExprKind::String(f) => Some(f),
            _ => None,
        },
        _ => None,
    };
    let dimples = || data::generators::HeightField::dimples(256, 16);
    let Some(file) = file else { return Ok(dimples()) };
    match data::load_height_field(&scene.resolve_program_file(file)) {
        Ok(h) => Ok(h),
        Err(data::TextureError::NotFound { .. }) => Ok(dimples()),
        Err(e) => Err(Unsupported::new(format!("an unreadable height field: {e}"))),
    }
}

fn kind_name(k: TextureKind) -> &'static str {
    match k {
        TextureKind::Tex1d => "1d",
        TextureKind::Tex2d => "2d",
        TextureKind::Tex3d => "3d",
        TextureKind::Cube => "cube",
    }
}

fn quantize(format: TexelFormat, v: f64) -> f64 {
    match format {
        TexelFormat::Rgba8 => (v.clamp(0.0, 1.0) * 255.0).round() / 255.0,
        TexelFormat::Signed8 => (v.clamp(-1.0, 1.0) * 127.0).round() / 127.0,
        TexelFormat::Rgba16 => (v.clamp(0.0, 1.0) * 65535.0).round() / 65535.0,
        TexelFormat::F32 => v,
    }
}

/// Kilgard 2000, Appendix D: each texel the unit vector through its centre
/// (the inverse of GL Table 3.19), range-compressed `(GLubyte)(128 + 127·v)`
/// in 8 bits, `round(65535·(v + 1)/2)` in 16; a signed format holds the
/// vector itself.
fn normalize_cube(size: u32, sixteen: bool, format: TextureFormat, filter: Filter) -> Cube {
    let signed = matches!(format, TextureFormat::Signed8 | TextureFormat::Signed16);
    let wide = sixteen || matches!(format, TextureFormat::Rgba16 | TextureFormat::Signed16);
    let face = |f: usize| {
        let mut texels = Vec::with_capacity((size * size) as usize);
        for y in 0..size {
            for x in 0..size {
                let sc = 2.0 * (f64::from(x) + 0.5) / f64::from(size) - 1.0;
                let tc = 2.0 * (f64::from(y) + 0.5) / f64::from(size) - 1.0;
                let d = face_direction(f, sc, tc);
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let v = d.map(|c| c / n);
                let enc = |c: f64| match (signed, wide) {
                    (true, true) => (c * 32767.0).round() / 32767.0,
                    (true, false) => (c * 127.0).round() / 127.0,
                    (false, true) => ((c + 1.0) * 0.5 * 65535.0).round() / 65535.0,
                    (false, false) => (128.0 + 127.0 * c).floor().clamp(0.0, 255.0) / 255.0,
                };
                texels.push([enc(v[0]), enc(v[1]), enc(v[2]), 1.0]);
            }
        }
        Image { levels: vec![Level { width: size, height: size, texels }], wrap: Wrap::ClampToEdge, filter }
    };
    Cube { faces: (0..6).map(face).collect() }
}

/// `image(…)` of a cube texture, read here from the documented layouts
/// (docs/language.md): one image — a horizontal cross (4:3), a vertical
/// cross (3:4, −Z turned 180°), six faces across (6:1) or down (1:6), an
/// equirectangular panorama (2:1) — its layout named by a second argument
/// or deduced from its shape; or six face files (`{face}` for px … nz, or
/// six names). A missing file is the procedural sky, as the renderers'
/// stand-in.
fn cube_image(
    args: &[&ast::Expr],
    store: TexelFormat,
    filter: Filter,
    scene: &Scene,
) -> Result<Tex, Unsupported> {
    let names: Vec<&str> = args
        .iter()
        .filter_map(|a| match &a.kind {
            ExprKind::String(s) => Some(s.as_str()),
            _ => None,
        })
        .collect();
    let files: Vec<String> = match names.as_slice() {
        [one] if one.contains("{face}") => {
            ["px", "nx", "py", "ny", "pz", "nz"].iter().map(|f| one.replace("{face}", f)).collect()
        }
        [one] | [one, _] => vec![one.to_string()],
        six if six.len() == 6 => six.iter().map(|f| f.to_string()).collect(),
        _ => return Ok(Tex::Missing("image() of a cube map with other arguments".into())),
    };
    let mut levels = Vec::new();
    for f in &files {
        match data::load_image(&scene.resolve_program_file(f), TexelFormat::F32, Wrap::ClampToEdge) {
            Ok(t) => levels.push(level(&t.levels[0])),
            Err(data::TextureError::NotFound { .. }) => return Ok(Tex::Cube(sky_cube(store, filter))),
            Err(e) => return Err(Unsupported::new(format!("an unreadable image: {e}"))),
        }
    }
    if levels.len() == 6 {
        let faces = levels.into_iter().map(|l| face_image(l, store, filter)).collect();
        return Ok(Tex::Cube(Cube { faces }));
    }
    let layout = names.get(1).copied();
    let Some(image) = levels.pop() else {
        return Ok(Tex::Missing("image() of a cube map without a file".into()));
    };
    Ok(cube_from_image(image, layout, store, filter).unwrap_or_else(Tex::Missing))
}

fn face_image(mut l: Level, store: TexelFormat, filter: Filter) -> Image {
    for t in &mut l.texels {
        *t = t.map(|c| quantize(store, c));
    }
    Image { levels: vec![l], wrap: Wrap::ClampToEdge, filter }
}

/// GL Table 3.19 inverted: the direction through (sc, tc) ∈ [−1, 1]² of
/// face `f` (+x, −x, +y, −y, +z, −z).
fn face_direction(f: usize, sc: f64, tc: f64) -> [f64; 3] {
    match f {
        0 => [1.0, -tc, -sc],
        1 => [-1.0, -tc, sc],
        2 => [sc, 1.0, tc],
        3 => [sc, -1.0, -tc],
        4 => [sc, -tc, 1.0],
        _ => [-sc, -tc, -1.0],
    }
}

/// One image cut (or resampled) into six faces, by `layout` or its shape.
fn cube_from_image(
    image: Level,
    layout: Option<&str>,
    store: TexelFormat,
    filter: Filter,
) -> Result<Tex, String> {
    let (w, h) = (image.width, image.height);
    let shape = match (4 * h == 3 * w, 3 * h == 4 * w, w == 6 * h, h == 6 * w, w == 2 * h) {
        _ if w == 0 || h == 0 => return Err("an empty image".into()),
        (true, ..) => "hcross",
        (_, true, ..) => "vcross",
        (_, _, true, ..) => "hstrip",
        (_, _, _, true, _) => "vstrip",
        (.., true) => "equirect",
        _ => return Err(format!("a {w}×{h} image is no cube-map layout")),
    };
    if layout.is_some_and(|l| l != shape) {
        return Err(format!("a {w}×{h} image is not in the layout `{}`", layout.unwrap_or_default()));
    }
    // (column, row, turned 180°) of each face, in face units.
    let cross = |neg_z: (u32, u32, bool)| {
        [(2, 1, false), (0, 1, false), (1, 0, false), (1, 2, false), (1, 1, false), neg_z]
    };
    let places: [(u32, u32, bool); 6] = match shape {
        "hcross" => cross((3, 1, false)),
        "vcross" => cross((1, 3, true)),
        "hstrip" => std::array::from_fn(|i| (i as u32, 0, false)),
        "vstrip" => std::array::from_fn(|i| (0, i as u32, false)),
        _ => return Ok(Tex::Cube(equirect_cube(&image, store, filter))),
    };
    let n = match shape {
        "hcross" => w / 4,
        "vcross" => w / 3,
        "hstrip" => h,
        _ => w,
    };
    let faces = places
        .iter()
        .map(|&(col, row, turned)| {
            let mut texels = Vec::with_capacity((n * n) as usize);
            for y in 0..n {
                for x in 0..n {
                    let (sx, sy) = if turned { (n - 1 - x, n - 1 - y) } else { (x, y) };
                    texels.push(image.texels[((row * n + sy) * w + col * n + sx) as usize]);
                }
            }
            face_image(Level { width: n, height: n, texels }, store, filter)
        })
        .collect();
    Ok(Tex::Cube(Cube { faces }))
}

/// An equirectangular image resampled to faces of (width/4)² (at most
/// 1024²): at each texel centre's direction d, the image's bilinear sample
/// at u = ½ + atan2(dx, −dz)/2π (repeating), v = acos(dy/|d|)/π (clamped).
fn equirect_cube(image: &Level, store: TexelFormat, filter: Filter) -> Cube {
    let (w, h) = (i64::from(image.width), i64::from(image.height));
    let n = (image.width / 4).clamp(1, 1024);
    let at = |x: i64, y: i64| image.texels[(y.clamp(0, h - 1) * w + x.rem_euclid(w)) as usize];
    let sample = |d: [f64; 3]| {
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let u = 0.5 + d[0].atan2(-d[2]) / std::f64::consts::TAU;
        let v = (d[1] / len).acos() / std::f64::consts::PI;
        let (fx, fy) = (u * w as f64 - 0.5, (v * h as f64 - 0.5).clamp(0.0, (h - 1) as f64));
        let (x0, y0) = (fx.floor(), fy.floor());
        let (ax, ay) = (fx - x0, fy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (a, b, c, e) = (at(x0, y0), at(x0 + 1, y0), at(x0, y0 + 1), at(x0 + 1, y0 + 1));
        std::array::from_fn(|k| {
            (1.0 - ay) * ((1.0 - ax) * a[k] + ax * b[k]) + ay * ((1.0 - ax) * c[k] + ax * e[k])
        })
    };
    let face = |f: usize| {
        let mut texels = Vec::with_capacity((n * n) as usize);
        for y in 0..n {
            for x in 0..n {
                let sc = 2.0 * (f64::from(x) + 0.5) / f64::from(n) - 1.0;
                let tc = 2.0 * (f64::from(y) + 0.5) / f64::from(n) - 1.0;
                texels.push(sample(face_direction(f, sc, tc)));
            }
        }
        face_image(Level { width: n, height: n, texels }, store, filter)
    };
    Cube { faces: (0..6).map(face).collect() }
}

/// The renderers' stand-in for a missing cube map image: the procedural
/// sky at each texel centre's direction, faces of 64².
fn sky_cube(store: TexelFormat, filter: Filter) -> Cube {
    let n = 64u32;
    let face = |f: usize| {
        let mut texels = Vec::with_capacity((n * n) as usize);
        for y in 0..n {
            for x in 0..n {
                let sc = 2.0 * (f64::from(x) + 0.5) / f64::from(n) - 1.0;
                let tc = 2.0 * (f64::from(y) + 0.5) / f64::from(n) - 1.0;
                let c = data::generators::sky(
                    face_direction(f, sc, tc).map(|v| v as f32),
                    data::generators::STAND_IN_SUN,
                );
                texels.push([f64::from(c[0]), f64::from(c[1]), f64::from(c[2]), 1.0]);
            }
        }
        face_image(Level { width: n, height: n, texels }, store, filter)
    };
    Cube { faces: (0..6).map(face).collect() }
}
