//! `!!VP1.0` vertex programs (NV_vertex_program, NVIDIA 2001): reading with
//! located errors for the spec's reasons, the CPU interpreter against the
//! spec's pseudo-code, the WGSL vertex stage (naga, and wgpu on lavapipe
//! against the interpreter on generated programs), and the GeForce3 passes'
//! per-vertex parts emitted as programs that validate and compute what the
//! host's evaluator computes.

use shadec::backends::vertex_program::{self as vp, emulate, Opcode, Output, VertexProgram};
use shadec::diag::SourceFile;

fn errors(text: &str) -> Vec<(String, &'static str, String)> {
    match vp::parse_file(text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(ds) => {
            let file = SourceFile::new("t.vp", text);
            ds.iter().map(|d| (file.location(d.primary.span.start), d.code, d.message.clone())).collect()
        }
    }
}

fn one_error(text: &str) -> (String, &'static str, String) {
    let e = errors(text);
    assert_eq!(e.len(), 1, "{e:?}");
    e.into_iter().next().unwrap()
}

const TRANSFORM: &str = "!!VP1.0
# the modelview-projection in c[0]..c[3]
DP4 o[HPOS].x, c[0], v[OPOS];
DP4 o[HPOS].y, c[1], v[OPOS];
DP4 o[HPOS].z, c[2], v[OPOS];
DP4 o[HPOS].w, c[3], v[OPOS];
DP3 R0.x, v[NRML], c[4];      // N.L
MAX R0.x, R0.x, c[5].x;
MUL o[COL0], R0.x, v[COL0];
MOV o[TEX0], v[TEX0];
END
";

#[test]
fn reads_a_transform_and_diffuse_program() {
    let p = vp::parse_file(TRANSFORM).unwrap();
    assert_eq!(p.instructions.len(), 8);
    assert_eq!(p.instructions[0].op, Opcode::Dp4);
    assert_eq!(p.instructions[6].src[0].swizzle, [0; 4]);
    let printed = vp::print(&p);
    assert_eq!(vp::parse_file(&printed).unwrap(), p, "{printed}");
}

#[test]
fn two_attribute_registers_are_refused() {
    let (at, code, msg) = one_error("!!VP1.0\nMOV o[HPOS], v[0];\nADD R0, v[0], v[1];\nEND\n");
    assert_eq!((at.as_str(), code), ("t.vp:3:15", "two-attributes"), "{msg}");
}

#[test]
fn the_same_attribute_twice_is_allowed() {
    vp::parse_file("!!VP1.0\nMUL o[HPOS], v[0], v[0].yzxw;\nEND\n").unwrap();
}

#[test]
fn two_parameter_registers_are_refused() {
    let (at, code, _) = one_error("!!VP1.0\nMOV o[HPOS], v[0];\nMAD R0, v[0], c[1], c[2];\nEND\n");
    assert_eq!((at.as_str(), code), ("t.vp:3:21", "two-parameters"));
    let (_, code, _) = one_error("!!VP1.0\nARL A0.x, v[0].x;\nADD o[HPOS], c[A0.x + 1], c[3];\nEND\n");
    assert_eq!(code, "two-parameters");
}

#[test]
fn hpos_must_be_written() {
    let (at, code, msg) = one_error("!!VP1.0\nMOV o[COL0], v[3];\nEND\n");
    assert_eq!((at.as_str(), code), ("t.vp:1:1", "no-hpos"));
    assert!(msg.contains("o[HPOS]"), "{msg}");
}

#[test]
fn more_than_128_instructions_are_refused() {
    let body = "MOV o[HPOS], v[0];\n".repeat(129);
    let (at, code, _) = one_error(&format!("!!VP1.0\n{body}END\n"));
    assert_eq!((at.as_str(), code), ("t.vp:130:1", "too-many-instructions"));
    vp::parse_file(&format!("!!VP1.0\n{}END\n", "MOV o[HPOS], v[0];\n".repeat(128))).unwrap();
}

