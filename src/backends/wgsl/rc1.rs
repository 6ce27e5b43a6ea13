//! Legacy register-combiner configs (`!!RC1.0`, or RON) as WGSL:
//! `shadec translate CONFIG.rc --emit wgsl`. The fragment shader evaluates
//! the config exactly as `combiners::emulator` does in `fixed9` — registers
//! are integers in [−255, 255] (units of 1/255), mapped inputs in units of
//! 1/510, products in 1/260100, and the only rounding is on the register
//! write, `⌊(t + 1020) / 2040⌋` clamped to ±255 (`docs/combiners.md`) — in
//! `i32` arithmetic, so its image is bit-identical to the emulator's.
//!
//! Interface (the runner's conventions): a full-screen pass.
//! - Vertex input `@location(0)`: the clip-space position, passed through.
//! - Group 0, `@binding(0)`: `Uniforms { constant0, constant1, fog }` (RGBA
//!   in [0, 1]); constants the config sets itself are baked in and these
//!   are ignored, as the emulator's `--const0` is.
//! - Units 0-3 (`@binding(1 + 2i)`, sampler at `2 + 2i`): texture0..3;
//!   unit 4 the primary colour, unit 5 the secondary colour — each an RGBA8
//!   image of the target's size, read with `textureLoad` at the pixel (the
//!   emulator's per-pixel inputs); bind a black image for a missing input.
//!
//! The text is generated directly (so it keeps its comments) and checked
//! by naga's WGSL front end and validator before it is returned.

use std::fmt::Write as _;

use crate::backends::combiners::config::{
    Bias, CombinerConfig, ComponentUsage, FinalSource, GeneralInput, GeneralPortion, InputMapping,
    PortionKind, Register, Scale,
};
use crate::backends::combiners::emulator::HARDWARE_HALF;

/// Registers in `Register::ALL` order, as WGSL variable names.
fn reg_name(r: Register) -> String {
    format!("r_{}", r.name())
}

/// `from_unit`: round(clamp(v, 0, 1) · 255), NaN → 0.
fn unit_k(v: f32) -> i32 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (v * 255.0 + 0.5).floor() as i32
}

/// An RGBA8 input at the pixel, as integers 0..255 (`translate` only).
pub(crate) const TEXEL_HELPER: &str = r#"
// An RGBA8 input at the pixel, as integers 0..255.
fn texel(t: texture_2d<f32>, p: vec2<i32>) -> vec4<i32> {
    return vec4<i32>(round(textureLoad(t, p, 0) * 255.0));
}
"#;

const HELPERS: &str = r#"
// ⌊a / b⌋ for b > 0 (WGSL's integer division truncates toward zero).
fn floor_div(a: i32, b: i32) -> i32 {
    let q = a / b;
    return select(q, q - 1, (a % b != 0) && (a < 0));
}

// A register write: t in units of 1/520200 to units of 1/255, to nearest
// with ties toward +∞, clamped to [−255, 255].
fn register_write(t: i32) -> i32 {
    return clamp(floor_div(t + 1020, 2040), -255, 255);
}

fn register_write3(t: vec3<i32>) -> vec3<i32> {
    return vec3<i32>(register_write(t.x), register_write(t.y), register_write(t.z));
}

// n / 510 rounded to nearest (ties up), for the final combiner.
fn round_510(n: i32) -> i32 {
    return floor_div(floor_div(2 * n + 255, 2), 255);
}

fn round_510_3(n: vec3<i32>) -> vec3<i32> {
    return vec3<i32>(round_510(n.x), round_510(n.y), round_510(n.z));
}

// A colour parameter: round(clamp(c, 0, 1) · 255).
fn unit_k(c: vec4<f32>) -> vec4<i32> {
    return vec4<i32>(floor(clamp(c, vec4<f32>(0.0), vec4<f32>(1.0)) * 255.0 + 0.5));
}
"#;

