//! A corpus of `!!VP1.0` / `!!VP1.1` programs in the shapes public sources
//! wrote them (`tests/data/vertex_programs/SOURCES.md` names each source;
//! the programs are written for shadec, not copied): each is read,
//! validated, run in the interpreter against values worked out by hand,
//! printed back identically and translated to a WGSL vertex stage that naga
//! validates. Programs that break a rule of NV_vertex_program (NVIDIA 2001)
//! are refused with the rule's code at the offending register, one named
//! test per rule.

use shadec::backends::vertex_program::{self as vp, emulate, Output, VertexProgram};
use shadec::diag::SourceFile;

type Vec4 = [f32; 4];

fn corpus(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/vertex_programs").join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Reads, validates, round-trips and translates `name`.
fn accepted(name: &str) -> VertexProgram {
    let text = corpus(name);
    let program = vp::parse_file(&text).unwrap_or_else(|ds| panic!("{name}: {ds:#?}"));
    assert!(vp::validate(&program).is_empty(), "{name}");
    let printed = vp::print(&program);
    assert_eq!(vp::parse_file(&printed).unwrap_or_else(|ds| panic!("{name}: {ds:?}\n{printed}")), program);
    let wgsl = vp::wgsl::translate(&program, name);
    let module = naga::front::wgsl::parse_str(&wgsl)
        .unwrap_or_else(|e| panic!("{name}: {}\n{wgsl}", e.emit_to_string(&wgsl)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {e:?}\n{wgsl}"));
    program
}

/// `c[0]..c[3]` the identity (the model-view-projection rows), then `extra`.
fn parameters(extra: &[(usize, Vec4)]) -> [Vec4; 96] {
    let mut c = [[0.0; 4]; 96];
    for (r, row) in c.iter_mut().enumerate().take(4) {
        row[r] = 1.0;
    }
    for &(k, v) in extra {
        c[k] = v;
    }
    c
}

fn attributes(v: &[(usize, Vec4)]) -> [Vec4; 16] {
    let mut a = [[0.0; 4]; 16];
    for &(k, x) in v {
        a[k] = x;
    }
    a
}

fn close(got: Vec4, want: Vec4) {
    for k in 0..4 {
        assert!((got[k] - want[k]).abs() <= 1e-5 * (1.0 + want[k].abs()), "got {got:?}, want {want:?}");
    }
}

#[test]
fn cg_vp20_output_with_its_comment_header_runs() {
    let p = accepted("cg_vp20_transform.vp");
    assert_eq!(p.instructions.len(), 9);
    let v = attributes(&[(0, [2.0, 4.0, 6.0, 2.0]), (3, [0.2, 0.4, 0.6, 1.0]), (8, [0.25, 0.75, 0.0, 1.0])]);
    let r = emulate::run(&p, &v, &parameters(&[(4, [0.5, 1.0, 0.0, 0.0])]));
    // Cg assumed w = 1 (it adds the last row): R0 = (2, 4, 6, 1).
    close(r.get(Output::HPOS), [2.0, 4.0, 6.0, 1.0]);
    close(r.get(Output::COL0), [0.1, 0.2, 0.3, 0.5]);
    close(r.get(Output::tex(0)), [0.25, 0.75, 0.0, 1.0]);
}

#[test]
fn a_warp_with_named_attributes_and_a_scalar_rsq_runs() {
    let p = accepted("warp_mesh.vp");
    let v = attributes(&[(0, [1.0, 0.0, 0.0, 1.0]), (3, [0.0, 1.0, 0.0, 1.0])]);
    // The point at the origin, strength 0.5: displaced by 0.5 towards it.
    let r = emulate::run(&p, &v, &parameters(&[(30, [0.0, 0.0, 0.0, 1.0]), (31, [0.5, 0.0, 0.0, 0.0])]));
    close(r.get(Output::HPOS), [0.5, 0.0, 0.0, 1.0]);
    close(r.get(Output::COL0), [0.0, 1.0, 0.0, 1.0]);
}

#[test]
fn tabs_a_header_comment_and_one_parameter_read_twice_run() {
    let p = accepted("tabs_and_clamp.vp");
    let v = attributes(&[(0, [1.0, 2.0, 3.0, 1.0]), (3, [0.5, 0.0, 0.0, 1.0]), (8, [0.5, 0.5, 0.0, 1.0])]);
    // R0 = clamp(0.5·3 + (−1, …), 0, 1): x = 0.5; R5 = c[15]·0.5 + v[0].
    let c = parameters(&[(8, [0.0, 1.0, 0.0, 0.0]), (9, [3.0, -1.0, 0.0, 0.0]), (15, [2.0, 0.0, 0.0, 0.0])]);
    let r = emulate::run(&p, &v, &c);
    close(r.get(Output::HPOS), [2.0, 2.0, 3.0, 1.0]);
    close(r.get(Output::tex(0)), [0.5, 0.5, 0.0, 1.0]);
}

#[test]
fn two_bone_skinning_by_relative_addressing_runs() {
    let p = accepted("skinning_two_bones.vp");
    // Bone at c[16..18] the identity, bone at c[19..21] a translation by
    // (10, 0, 0); weights 0.75 and 0.25.
    let mut extra = vec![(4, [0.0, 1.0, 0.0, 0.0])];
    extra.extend([(16, [1.0, 0.0, 0.0, 0.0]), (17, [0.0, 1.0, 0.0, 0.0]), (18, [0.0, 0.0, 1.0, 0.0])]);
    extra.extend([(19, [1.0, 0.0, 0.0, 10.0]), (20, [0.0, 1.0, 0.0, 0.0]), (21, [0.0, 0.0, 1.0, 0.0])]);
    let v =
        attributes(&[(0, [1.0, 2.0, 3.0, 1.0]), (1, [0.75, 0.25, 16.0, 19.0]), (8, [0.1, 0.2, 0.3, 0.4])]);
    let r = emulate::run(&p, &v, &parameters(&extra));
    close(r.get(Output::HPOS), [3.5, 2.0, 3.0, 1.0]);
    close(r.get(Output::tex(0)), [0.1, 0.2, 0.3, 0.4]);
}

#[test]
fn a_light_writing_every_result_runs_and_its_colours_reach_the_rasterizer_clamped() {
    let p = accepted("lighting_every_result.vp");
    // A vertex at the origin, normal +z, the light at (0, 0, 2): N·L = 1,
    // d = 2, LIT (1, 1, 1, 1) with exponent 16; c[10] the material.
    let v = attributes(&[(0, [0.0, 0.0, 0.0, 1.0]), (2, [0.0, 0.0, 1.0, 0.0])]);
    let c = parameters(&[
        (6, [0.0, 0.0, 1.0, -5.0]),
        (8, [0.0, 0.0, 2.0, 1.0]),
        (9, [0.0, 1.0, 0.5, 16.0]),
        (10, [3.0, 1.0, 0.5, 1.0]),
    ]);
    let r = emulate::run(&p, &v, &c);
    // COL0 = LIT.y · c[10] / d = (1.5, 0.5, 0.25, 0.5) as written …
    close(r.get(Output::COL0), [1.5, 0.5, 0.25, 0.5]);
    close(r.get(Output::COL1), [1.0; 4]);
    close(r.get(Output::BFC0), [0.0; 4]);
    close(r.get(Output::BFC1), [0.5; 4]);
    close(r.get(Output::FOGC), [5.0, 0.0, 0.0, 1.0]);
    // … and (1, 0.5, 0.25, 0.5) as the rasterizer receives it.
    close(r.rasterized(64.0).get(Output::COL0), [1.0, 0.5, 0.25, 0.5]);
    // PSIZ.x = LOG(4).x · 0.5 + EXP(LOG(4).y).z = 2 · 0.5 + 2^1 = 3.
    close(r.get(Output::PSIZ), [3.0, 0.0, 0.0, 1.0]);
}

#[test]
fn a_position_invariant_vp11_program_runs() {
    let p = accepted("position_invariant.vp");
    assert!(p.position_invariant);
    let v = attributes(&[(0, [1.0, 2.0, 3.0, 1.0]), (3, [0.5, 0.25, 1.0, 1.0]), (8, [0.3, 0.0, 0.0, 1.0])]);
    // DPH = (1, 2, 3)·(1, 0, 0) + 3 = 4; RCC 0.25; |v[3] − c[13]|.
    let c = parameters(&[(12, [1.0, 0.0, 0.0, 3.0]), (13, [1.0, 0.25, 0.0, 0.0])]);
    let r = emulate::run(&p, &v, &c);
    close(r.get(Output::COL0), [0.125, 0.0, 0.25, 0.25]);
    close(r.get(Output::tex(0)), [0.3, 0.0, 0.0, 1.0]);
}

/// The one error of `text`: its code and `line:col`.
fn refused(text: &str) -> (&'static str, String) {
    let ds = vp::parse_file(text).err().unwrap_or_else(|| panic!("accepted:\n{text}"));
    let file = SourceFile::new("t.vp", text);
    let d = &ds[0];
    assert!(d.help.is_some(), "{d:?}");
    (d.code, file.location(d.primary.span.start))
}

const MVP: &str = "DP4 o[HPOS].x, c[0], v[0];\nDP4 o[HPOS].y, c[1], v[0];\nDP4 o[HPOS].z, c[2], v[0];\nDP4 o[HPOS].w, c[3], v[0];\n";

#[test]
fn reading_two_attribute_registers_is_refused() {
    let text = format!("!!VP1.0\n{MVP}ADD o[COL0], v[3], v[NRML];\nEND\n");
    assert_eq!(refused(&text), ("two-attributes", "t.vp:6:20".into()));
}

#[test]
fn reading_two_parameter_registers_is_refused() {
    let text = format!("!!VP1.0\n{MVP}MAD o[COL0], v[3], c[4], c[5];\nEND\n");
    assert_eq!(refused(&text), ("two-parameters", "t.vp:6:26".into()));
    // A relative read and an absolute one are two registers as well.
    let text = format!("!!VP1.0\nARL A0.x, v[1].x;\n{MVP}ADD o[COL0], c[A0.x + 1], c[3];\nEND\n");
    assert_eq!(refused(&text).0, "two-parameters");
}

#[test]
fn more_than_128_instructions_are_refused() {
    let text = format!("!!VP1.0\n{MVP}{}END\n", "ADD R0, R0, c[4];\n".repeat(125));
    assert_eq!(refused(&text).0, "too-many-instructions");
    let text = format!("!!VP1.0\n{MVP}{}END\n", "ADD R0, R0, c[4];\n".repeat(124));
    assert!(vp::parse_file(&text).is_ok());
}

#[test]
fn a_program_without_a_position_is_refused() {
    assert_eq!(refused("!!VP1.0\nMOV o[COL0], v[3];\nEND\n").0, "no-hpos");
}

#[test]
fn a_position_invariant_program_writing_the_position_is_refused() {
    let text = format!("!!VP1.1\nOPTION NV_position_invariant;\n{MVP}END\n");
    assert_eq!(refused(&text).0, "hpos-invariant");
}

#[test]
fn registers_beyond_the_machine_are_refused() {
    for (line, col) in [("MOV R0, c[96];", 11), ("MOV R12, v[0];", 5), ("MOV R0, v[16];", 11)] {
        let text = format!("!!VP1.0\n{MVP}{line}\nEND\n");
        assert_eq!(refused(&text), ("register-range", format!("t.vp:6:{col}")), "{line}");
    }
    let text = format!("!!VP1.0\nARL A0.x, v[1].x;\n{MVP}MOV R0, c[A0.x + 64];\nEND\n");
    assert_eq!(refused(&text).0, "register-range");
}

#[test]
fn writing_an_input_register_is_refused() {
    assert_eq!(refused(&format!("!!VP1.0\n{MVP}MOV c[0], v[0];\nEND\n")).0, "read-only-register");
    assert_eq!(refused(&format!("!!VP1.0\n{MVP}MOV v[3], c[0];\nEND\n")).0, "read-only-register");
}

#[test]
fn reading_a_result_register_is_refused() {
    assert_eq!(refused(&format!("!!VP1.0\n{MVP}MOV R0, o[HPOS];\nEND\n")).0, "write-only-register");
}

#[test]
fn vp11_instructions_under_the_vp10_header_are_refused() {
    for op in ["DPH R0, v[0], c[4];", "RCC R0.x, v[0].x;", "SUB R0, v[0], c[4];", "ABS R0, v[0];"] {
        assert_eq!(
            refused(&format!("!!VP1.0\n{MVP}{op}\nEND\n")),
            ("not-in-vp1.0", "t.vp:6:1".into()),
            "{op}"
        );
    }
}

#[test]
fn the_address_register_written_by_anything_but_arl_is_refused() {
    assert_eq!(refused(&format!("!!VP1.0\n{MVP}MOV A0.x, v[1].x;\nEND\n")).0, "syntax");
}

#[test]
fn a_scalar_instruction_without_a_component_is_refused() {
    assert_eq!(refused(&format!("!!VP1.0\n{MVP}RCP R0, v[1];\nEND\n")).0, "syntax");
}

#[test]
fn a_vertex_state_program_is_read_and_an_arb_program_named_and_refused() {
    let p = vp::parse_file("!!VSP1.0\nMOV c[0], v[0];\nEND\n").unwrap();
    assert!(p.version.is_state_program());
    let (code, at) = refused("!!ARBvp1.0\nMOV result.position, vertex.position;\nEND\n");
    assert_eq!((code, at.as_str()), ("syntax", "t.vp:1:1"));
}