#[test]
fn vp11_instructions_need_the_vp11_header() {
    let (at, code, _) = one_error("!!VP1.0\nSUB o[HPOS], v[0], c[0];\nEND\n");
    assert_eq!((at.as_str(), code), ("t.vp:2:1", "not-in-vp1.0"));
    vp::parse_file("!!VP1.1\nSUB o[HPOS], v[0], c[0];\nDPH R0.x, v[0], c[1];\nEND\n").unwrap();
    let p = vp::parse_file("!!VP1.1\nOPTION NV_position_invariant;\nMOV o[COL0], v[3];\nEND\n").unwrap();
    assert!(p.position_invariant);
}

#[test]
fn registers_out_of_range_are_located() {
    for (text, at) in [
        ("!!VP1.0\nMOV o[HPOS], v[16];\nEND\n", "t.vp:2:16"),
        ("!!VP1.0\nMOV o[HPOS], c[96];\nEND\n", "t.vp:2:16"),
        ("!!VP1.0\nMOV R12, v[0];\nEND\n", "t.vp:2:5"),
        ("!!VP1.0\nARL A0.x, v[0].x;\nMOV o[HPOS], c[A0.x + 64];\nEND\n", "t.vp:3:23"),
    ] {
        let (got, code, _) = one_error(text);
        assert_eq!((got.as_str(), code), (at, "register-range"), "{text}");
    }
    vp::parse_file("!!VP1.0\nARL A0.x, v[0].x;\nMOV o[HPOS], c[A0.x - 64];\nEND\n").unwrap();
}

#[test]
fn grammar_errors_say_the_specs_reason() {
    let cases: [(&str, &str, &str); 9] = [
        ("!!VP1.0\nRCP R0, v[0];\nMOV o[HPOS], v[0];\nEND\n", "t.vp:2:9", "scalar"),
        ("!!VP1.0\nMOV o[HPOS], v[0].xy;\nEND\n", "t.vp:2:19", "not a swizzle"),
        ("!!VP1.0\nMOV o[HPOS].yx, v[0];\nEND\n", "t.vp:2:13", "not a write mask"),
        ("!!VP1.0\nmov o[HPOS], v[0];\nEND\n", "t.vp:2:1", "unknown instruction"),
        ("!!VP1.0\nMOV o[HPOS], v[0];\n", "t.vp:3:1", "no `END`"),
        ("!!VP1.0\nMOV v[0], c[0];\nMOV o[HPOS], v[0];\nEND\n", "t.vp:2:5", "cannot write"),
        ("!!VP1.0\nMOV o[HPOS], o[COL0];\nEND\n", "t.vp:2:14", "cannot read"),
        ("!!VP1.0\nMOV A0.x, v[0];\nEND\n", "t.vp:2:5", "address register"),
        ("!!ARBvp1.0\nEND\n", "t.vp:1:1", "ARB_vertex_program"),
    ];
    for (text, at, words) in cases {
        let (got, _, msg) = one_error(text);
        assert_eq!(got, at, "{text}: {msg}");
        assert!(msg.contains(words), "{text}: {msg}");
    }
}

#[test]
fn nothing_panics_on_mangled_programs() {
    let chars: Vec<char> = TRANSFORM.chars().collect();
    for cut in 0..chars.len() {
        let text: String = chars[..cut].iter().collect();
        let _ = vp::parse_file(&text);
        let mut swapped = chars.clone();
        swapped[cut] = ['[', ']', '-', '.', '9', 'R', ';', '#'][cut % 8];
        let _ = vp::parse_file(&swapped.iter().collect::<String>());
    }
}

fn run(text: &str, v: &[(usize, [f32; 4])], c: &[(usize, [f32; 4])]) -> emulate::Results {
    let p = vp::parse_file(text).unwrap_or_else(|e| panic!("{e:?}"));
    let mut a = [[0.0; 4]; 16];
    for (k, x) in v {
        a[*k] = *x;
    }
    let mut params = [[0.0; 4]; 96];
    for (k, x) in c {
        params[*k] = *x;
    }
    emulate::run(&p, &a, &params)
}

