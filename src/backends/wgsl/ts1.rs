//! A `!!TS1.0` + `!!RC1.0` pair as WGSL: the texture-shader stages compute
//! texture0..3 per pixel exactly as `combiners::ts1::emulate` does (the
//! same integer model: coordinates in units of 1/65536, nearest texels by
//! `textureLoad`, the offset matrix in units of 1/4096), then the
//! combiners run as `rc1` translates them, so the image is bit-identical to
//! `shadec emulate`'s.
//!
//! Interface: as `rc1`'s, with these differences.
//! - Units 0-3 (`@binding(1 + 2i)`) are texture *images* of any size (at
//!   most 4096 a side; cube maps as six faces stacked, 3-D textures as
//!   square slices stacked, as `emulate` reads them), read with
//!   `textureLoad` at the texel the stage computes; bind a 1×1 black image
//!   for a missing one.
//! - Units 6-9 (`@binding(13 + 2k)`, sampler at `14 + 2k`): the coordinate
//!   images of units 0-3 (RGBA8 = s, t, r, q; the target's size).
//! - `Uniforms` gains `texture_shader: vec4<i32>` = (target width, target
//!   height, a bit mask of the units whose coordinate image is bound (bit
//!   k = unit k; the others take the default coordinates), 0).

use std::fmt::Write as _;

use crate::backends::combiners::config::CombinerConfig;
use crate::backends::combiners::ts1::emulate::{eye_units, matrix_units, signed_coordinates};
use crate::backends::combiners::ts1::{
    CullCondition, DotFamily, DotMapping, Operation, TextureShader, MAX_STAGES,
};

use super::rc1::{combiners_function, combiners_helpers, COMBINERS_FUNCTION, TEXEL_HELPER};

const TS_HELPERS: &str = r#"
// A texel of `t` at (ix, iy), clamped to the edge, as integers 0..255.
fn ts_fetch(t: texture_2d<f32>, ix: i32, iy: i32) -> vec4<i32> {
    let d = vec2<i32>(textureDimensions(t));
    let p = clamp(vec2<i32>(ix, iy), vec2<i32>(0), d - vec2<i32>(1));
    return vec4<i32>(round(textureLoad(t, p, 0) * 255.0));
}

// The texel index of coordinate c / q (units of 1/65536) in a side of n.
fn ts_index(c: i32, q: i32, n: i32) -> i32 {
    if (q <= 0) {
        return 0;
    }
    return clamp(floor_div(clamp(c, -131072, 131072) * n, q), 0, n - 1);
}

// A nearest, clamp-to-edge lookup at (s, t) / q.
fn ts_lookup(t: texture_2d<f32>, s: i32, tt: i32, q: i32) -> vec4<i32> {
    let d = vec2<i32>(textureDimensions(t));
    return ts_fetch(t, ts_index(s, q, d.x), ts_index(tt, q, d.y));
}

// A coordinate byte b: b/255, or (2b - 255)/255 for a direction, in units of 1/65536.
fn ts_coordinate(b: i32, signed: bool) -> i32 {
    let v = select(b, 2 * b - 255, signed);
    return floor_div(v * 131072 + 255, 510);
}

// (i + 1/2)/n in units of 1/65536, rounded to nearest.
fn ts_default(i: i32, n: i32) -> i32 {
    return floor_div((2 * i + 1) * 65536 + n, 2 * n);
}

// Unit k's (s, t, r, q): its coordinate image if bound, else pixel centres.
fn ts_coordinates(image: texture_2d<f32>, k: u32, p: vec2<i32>, signed: bool) -> vec4<i32> {
    let ts = uniforms.texture_shader;
    if ((u32(ts.z) & (1u << k)) != 0u) {
        let b = texel(image, p);
        return vec4<i32>(ts_coordinate(b.x, signed), ts_coordinate(b.y, signed), ts_coordinate(b.z, signed), ts_coordinate(b.w, signed));
    }
    return vec4<i32>(ts_default(p.x, ts.x), ts_default(p.y, ts.y), 0, 65536);
}

// A two's-complement byte as a signed DSDT component, max(k, -127) (units of 1/127).
fn ts_signed(k: i32) -> i32 {
    return max(select(k, k - 256, k > 127), -127);
}

// RGB times factor f (units of 1/(4096 * 255)), rounded to nearest; alpha kept.
fn ts_scale(t: vec4<i32>, f: i32) -> vec4<i32> {
    let k = vec3<i32>(floor_div(t.x * f + 522240, 1044480), floor_div(t.y * f + 522240, 1044480), floor_div(t.z * f + 522240, 1044480));
    return vec4<i32>(k, t.w);
}

