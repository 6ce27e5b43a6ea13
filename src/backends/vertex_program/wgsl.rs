//! A vertex program as a WGSL vertex stage: one statement per instruction
//! on `array<vec4<f32>, N>` register files, the parameters `c[]` a uniform
//! array, each attribute the program reads a `@location(k)` input (`v[k]`),
//! `o[HPOS]` the clip position and every other result it writes a
//! `@location` output in the order of [`super::program::OUTPUT_NAMES`]. The
//! instructions' functions are the ones [`super::emulate`] computes, in the
//! same order of operations (a dot product summed x, y, z, w), so the two
//! agree within the GPU's f32 rounding of `1/x`, `inverseSqrt`, `log2`,
//! `exp2` and a multiply-add it may fuse.

use std::fmt::Write as _;

use super::program::*;

/// The shared functions and `fn vertex_program(v) -> array<vec4<f32>, 15>`,
/// reading `c` (declared here at `@group(0) @binding(0)`). The entry point
/// of [`translate`] calls it; a test harness may call it from a compute
/// shader instead.
pub fn function(program: &VertexProgram) -> String {
    let mut out = String::from(DECLARATION);
    out.push_str(&functions(program, "c"));
    out
}

/// The functions of [`function`] reading the parameter registers from
/// `parameters` (an expression of type `array<vec4<f32>, 96>`).
fn functions(program: &VertexProgram, parameters: &str) -> String {
    let mut out = format!(
        "fn vp_param(i: i32) -> vec4<f32> {{\n    if (i < 0 || i > 95) {{ return vec4<f32>(0.0); }}\n    return {parameters}[i];\n}}\n"
    );
    out.push_str(PRELUDE);
    out.push_str("fn vertex_program(v: array<vec4<f32>, 16>) -> array<vec4<f32>, 15> {\n");
    out.push_str("    var r: array<vec4<f32>, 12>;\n");
    out.push_str("    var o: array<vec4<f32>, 15>;\n");
    out.push_str("    for (var i = 0; i < 15; i++) { o[i] = vec4<f32>(0.0, 0.0, 0.0, 1.0); }\n");
    out.push_str("    var a0: i32 = 0;\n");
    for ins in &program.instructions {
        let _ = writeln!(out, "    // {}", super::printer::instruction(ins));
        out.push_str(&statement(ins, parameters));
    }
    out.push_str("    return o;\n}\n");
    out
}

/// The entry point of [`pass_stage`].
pub const PASS_ENTRY: &str = "vp_main";

/// A pass's vertex program as the vertex stage of a pass whose fragment
/// stage is another module (the WGSL backend's): `@vertex fn vp_main`
/// writes `outputs[k]` to `@location(k)` as a perspective-interpolated
/// `vec4<f32>`, the colours clamped to [0, 1] as they reach the
/// rasterizer (NV_vertex_program, Section 2.14.1.5; `Results::rasterized`),
/// and `o[HPOS]` with GL's depth range −w..w mapped to wgpu's 0..w as the
/// backend's own vertex stage maps it. The parameters share the pass's
/// uniform buffer (`@group(0) @binding(0)`): the fragment stage's block is
/// its first `host_vec4s` vectors, `c[0]`..`c[95]` follow.
pub fn pass_stage(program: &VertexProgram, outputs: &[Output], host_vec4s: usize) -> String {
    let mut out = String::from("// A vertex program (NV_vertex_program) as a pass's WGSL vertex stage.\n\n");
    out.push_str("struct VpParameters {\n");
    if host_vec4s > 0 {
        let _ = writeln!(out, "    host: array<vec4<f32>, {host_vec4s}>,");
    }
    out.push_str(
        "    c: array<vec4<f32>, 96>,\n}\n\n@group(0) @binding(0) var<uniform> vp: VpParameters;\n\n",
    );
    out.push_str(&functions(program, "vp.c"));
    let read = attributes_read(program);
    out.push_str("\nstruct VpIn {\n");
    for k in &read {
        let _ = writeln!(out, "    @location({k}) v{k}: vec4<f32>,");
    }
    if read.is_empty() {
        out.push_str("    @builtin(vertex_index) index: u32,\n");
    }
    out.push_str("}\n\nstruct VpOut {\n    @builtin(position) hpos: vec4<f32>,\n");
    for k in 0..outputs.len() {
        let _ = writeln!(out, "    @location({k}) i{k}: vec4<f32>,");
    }
    let _ = write!(
        out,
        "}}\n\n@vertex\nfn {PASS_ENTRY}(input: VpIn) -> VpOut {{\n    var v: array<vec4<f32>, 16>;\n"
    );
    for k in &read {
        let _ = writeln!(out, "    v[{k}] = input.v{k};");
    }
    out.push_str("    let o = vertex_program(v);\n    var out: VpOut;\n");
    out.push_str("    out.hpos = vec4<f32>(o[0].xy, (o[0].z + o[0].w) * 0.5, o[0].w);\n");
    for (k, o) in outputs.iter().enumerate() {
        let i = o.index();
        if Output::COLOURS.contains(o) {
            let _ = writeln!(out, "    out.i{k} = clamp(o[{i}], vec4<f32>(0.0), vec4<f32>(1.0));");
        } else {
            let _ = writeln!(out, "    out.i{k} = o[{i}];");
        }
    }
    out.push_str("    return out;\n}\n");
    out
}