/// Translates `config` to a WGSL module (vertex `vs_main`, fragment `fs_main`).
///
/// A config with a `!!TS1.0` texture shader is translated by [`super::ts1`]
/// (its stages compute texture0..3; the bindings differ, see there).
pub fn translate(config: &CombinerConfig, title: &str) -> Result<String, String> {
    if let Some(program) = &config.texture_shader {
        return super::ts1::translate(config, program, title);
    }
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(w, "// shadec translate: {title}");
    let _ = writeln!(
        w,
        "// The register combiners in fixed9 (8 bits + sign), as `shadec emulate --precision fixed9`."
    );
    let _ = writeln!(
        w,
        "// {} general combiner(s); bindings: docs/combiners.md, \"Translated shaders\".",
        config.general.len()
    );
    let _ = writeln!(w, "\nstruct Uniforms {{\n    constant0: vec4<f32>,\n    constant1: vec4<f32>,\n    fog: vec4<f32>,\n}}\n");
    let _ = writeln!(w, "@group(0) @binding(0) var<uniform> uniforms: Uniforms;");
    let units = ["texture0", "texture1", "texture2", "texture3", "primary", "secondary"];
    for (i, name) in units.iter().enumerate() {
        let _ = writeln!(w, "@group(0) @binding({}) var {name}_image: texture_2d<f32>;", 1 + 2 * i);
        let _ = writeln!(w, "@group(0) @binding({}) var {name}_sampler: sampler;", 2 + 2 * i);
    }
    w.push_str(HELPERS);
    w.push_str(TEXEL_HELPER);
    w.push_str(&combiners_function(config));
    let _ = writeln!(w, "\n@vertex\nfn vs_main(@location(0) position: vec4<f32>) -> @builtin(position) vec4<f32> {{\n    return position;\n}}\n");
    let _ =
        writeln!(w, "@fragment\nfn fs_main(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {{");
    let _ = writeln!(w, "    let p = vec2<i32>(frag.xy);");
    let args: Vec<String> = units.iter().map(|u| format!("texel({u}_image, p)")).collect();
    let _ = writeln!(
        w,
        "    return {COMBINERS_FUNCTION}({}, uniforms.constant0, uniforms.constant1, uniforms.fog);",
        args.join(", ")
    );
    let _ = writeln!(w, "}}");
    // A compiler bug if naga rejects it.
    super::validate::parse_and_validate(&s)
        .map_err(|e| format!("compiler bug: the translated shader {e}"))?;
    Ok(s)
}

/// The name of the function [`combiners_function`] defines.
pub const COMBINERS_FUNCTION: &str = "register_combiners";

/// The helpers [`combiners_function`]'s text calls (register writes and
/// roundings, `unit_k`), to be placed once in the same module.
pub fn combiners_helpers() -> &'static str {
    HELPERS
}

/// `config` as one WGSL function of the per-pixel registers:
/// `register_combiners(texture0, texture1, texture2, texture3, primary,
/// secondary: vec4<i32>, constant0, constant1, fog: vec4<f32>) -> vec4<f32>`
/// — registers as integers 0..255, constants and fog as colours in [0, 1]
/// (used where the config leaves them unset) — returning the final
/// combiner's RGBA in [0, 1], computed exactly as the emulator's fixed9
/// model does. Needs [`combiners_helpers`] in the module.
pub fn combiners_function(config: &CombinerConfig) -> String {
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(
        w,
        "\n// The register combiners (Kilgard 2000, Section 4.2) in fixed9: {} general combiner(s).",
        config.general.len()
    );
    let _ = writeln!(
        w,
        "fn {COMBINERS_FUNCTION}(in_texture0: vec4<i32>, in_texture1: vec4<i32>, in_texture2: vec4<i32>, in_texture3: vec4<i32>, in_primary: vec4<i32>, in_secondary: vec4<i32>, in_constant0: vec4<f32>, in_constant1: vec4<f32>, in_fog: vec4<f32>) -> vec4<f32> {{"
    );
    let _ = writeln!(w, "    // Registers (Table 2), integers in units of 1/255.");
    let _ = writeln!(w, "    var r_zero = vec4<i32>(0);");
    let constant = |c: Option<[f32; 4]>, given: &str| match c {
        Some(c) => {
            format!("vec4<i32>({}, {}, {}, {})", unit_k(c[0]), unit_k(c[1]), unit_k(c[2]), unit_k(c[3]))
        }
        None => format!("unit_k({given})"),
    };
    let _ = writeln!(w, "    var r_fog = unit_k(in_fog);");
    let _ = writeln!(w, "    var r_constant0 = {};", constant(config.constant0, "in_constant0"));
    let _ = writeln!(w, "    var r_constant1 = {};", constant(config.constant1, "in_constant1"));
    let _ = writeln!(w, "    var r_primary = in_primary;");
    let _ = writeln!(w, "    var r_secondary = in_secondary;");
    for i in 0..4 {
        let _ = writeln!(w, "    var r_texture{i} = in_texture{i};");
    }
    let _ = writeln!(w, "    // spare0.rgb and spare1 start at zero, spare0.a = texture0.a (Section 4.2.1).");
    let _ = writeln!(w, "    var r_spare0 = vec4<i32>(0, 0, 0, r_texture0.w);");
    let _ = writeln!(w, "    var r_spare1 = vec4<i32>(0);");
    for (k, stage) in config.general.iter().enumerate() {
        let _ =
            writeln!(w, "    // General combiner {k}: both portions read the registers as the stage began.");
        let _ = writeln!(w, "    {{");
        let c0 = stage.constant0.or(config.constant0);
        let c1 = stage.constant1.or(config.constant1);
        if stage.constant0.is_some() || stage.constant1.is_some() {
            let _ = writeln!(w, "        // Per-stage constants.");
            let _ = writeln!(w, "        let r_constant0 = {};", constant(c0, "in_constant0"));
            let _ = writeln!(w, "        let r_constant1 = {};", constant(c1, "in_constant1"));
        }
        let mut writes = Vec::new();
        for kind in [PortionKind::Rgb, PortionKind::Alpha] {
            portion(w, stage.portion(kind), kind, &mut writes);
        }
        for (r, kind, value) in writes {
            let name = reg_name(r);
            match kind {
                PortionKind::Rgb => {
                    let _ = writeln!(w, "        {name} = vec4<i32>({value}, {name}.w);");
                }
                PortionKind::Alpha => {
                    let _ = writeln!(w, "        {name}.w = {value};");
                }
            }
        }
        let _ = writeln!(w, "    }}");
    }
    final_combiner(w, config);
    let _ = writeln!(w, "}}");
    s
}