// A 3-D texture (square slices stacked top to bottom) at (s, t, r) / q.
fn ts_volume(t: texture_2d<f32>, c: vec3<i32>, q: i32) -> vec4<i32> {
    let d = vec2<i32>(textureDimensions(t));
    let depth = d.y / max(d.x, 1);
    return ts_fetch(t, ts_index(c.x, q, d.x), ts_index(c.z, q, depth) * d.x + ts_index(c.y, q, d.x));
}

// A cube map (six faces stacked, +X -X +Y -Y +Z -Z) in direction v.
fn ts_cube(t: texture_2d<f32>, v0: vec3<i32>) -> vec4<i32> {
    let size = i32(textureDimensions(t).x);
    let v = clamp(v0, vec3<i32>(-262144), vec3<i32>(262144));
    let a = abs(v);
    var face = 0;
    var sc = 0;
    var tc = 0;
    var ma = 0;
    if (a.x >= a.y && a.x >= a.z) {
        ma = a.x;
        tc = -v.y;
        if (v.x >= 0) { face = 0; sc = -v.z; } else { face = 1; sc = v.z; }
    } else if (a.y >= a.z) {
        ma = a.y;
        sc = v.x;
        if (v.y >= 0) { face = 2; tc = v.z; } else { face = 3; tc = -v.z; }
    } else {
        ma = a.z;
        tc = -v.y;
        if (v.z >= 0) { face = 4; sc = v.x; } else { face = 5; sc = -v.x; }
    }
    if (ma == 0) {
        return ts_fetch(t, 0, 0);
    }
    let ix = clamp(floor_div((sc + ma) * size, 2 * ma), 0, size - 1);
    let iy = clamp(floor_div((tc + ma) * size, 2 * ma), 0, size - 1);
    return ts_fetch(t, ix, face * size + iy);
}

// R = 2 N (N.E) / (N.N) - E, per component rounded down; -E when N = 0.
fn ts_reflect(n: vec3<i32>, e: vec3<i32>) -> vec3<i32> {
    let ne = n.x * e.x + n.y * e.y + n.z * e.z;
    let nn = n.x * n.x + n.y * n.y + n.z * n.z;
    if (nn == 0) {
        return -e;
    }
    return vec3<i32>(floor_div(2 * n.x * ne, nn), floor_div(2 * n.y * ne, nn), floor_div(2 * n.z * ne, nn)) - e;
}

// The offset floor((a ds + b dt) 16 / 127) in units of 1/65536.
fn ts_offset(a: i32, b: i32, ds: i32, dt: i32) -> i32 {
    return floor_div((a * ds + b * dt) * 16, 127);
}
"#;

/// Translates the pair to a WGSL module (vertex `vs_main`, fragment `fs_main`).
pub fn translate(config: &CombinerConfig, program: &TextureShader, title: &str) -> Result<String, String> {
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(w, "// shadec translate: {title}");
    let _ = writeln!(
        w,
        "// A !!TS1.0 texture shader ({} stage(s)) and the register combiners in fixed9, as `shadec emulate`.",
        program.stages.len()
    );
    let _ = writeln!(w, "// Bindings: docs/combiners.md, \"Translated shaders\".");
    let _ = writeln!(w, "\nstruct Uniforms {{\n    constant0: vec4<f32>,\n    constant1: vec4<f32>,\n    fog: vec4<f32>,\n    texture_shader: vec4<i32>,\n}}\n");
    let _ = writeln!(w, "@group(0) @binding(0) var<uniform> uniforms: Uniforms;");
    let units = [
        "texture0",
        "texture1",
        "texture2",
        "texture3",
        "primary",
        "secondary",
        "coord0",
        "coord1",
        "coord2",
        "coord3",
    ];
    for (i, name) in units.iter().enumerate() {
        let _ = writeln!(w, "@group(0) @binding({}) var {name}_image: texture_2d<f32>;", 1 + 2 * i);
        let _ = writeln!(w, "@group(0) @binding({}) var {name}_sampler: sampler;", 2 + 2 * i);
    }
    w.push_str(combiners_helpers());
    w.push_str(TEXEL_HELPER);
    w.push_str(TS_HELPERS);
    w.push_str(&texture_shader_function(program));
    w.push_str(&combiners_function(config));
    let _ = writeln!(w, "\n@vertex\nfn vs_main(@location(0) position: vec4<f32>) -> @builtin(position) vec4<f32> {{\n    return position;\n}}\n");
    let _ =
        writeln!(w, "@fragment\nfn fs_main(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {{");
    let _ = writeln!(w, "    let p = vec2<i32>(frag.xy);");
    let _ = writeln!(w, "    let ts = texture_shader(p);");
    let _ = writeln!(w, "    if (ts.culled) {{\n        return vec4<f32>(0.0); // cull_fragment\n    }}");
    let _ = writeln!(
        w,
        "    return {COMBINERS_FUNCTION}(ts.tex0, ts.tex1, ts.tex2, ts.tex3, texel(primary_image, p), texel(secondary_image, p), uniforms.constant0, uniforms.constant1, uniforms.fog);"
    );
    let _ = writeln!(w, "}}");
    super::validate::parse_and_validate(&s)
        .map_err(|e| format!("compiler bug: the translated shader {e}"))?;
    Ok(s)
}