/// A whole WGSL module with a `@vertex fn main` (a vertex state program:
/// with a `@compute fn main`, [`state_program`]).
pub fn translate(program: &VertexProgram, title: &str) -> String {
    if program.version.is_state_program() {
        return state_program(program, title);
    }
    let mut out = format!("// {title}: a vertex program (NV_vertex_program) as a WGSL vertex stage.\n\n");
    out.push_str(&function(program));
    let read = attributes_read(program);
    let written = outputs_written(program);
    out.push_str("\nstruct VertexIn {\n");
    for k in &read {
        let _ = writeln!(out, "    @location({k}) v{k}: vec4<f32>,");
    }
    if read.is_empty() {
        out.push_str("    @builtin(vertex_index) index: u32,\n");
    }
    out.push_str("}\n\nstruct VertexOut {\n    @builtin(position) hpos: vec4<f32>,\n");
    for (j, o) in written.iter().enumerate() {
        let _ = writeln!(out, "    @location({j}) {}: vec4<f32>,", OUTPUT_NAMES[*o].to_ascii_lowercase());
    }
    out.push_str("}\n\n@vertex\nfn main(input: VertexIn) -> VertexOut {\n    var v: array<vec4<f32>, 16>;\n");
    for k in &read {
        let _ = writeln!(out, "    v[{k}] = input.v{k};");
    }
    out.push_str("    let o = vertex_program(v);\n    var out: VertexOut;\n    out.hpos = o[0];\n");
    for o in &written {
        let name = OUTPUT_NAMES[*o].to_ascii_lowercase();
        // The colours reach the rasterizer clamped to [0, 1]
        // (NV_vertex_program, Section 2.14.1.5; `Results::rasterized`).
        // WGSL has no point size, so `o[PSIZ]` is passed on as written.
        if Output::COLOURS.iter().any(|c| c.index() == *o) {
            let _ = writeln!(out, "    out.{name} = clamp(o[{o}], vec4<f32>(0.0), vec4<f32>(1.0));");
        } else {
            let _ = writeln!(out, "    out.{name} = o[{o}];");
        }
    }
    out.push_str("    return out;\n}\n");
    out
}

/// A vertex state program (`!!VSP1.0`) as a WGSL compute shader that runs
/// it once, as `ExecuteProgramNV` does (NV_vertex_program, Section
/// 2.14.4): the parameters `c[]` a read-write storage buffer the program
/// updates in place (a later instruction reads what an earlier one wrote),
/// `v[0]` the uniform the application passes.
pub fn state_program(program: &VertexProgram, title: &str) -> String {
    let mut out =
        format!("// {title}: a vertex state program (NV_vertex_program) as a WGSL compute shader.\n\n");
    out.push_str("@group(0) @binding(0) var<storage, read_write> c: array<vec4<f32>, 96>;\n");
    out.push_str("@group(0) @binding(1) var<uniform> v0: vec4<f32>;\n\n");
    out.push_str(&functions(program, "c"));
    out.push_str(
        "\n@compute @workgroup_size(1)\nfn main() {\n    var v: array<vec4<f32>, 16>;\n    v[0] = v0;\n",
    );
    out.push_str("    _ = vertex_program(v);\n}\n");
    out
}

/// The attribute registers the program reads, ascending.
pub fn attributes_read(program: &VertexProgram) -> Vec<usize> {
    let mut read = [false; ATTRIBUTES];
    for s in program.instructions.iter().flat_map(|i| &i.src) {
        if let SrcReg::Attribute(k) = s.reg {
            read[usize::from(k) % ATTRIBUTES] = true;
        }
    }
    (0..ATTRIBUTES).filter(|&k| read[k]).collect()
}

/// The result registers other than `o[HPOS]` the program writes, ascending.
pub fn outputs_written(program: &VertexProgram) -> Vec<usize> {
    let mut written = [false; OUTPUTS];
    for i in &program.instructions {
        if let DstReg::Output(o) = i.dst.reg {
            written[o.index() % OUTPUTS] = true;
        }
    }
    (1..OUTPUTS).filter(|&k| written[k]).collect()
}

const DECLARATION: &str = "@group(0) @binding(0) var<uniform> c: array<vec4<f32>, 96>;

";

const PRELUDE: &str = "
fn vp_rcp(x: f32) -> f32 {
    if (x == 1.0) { return 1.0; }
    return 1.0 / x;
}

fn vp_rcc(x: f32) -> f32 {
    let r = vp_rcp(x);
    let m = clamp(abs(r), 5.42101e-20, 1.884467e19);
    return select(m, -m, r < 0.0);
}

fn vp_rsq(x: f32) -> f32 {
    let t = abs(x);
    if (t == 1.0) { return 1.0; }
    return inverseSqrt(t);
}