/// One input variable, mapped (units of 1/510).
fn mapped(input: &GeneralInput, kind: PortionKind) -> String {
    let r = reg_name(input.register);
    let (src, zero, k255) = match (kind, input.usage) {
        (PortionKind::Rgb, ComponentUsage::Rgb) => (format!("{r}.xyz"), "vec3<i32>(0)", "vec3<i32>(255)"),
        (PortionKind::Rgb, ComponentUsage::Alpha) => {
            (format!("vec3<i32>({r}.w)"), "vec3<i32>(0)", "vec3<i32>(255)")
        }
        (PortionKind::Rgb, ComponentUsage::Blue) => {
            (format!("vec3<i32>({r}.z)"), "vec3<i32>(0)", "vec3<i32>(255)")
        }
        (PortionKind::Alpha, ComponentUsage::Blue) => (format!("{r}.z"), "0", "255"),
        (PortionKind::Alpha, _) => (format!("{r}.w"), "0", "255"),
    };
    match input.mapping {
        InputMapping::UnsignedIdentity => format!("2 * max({src}, {zero})"),
        InputMapping::UnsignedInvert => format!("2 * (255 - clamp({src}, {zero}, {k255}))"),
        InputMapping::ExpandNormal => format!("4 * max({src}, {zero}) - 510"),
        InputMapping::ExpandNegate => format!("510 - 4 * max({src}, {zero})"),
        InputMapping::HalfBiasNormal => format!("2 * max({src}, {zero}) - 255"),
        InputMapping::HalfBiasNegate => format!("255 - 2 * max({src}, {zero})"),
        InputMapping::SignedIdentity => format!("2 * {src}"),
        InputMapping::SignedNegate => format!("-2 * {src}"),
    }
}