/// `texture_shader(p) -> TextureShaderOut`: the four texture registers
/// (integers 0..255) and whether `cull_fragment` discarded the pixel.
fn texture_shader_function(program: &TextureShader) -> String {
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(w, "\nstruct TextureShaderOut {{\n    tex0: vec4<i32>,\n    tex1: vec4<i32>,\n    tex2: vec4<i32>,\n    tex3: vec4<i32>,\n    culled: bool,\n}}\n");
    let _ = writeln!(w, "// The texture-shader stages (NV_texture_shader), one per unit.");
    let _ = writeln!(w, "fn texture_shader(p: vec2<i32>) -> TextureShaderOut {{");
    let _ = writeln!(w, "    var culled = false;");
    let _ = writeln!(w, "    var dots = vec3<i32>(0);");
    let _ = writeln!(w, "    var eyes = vec3<i32>(0);");
    let _ = writeln!(w, "    var const_eye = vec3<i32>(0);");
    for unit in 0..MAX_STAGES {
        let op = program.stage(unit);
        let _ = writeln!(w, "    // Unit {unit}: {}", crate::backends::combiners::ts1::instruction(&op));
        let signed = signed_coordinates(&op);
        let _ = writeln!(w, "    let c{unit} = ts_coordinates(coord{unit}_image, {unit}u, p, {signed});");
        let _ = writeln!(w, "    var tex{unit} = vec4<i32>(0);");
        w.push_str(&stage_code(program, &op, unit));
    }
    let _ = writeln!(w, "    return TextureShaderOut(tex0, tex1, tex2, tex3, culled);");
    let _ = writeln!(w, "}}");
    s
}

/// The statements that set `tex{unit}` (and `culled`, `dots`) for `op`.
fn stage_code(program: &TextureShader, op: &Operation, unit: usize) -> String {
    let img = format!("texture{unit}_image");
    let c = format!("c{unit}");
    let set = |value: String| format!("    tex{unit} = {value};\n");
    match *op {
        Operation::Nop => String::new(),
        Operation::Texture3d => set(format!("ts_volume({img}, {c}.xyz, {c}.w)")),
        Operation::TextureCubeMap => set(format!("ts_cube({img}, {c}.xyz)")),
        Operation::Texture1d => set(format!("ts_lookup({img}, {c}.x, 0, {c}.w)")),
        Operation::Texture2d | Operation::TextureRectangle => {
            set(format!("ts_lookup({img}, {c}.x, {c}.y, {c}.w)"))
        }
        Operation::PassThrough => {
            let k = |k: &str| format!("floor_div({c}.{k} * 255 + 32768, 65536)");
            set(format!(
                "clamp(vec4<i32>({}, {}, {}, {}), vec4<i32>(0), vec4<i32>(255))",
                k("x"),
                k("y"),
                k("z"),
                k("w")
            ))
        }
        Operation::CullFragment(conds) => {
            let tests: Vec<String> = conds
                .iter()
                .zip(["x", "y", "z", "w"])
                .map(|(cond, k)| match cond {
                    CullCondition::GequalToZero => format!("{c}.{k} >= 0"),
                    CullCondition::LessThanZero => format!("{c}.{k} < 0"),
                })
                .collect();
            format!("    culled = culled || !({});\n", tests.join(" && "))
        }
        Operation::Offset { rectangle, previous, matrix, scale } => {
            set(offset_value(unit, previous, rectangle, matrix, scale))
        }
        Operation::Dependent { green_blue, previous } => {
            let (s, t) = if green_blue { ("y", "z") } else { ("w", "x") };
            set(format!(
                "ts_lookup({img}, ts_coordinate(tex{previous}.{s}, false), ts_coordinate(tex{previous}.{t}, false), 65536)"
            ))
        }
        Operation::DotProduct { family, step, previous, mapping, eye } => {
            let slot = ["x", "y", "z"][step as usize];
            let mut code =
                format!("    dots.{slot} = {};\n    eyes.{slot} = {c}.w;\n", dot_expr(&c, previous, mapping));
            if let Some(e) = eye {
                let e = e.map(eye_units);
                code.push_str(&format!("    const_eye = vec3<i32>({}, {}, {});\n", e[0], e[1], e[2]));
            }
            if step == 1 && family.has_output(1) {
                // The diffuse stage reads N = (dot0, dot1, dot2): the next dot product first.
                if let Operation::DotProduct { previous: p, mapping: m, .. } = program.stage(unit + 1) {
                    let next = unit + 1;
                    let signed = signed_coordinates(&program.stage(next));
                    code.push_str(&format!(
                        "    let c{next}_early = ts_coordinates(coord{next}_image, {next}u, p, {signed});\n"
                    ));
                    code.push_str(&format!("    dots.z = {};\n", dot_expr(&format!("c{next}_early"), p, m)));
                }
            }
            if family.has_output(step) {
                if let Some(value) = dot_lookup(&img, family, step) {
                    code.push_str(&set(value));
                }
            }
            code
        }
    }
}