#[test]
fn registers_start_as_the_spec_says() {
    let r = run("!!VP1.0\nMOV o[HPOS], R3;\nEND\n", &[], &[]);
    assert_eq!(r.get(Output::HPOS), [0.0; 4]);
    assert_eq!(r.get(Output::COL0), [0.0, 0.0, 0.0, 1.0]);
}

#[test]
fn swizzle_negation_and_write_mask() {
    let r = run(
        "!!VP1.0\nMOV o[HPOS], c[1];\nMOV o[HPOS].yw, -v[0].wzyx;\nEND\n",
        &[(0, [1.0, 2.0, 3.0, 4.0])],
        &[(1, [9.0; 4])],
    );
    assert_eq!(r.get(Output::HPOS), [9.0, -3.0, 9.0, -1.0]);
}

#[test]
fn dst_lit_and_the_arithmetic_follow_the_pseudo_code() {
    let c = [(0, [2.0, 3.0, 5.0, 7.0]), (1, [11.0, 13.0, 17.0, 19.0])];
    let text = "!!VP1.0\nMOV o[HPOS], v[0];\nDST R0, v[0], c[1];\nMOV o[TEX0], R0;\nDP3 o[TEX1], v[0], v[0];\nDP4 o[TEX2], v[0], v[0];\nSLT o[TEX3], v[0], v[0].yxzw;\nSGE o[TEX4], v[0], v[0].yxzw;\nMIN o[TEX5], v[0], v[0].wzyx;\nMAX o[TEX6], v[0], v[0].wzyx;\nEND\n";
    let r = run(text, &[(0, [2.0, 3.0, 5.0, 7.0])], &c);
    assert_eq!(r.get(Output::tex(0)), [1.0, 3.0 * 13.0, 5.0, 19.0]);
    assert_eq!(r.get(Output::tex(1)), [38.0; 4]);
    assert_eq!(r.get(Output::tex(2)), [87.0; 4]);
    assert_eq!(r.get(Output::tex(3)), [1.0, 0.0, 0.0, 0.0]);
    assert_eq!(r.get(Output::tex(4)), [0.0, 1.0, 1.0, 1.0]);
    assert_eq!(r.get(Output::tex(5)), [2.0, 3.0, 3.0, 2.0]);
    assert_eq!(r.get(Output::tex(6)), [7.0, 5.0, 5.0, 7.0]);
    // LIT: (1, max(x, 0), x > 0 ? max(y, 0)^w : 0, 1), w clamped to ±(128 − 1/256).
    assert_eq!(emulate::lit([0.5, 0.25, 0.0, 2.0]), [1.0, 0.5, 0.0625, 1.0]);
    assert_eq!(emulate::lit([-0.5, 0.25, 0.0, 2.0]), [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(emulate::lit([1.0, 0.0, 0.0, 0.0]), [1.0, 1.0, 1.0, 1.0], "0^0 = 1");
    assert_eq!(emulate::lit([1.0, 2.0, 0.0, 1000.0])[2], (128.0f32 - 1.0 / 256.0).exp2());
}

#[test]
fn log_exp_rcp_rsq_follow_the_pseudo_code() {
    assert_eq!(emulate::log(-10.0), [3.0, 1.25, 10f32.log2(), 1.0]);
    assert_eq!(emulate::log(0.0), [f32::NEG_INFINITY, 1.0, f32::NEG_INFINITY, 1.0]);
    assert_eq!(emulate::log(1.0e-40)[0], -133.0, "subnormal exponent");
    assert!((1.0..2.0).contains(&emulate::log(1.0e-40)[1]));
    assert_eq!(emulate::exp(2.75), [4.0, 0.75, 2.75f32.exp2(), 1.0]);
    assert_eq!(emulate::exp(-1.25), [0.25, 0.75, (-1.25f32).exp2(), 1.0]);
    assert_eq!(emulate::rcp(1.0), 1.0);
    assert_eq!(emulate::rcp(-0.0), f32::NEG_INFINITY);
    assert_eq!(emulate::rsq(-4.0), 0.5, "RSQ takes |x|");
    assert_eq!(emulate::rsq(0.0), f32::INFINITY);
    assert_eq!(emulate::rcc(0.0), 1.884467e19);
    let r = run("!!VP1.0\nMOV o[HPOS], v[0];\nLOG o[TEX0], v[0].y;\nEXP o[TEX1], v[0].z;\nRCP o[TEX2].xz, v[0].w;\nEND\n", &[(0, [0.0, 8.0, 1.5, 4.0])], &[]);
    assert_eq!(r.get(Output::tex(0)), [3.0, 1.0, 3.0, 1.0]);
    assert_eq!(r.get(Output::tex(1)), [2.0, 0.5, 1.5f32.exp2(), 1.0]);
    assert_eq!(r.get(Output::tex(2)), [0.25, 0.0, 0.25, 1.0]);
}

#[test]
fn relative_addressing_and_out_of_range_reads() {
    let text = "!!VP1.0\nARL A0.x, v[0].x;\nMOV o[HPOS], c[A0.x + 2];\nMOV o[TEX0], c[A0.x - 3];\nEND\n";
    let c = [(5, [5.0; 4]), (0, [1.0; 4])];
    let r = run(text, &[(0, [3.7, 0.0, 0.0, 0.0])], &c);
    assert_eq!(r.get(Output::HPOS), [5.0; 4], "floor(3.7) + 2 = 5");
    assert_eq!(r.get(Output::tex(0)), [1.0; 4]);
    let r = run(text, &[(0, [-1.5, 0.0, 0.0, 0.0])], &c);
    assert_eq!(r.get(Output::tex(0)), [0.0; 4], "c[-5] reads zero");
}

#[test]
fn the_wgsl_stage_validates_with_naga() {
    let p: VertexProgram = vp::parse_file(TRANSFORM).unwrap();
    let wgsl = vp::wgsl::translate(&p, "transform");
    let module =
        naga::front::wgsl::parse_str(&wgsl).unwrap_or_else(|e| panic!("{}\n{wgsl}", e.emit_to_string(&wgsl)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{e:?}\n{wgsl}"));
    assert!(wgsl.contains("@vertex"));
}

#[path = "vertex_programs_emit.rs"]
mod emit;
#[path = "vertex_programs_gpu.rs"]
mod gpu;

fn shadec(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shadec")).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn example(name: &str) -> String {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join(name).display().to_string()
}

/// The `!!VP1.0` blocks of `compile --emit combiners` output.
fn vertex_blocks(text: &str) -> Vec<String> {
    text.split("!!VP1.0")
        .skip(1)
        .map(|b| format!("!!VP1.0{}", &b[..b.find("END\n").map_or(b.len(), |e| e + 4)]))
        .collect()
}

#[test]
fn compile_emits_a_vertex_program_per_geforce3_pass() {
    for name in ["gouraud.shd", "kilgard_bump_mapping.shd", "spheremap_texgen.shd"] {
        let (code, out, err) = shadec(&[
            "compile",
            "--stand-ins",
            &example(name),
            "--target",
            "geforce3",
            "--emit",
            "combiners",
        ]);
        assert_eq!(code, 0, "{name}: {err}");
        let passes = out.matches("!!RC1.0").count();
        let blocks = vertex_blocks(&out);
        assert_eq!(blocks.len(), passes, "{name}: one vertex program per pass\n{out}");
        for b in &blocks {
            let p = vp::parse_file(b).unwrap_or_else(|e| panic!("{name}: {e:?}\n{b}"));
            assert!(p.instructions.len() <= 128);
        }
    }
}

#[test]
fn geforce256_says_what_the_host_computes_per_vertex() {
    let (code, out, err) = shadec(&[
        "compile",
        "--stand-ins",
        &example("gouraud.shd"),
        "--target",
        "geforce256",
        "--emit",
        "combiners",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(!out.contains("!!VP1.0"), "{out}");
    assert!(out.contains("# geforce256 has no vertex programs"), "{out}");
    assert!(out.contains("#   the clip position `πx`"), "{out}");
    // The Gouraud sum (up to 1.8) goes as its two terms, each in [0, 1]:
    // GL clamps a vertex colour.
    assert!(out.contains("#   the interpolated `kd * max(0, N·L)`"), "{out}");
    assert!(out.contains("#   the interpolated `ks * max(0, N·H)^n`"), "{out}");
}

#[test]
fn translate_reads_a_vertex_program_into_a_wgsl_vertex_stage() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("t.vp");
    std::fs::write(&good, TRANSFORM).unwrap();
    let (code, out, err) = shadec(&["translate", good.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("@vertex") && out.contains("fn vertex_program"), "{out}");
    let bad = dir.path().join("bad.vp");
    std::fs::write(&bad, "!!VP1.0\nMOV o[COL0], v[3];\nADD R0, v[0], v[1];\nEND\n").unwrap();
    let (code, _, err) = shadec(&["translate", bad.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("bad.vp:3:15") && err.contains("two vertex attribute registers"), "{err}");
    assert!(err.contains("o[HPOS]"), "{err}");
}

#[test]
fn corpus_programs_are_read_or_refused_for_their_reason() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/vp1");
    let cases = [
        ("transform_diffuse.vp", None),
        ("skinning_relative.vp", None),
        ("specular_lit.vp", None),
        ("vp11_options.vp", None),
        ("edges.vp", None),
        ("two_attributes.vp", Some("two-attributes")),
        ("two_parameters.vp", Some("two-parameters")),
        ("no_hpos.vp", Some("no-hpos")),
        ("bad_grammar.vp", Some("register-range")),
        ("unterminated.vp", Some("syntax")),
        ("state_program.vp", None),
        ("public_text_after_end.vp", Some("syntax")),
        ("public_xbox_r12.vp", Some("register-range")),
    ];
    for (name, want) in cases {
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        match (vp::parse_file(&text), want) {
            (Ok(p), None) => {
                let wgsl = vp::wgsl::translate(&p, name);
                let module = naga::front::wgsl::parse_str(&wgsl)
                    .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&wgsl)));
                naga::valid::Validator::new(
                    naga::valid::ValidationFlags::all(),
                    naga::valid::Capabilities::all(),
                )
                .validate(&module)
                .unwrap_or_else(|e| panic!("{name}: {e:?}"));
            }
            (Err(ds), Some(code)) => assert_eq!(ds[0].code, code, "{name}: {ds:?}"),
            (got, want) => panic!("{name}: {got:?}, wanted {want:?}"),
        }
    }
}

#[test]
fn snapshot_of_the_diagnostics() {
    let text = "!!VP1.0\nMOV R1, v[NRML];\nMAD R0, v[0], c[1], c[2];\nRCP R2, R1;\nEND\n";
    let parsed = vp::read(text).err();
    let file = SourceFile::new("bad.vp", text);
    let mut out = String::new();
    if let Some(d) = parsed {
        out.push_str(&file.render(&[d], false));
    }
    let text2 = "!!VP1.0\nMOV R1, v[NRML];\nMAD R0, v[0], c[1], c[2];\nADD R3, v[1], v[2];\nEND\n";
    let file2 = SourceFile::new("rules.vp", text2);
    out.push_str(&file2.render(&vp::parse_file(text2).unwrap_err(), false));
    insta::assert_snapshot!("vertex_program_diagnostics", out);
}

#[test]
fn snapshot_of_the_wgsl_stage() {
    let p = vp::parse_file(TRANSFORM).unwrap();
    insta::assert_snapshot!("vertex_program_wgsl", vp::wgsl::translate(&p, "transform.vp"));
}

#[test]
fn snapshot_of_gouraud_on_geforce3() {
    let (code, out, err) = shadec(&[
        "compile",
        "--stand-ins",
        &example("gouraud.shd"),
        "--target",
        "geforce3",
        "--emit",
        "combiners",
    ]);
    assert_eq!(code, 0, "{err}");
    // Only the vertex program: the combiner setup above it is another module's output.
    insta::assert_snapshot!("vertex_program_gouraud_geforce3", vertex_blocks(&out).join("\n"));
}