fn vp_log(x: f32) -> vec4<f32> {
    let t = abs(x);
    if (t == 0.0) { return vec4<f32>(-bitcast<f32>(0x7f800000u), 1.0, -bitcast<f32>(0x7f800000u), 1.0); }
    let bits = bitcast<u32>(t);
    let e = f32(i32((bits >> 23u) & 0xffu) - 127);
    let m = bitcast<f32>((bits & 0x7fffffu) | 0x3f800000u);
    return vec4<f32>(e, m, log2(t), 1.0);
}

fn vp_exp(x: f32) -> vec4<f32> {
    let f = floor(x);
    return vec4<f32>(exp2(f), x - f, exp2(x), 1.0);
}

fn vp_lit(s: vec4<f32>) -> vec4<f32> {
    let x = select(s.x, 0.0, s.x < 0.0);
    let y = select(s.y, 0.0, s.y < 0.0);
    let w = clamp(s.w, -(128.0 - 1.0 / 256.0), 128.0 - 1.0 / 256.0);
    var z = 0.0;
    if (x > 0.0) {
        if (y == 0.0 && w == 0.0) { z = 1.0; } else { z = exp2(w * log2(y)); }
    }
    return vec4<f32>(1.0, x, z, 1.0);
}

fn vp_dp3(a: vec4<f32>, b: vec4<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn vp_dp4(a: vec4<f32>, b: vec4<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w;
}

";

fn operand(s: &Source, parameters: &str) -> String {
    let reg = match s.reg {
        SrcReg::Attribute(k) => format!("v[{k}]"),
        SrcReg::Parameter(k) => format!("{parameters}[{k}]"),
        SrcReg::Relative(k) => format!("vp_param(a0 + {k})"),
        SrcReg::Temporary(k) => format!("r[{k}]"),
    };
    let xyzw = ['x', 'y', 'z', 'w'];
    let sw: String = s.swizzle.iter().map(|&c| xyzw[usize::from(c & 3)]).collect();
    let v = if sw == "xyzw" { reg } else { format!("{reg}.{sw}") };
    if s.negate {
        format!("(-{v})")
    } else {
        v
    }
}

fn value(op: Opcode, s: &[String]) -> String {
    let a = s.first().map_or("vec4<f32>(0.0)", String::as_str);
    let b = s.get(1).map_or("vec4<f32>(0.0)", String::as_str);
    let c = s.get(2).map_or("vec4<f32>(0.0)", String::as_str);
    use Opcode::*;
    match op {
        Mov => a.to_string(),
        Mul => format!("{a} * {b}"),
        Add => format!("{a} + {b}"),
        Sub => format!("{a} - {b}"),
        Mad => format!("{a} * {b} + {c}"),
        Abs => format!("abs({a})"),
        Dst => format!("vec4<f32>(1.0, {a}.y * {b}.y, {a}.z, {b}.w)"),
        Min => format!("select({b}, {a}, {a} < {b})"),
        Max => format!("select({b}, {a}, {a} >= {b})"),
        Slt => format!("select(vec4<f32>(0.0), vec4<f32>(1.0), {a} < {b})"),
        Sge => format!("select(vec4<f32>(0.0), vec4<f32>(1.0), {a} >= {b})"),
        Rcp => format!("vec4<f32>(vp_rcp({a}.x))"),
        Rcc => format!("vec4<f32>(vp_rcc({a}.x))"),
        Rsq => format!("vec4<f32>(vp_rsq({a}.x))"),
        Dp3 => format!("vec4<f32>(vp_dp3({a}, {b}))"),
        Dp4 => format!("vec4<f32>(vp_dp4({a}, {b}))"),
        Dph => format!("vec4<f32>(vp_dp3({a}, {b}) + {b}.w)"),
        Log => format!("vp_log({a}.x)"),
        Exp => format!("vp_exp({a}.x)"),
        Lit => format!("vp_lit({a})"),
        Arl => a.to_string(),
    }
}

fn statement(ins: &Instruction, parameters: &str) -> String {
    let srcs: Vec<String> = ins.src.iter().map(|s| operand(s, parameters)).collect();
    if ins.op == Opcode::Arl {
        return format!("    a0 = i32(floor({}.x));\n", srcs[0]);
    }
    let target = match ins.dst.reg {
        DstReg::Temporary(k) => format!("r[{k}]"),
        DstReg::Output(o) => format!("o[{}]", o.index()),
        DstReg::Parameter(k) => format!("{parameters}[{k}]"),
        DstReg::Address => return String::new(),
    };
    if ins.dst.mask & 15 == 15 {
        return format!("    {target} = {};\n", value(ins.op, &srcs));
    }
    let mut out = format!("    {{\n        let t = {};\n", value(ins.op, &srcs));
    for (k, c) in ['x', 'y', 'z', 'w'].iter().enumerate() {
        if ins.dst.mask & (1 << k) != 0 {
            let _ = writeln!(out, "        {target}.{c} = t.{c};");
        }
    }
    out.push_str("    }\n");
    out
}