fn portion(
    w: &mut String,
    p: &GeneralPortion,
    kind: PortionKind,
    writes: &mut Vec<(Register, PortionKind, String)>,
) {
    let sum = p.sum_output.is_some();
    let need_ab = p.ab_output.is_some() || sum;
    let need_cd = p.cd_output.is_some() || sum;
    let k = if kind == PortionKind::Rgb { "rgb" } else { "alpha" };
    if !need_ab && !need_cd {
        let _ = writeln!(w, "        // {k} portion: computes nothing.");
        return;
    }
    let _ = writeln!(w, "        // {k} portion.");
    let rgb = kind == PortionKind::Rgb;
    for (v, input, needed) in
        [("a", &p.a, need_ab), ("b", &p.b, need_ab), ("c", &p.c, need_cd), ("d", &p.d, need_cd)]
    {
        if needed {
            let _ = writeln!(
                w,
                "        let {k}_{v} = {}; // {} {}",
                mapped(input, kind),
                input.mapping.name(),
                input.register.name()
            );
        }
    }
    let product = |x: &str, y: &str, dot: bool| {
        if dot && rgb {
            format!("vec3<i32>(dot({k}_{x}, {k}_{y}))")
        } else {
            format!("{k}_{x} * {k}_{y}")
        }
    };
    if need_ab {
        let _ = writeln!(w, "        let {k}_ab = {};", product("a", "b", p.ab_dot));
    }
    if need_cd {
        let _ = writeln!(w, "        let {k}_cd = {};", product("c", "d", p.cd_dot));
    }
    if sum {
        if p.mux_sum {
            let _ = writeln!(
                w,
                "        let {k}_sum = select({k}_cd, {k}_ab, r_spare0.w < 128); // mux: spare0.a < ½ → AB"
            );
        } else {
            let _ = writeln!(w, "        let {k}_sum = {k}_ab + {k}_cd;");
        }
    }
    let b = match p.bias {
        Bias::Zero => 0,
        Bias::NegativeOneHalf => -(HARDWARE_HALF as i32) * 1020,
    };
    let s = match p.scale {
        Scale::OneHalf => 1,
        Scale::One => 2,
        Scale::Two => 4,
        Scale::Four => 8,
    };
    let write_fn = if rgb { "register_write3" } else { "register_write" };
    for (slot, out) in [("ab", p.ab_output), ("cd", p.cd_output), ("sum", p.sum_output)] {
        if let Some(r) = out {
            let v = format!("{k}_{slot}_out");
            let biased = if b == 0 { format!("{k}_{slot}") } else { format!("({k}_{slot} + {b})") };
            let _ = writeln!(w, "        let {v} = {write_fn}({biased} * {s}); // → {}", r.name());
            writes.push((r, kind, v));
        }
    }
}

fn final_combiner(w: &mut String, config: &CombinerConfig) {
    let fc = &config.final_combiner;
    let _ = writeln!(w, "    // Final combiner: rgb = A·B + (1 − A)·C + D, alpha = G (Section 4.2.3).");
    // (Per-stage constants were block-scoped: the global ones apply here.)
    let vars = [fc.a, fc.b, fc.c, fc.d, fc.e, fc.f, fc.g];
    let uses = |src: FinalSource| vars[..4].iter().any(|v| v.source == src);
    let load = |v: usize| -> String {
        let input = vars[v];
        let src = match input.source {
            FinalSource::Register(r) => {
                let n = reg_name(r);
                if v == 6 && input.usage == ComponentUsage::Blue {
                    format!("{n}.z")
                } else if v == 6 {
                    format!("{n}.w")
                } else if input.usage == ComponentUsage::Alpha {
                    format!("vec3<i32>({n}.w)")
                } else {
                    format!("{n}.xyz")
                }
            }
            FinalSource::EfProduct => "ef".to_string(),
            FinalSource::Spare0PlusSecondary => "color_sum".to_string(),
        };
        let (zero, k255) = if v == 6 { ("0", "255") } else { ("vec3<i32>(0)", "vec3<i32>(255)") };
        match input.mapping {
            InputMapping::UnsignedInvert => format!("255 - clamp({src}, {zero}, {k255})"),
            _ => format!("max({src}, {zero})"),
        }
    };
    if uses(FinalSource::EfProduct) {
        let _ = writeln!(w, "    let fin_e = {};", load(4));
        let _ = writeln!(w, "    let fin_f = {};", load(5));
        let _ = writeln!(w, "    let ef = round_510_3(fin_e * fin_f);");
    }
    if uses(FinalSource::Spare0PlusSecondary) {
        let max = if fc.color_sum_clamp { 255 } else { 510 };
        let _ = writeln!(w, "    let color_sum = min(max(r_spare0.xyz, vec3<i32>(0)) + max(r_secondary.xyz, vec3<i32>(0)), vec3<i32>({max}));");
    }
    for (i, v) in ["a", "b", "c", "d"].iter().enumerate() {
        let _ = writeln!(w, "    let fin_{v} = {};", load(i));
    }
    let _ = writeln!(w, "    let fin_g = {};", load(6));
    let _ = writeln!(w, "    let rgb = min(round_510_3(fin_a * fin_b + (255 - fin_a) * fin_c + 255 * fin_d), vec3<i32>(255));");
    let _ = writeln!(
        w,
        "    let out = vec4<i32>(clamp(rgb, vec3<i32>(0), vec3<i32>(255)), clamp(fin_g, 0, 255));"
    );
    let _ = writeln!(w, "    return vec4<f32>(out) / 255.0;");
}