/// dot((s, t, r), mapped RGB of `tex{previous}`), in coordinate units.
fn dot_expr(c: &str, previous: u8, mapping: DotMapping) -> String {
    let m = |k: &str| match mapping {
        DotMapping::UnsignedIdentity => format!("tex{previous}.{k}"),
        DotMapping::ExpandNormal => format!("(2 * tex{previous}.{k} - 255)"),
    };
    format!("floor_div({c}.x * {} + {c}.y * {} + {c}.z * {}, 255)", m("x"), m("y"), m("z"))
}

/// The lookup a dot-product family's output stage makes.
fn dot_lookup(img: &str, family: DotFamily, step: u8) -> Option<String> {
    let n = "vec3<i32>(floor_div(dots.x, 256), floor_div(dots.y, 256), floor_div(dots.z, 256))";
    let eyes = "vec3<i32>(floor_div(eyes.x, 256), floor_div(eyes.y, 256), floor_div(eyes.z, 256))";
    Some(match family {
        DotFamily::Texture2d => format!("ts_lookup({img}, dots.x, dots.y, 65536)"),
        DotFamily::Rectangle => {
            format!("ts_fetch({img}, floor_div(dots.x, 65536), floor_div(dots.y, 65536))")
        }
        DotFamily::DepthReplace => return None,
        DotFamily::Texture3d => format!("ts_volume({img}, dots, 65536)"),
        DotFamily::CubeMap => format!("ts_cube({img}, dots)"),
        DotFamily::DiffuseReflectEyeFromQs | DotFamily::DiffuseReflectConstEye if step == 1 => {
            format!("ts_cube({img}, dots)")
        }
        DotFamily::ReflectEyeFromQs | DotFamily::DiffuseReflectEyeFromQs => {
            format!("ts_cube({img}, ts_reflect({n}, {eyes}))")
        }
        DotFamily::ReflectConstEye | DotFamily::DiffuseReflectConstEye => {
            format!("ts_cube({img}, ts_reflect({n}, const_eye))")
        }
    })
}

fn offset_value(
    unit: usize,
    previous: u8,
    rectangle: bool,
    matrix: [f32; 4],
    scale: Option<(f32, f32)>,
) -> String {
    let img = format!("texture{unit}_image");
    let c = format!("c{unit}");
    let m = matrix.map(matrix_units);
    let ds = format!("ts_signed(tex{previous}.x)");
    let dt = format!("ts_signed(tex{previous}.y)");
    let os = format!("ts_offset({}, {}, {ds}, {dt})", m[0], m[2]);
    let ot = format!("ts_offset({}, {}, {ds}, {dt})", m[1], m[3]);
    let texel = if rectangle {
        let d = format!("vec2<i32>(textureDimensions({img}))");
        format!(
            "ts_fetch({img}, floor_div(clamp({c}.x, -131072, 131072) * {d}.x + clamp({os}, -16777216, 16777216), 65536), floor_div(clamp({c}.y, -131072, 131072) * {d}.y + clamp({ot}, -16777216, 16777216), 65536))"
        )
    } else {
        format!("ts_lookup({img}, {c}.x + {os}, {c}.y + {ot}, 65536)")
    };
    match scale {
        None => texel,
        Some((scale, bias)) => {
            let (sk, bk) = (matrix_units(scale), matrix_units(bias));
            format!("ts_scale({texel}, clamp({sk} * tex{previous}.z + {bk} * 255, 0, 1044480))")
        }
    }
}
