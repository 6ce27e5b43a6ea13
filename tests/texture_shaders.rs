//! `!!TS1.0` texture shaders (issue 20): every instruction parsed, printed
//! and read back; every consistency rule of NV_texture_shader a located
//! error; the per-pixel emulation against references computed here from the
//! extension's formulas on real numbers (f64); and `shadec emulate` /
//! `translate` end to end.

use crate::combiners_common;
use combiners_common::Rng;

use std::path::{Path, PathBuf};
use std::process::Command;

use proptest::prelude::*;
use shadec::backends::combiners::emulator::{Inputs, Precision};
use shadec::backends::combiners::rc1;
use shadec::backends::combiners::ts1::emulate::{self as ts_emulate, Image, TextureInputs, TsEmulateError};
use shadec::backends::combiners::ts1::{
    self, parse_file, print, CullCondition, DotFamily, DotMapping, Operation, TextureShader,
};
use shadec::backends::combiners::CombinerLimits;
use shadec::diag::SourceFile;

fn ok(text: &str) -> TextureShader {
    match parse_file(text) {
        Ok(p) => p,
        Err(d) => panic!("{}", SourceFile::new("test.ts", text).render(&d, false)),
    }
}

/// The short rendered errors (`file:line:col: error[code]: message`), after
/// checking every error has a help line.
fn errors(text: &str) -> String {
    match parse_file(text) {
        Ok(p) => panic!("expected an error, got {p:?}"),
        Err(d) => {
            let file = SourceFile::new("test.ts", text);
            let full = file.render(&d, false);
            assert_eq!(full.matches("help:").count(), d.len(), "every error has a help line: {full}");
            file.render_short(&d)
        }
    }
}

#[track_caller]
fn check_error(text: &str, expected: &[&str]) {
    let got = errors(text);
    for e in expected {
        assert!(got.contains(e), "expected `{e}` in:\n{got}");
    }
}

/// One valid program per group of instructions: together they use every
/// instruction nvparse's `ts1.0_grammar.y` has.
const EVERY_INSTRUCTION: [&str; 13] = [
    "!!TS1.0\ntexture_1d();\ntexture_2d();\ntexture_rectangle();\ntexture_3d();\n",
    "!!TS1.0\ntexture_cube_map();\npass_through();\nnop();\ncull_fragment(GEQUAL_TO_ZERO, LESS_THAN_ZERO, GEQUAL_TO_ZERO, LESS_THAN_ZERO);\n",
    "!!TS1.0\ntexture_2d();\noffset_2d(tex0, 0.5, -0.25, 0.125, 1);\noffset_2d_scale(tex1, 1, 0, 0, 1, 0.5, -0.25);\noffset_rectangle(tex0, 2, 0, 0, 2);\n",
    "!!TS1.0\ntexture_2d();\noffset_rectangle_scale(tex0, 1, 0, 0, 1, 2, 0);\ndependent_ar(tex1);\ndependent_gb(tex0);\n",
    "!!TS1.0\ntexture_2d();\ndot_product_2d_1of2(expand(tex0));\ndot_product_2d_2of2(expand(tex0));\nnop();\n",
    "!!TS1.0\ntexture_2d();\ndot_product_rectangle_1of2(tex0);\ndot_product_rectangle_2of2(tex0);\n",
    "!!TS1.0\ntexture_2d();\ndot_product_depth_replace_1of2(expand(tex0));\ndot_product_depth_replace_2of2(expand(tex0));\n",
    "!!TS1.0\ntexture_2d();\ndot_product_3d_1of3(expand(tex0));\ndot_product_3d_2of3(expand(tex0));\ndot_product_3d_3of3(expand(tex0));\n",
    "!!TS1.0\ntexture_2d();\ndot_product_cube_map_1of3(expand(tex0));\ndot_product_cube_map_2of3(expand(tex0));\ndot_product_cube_map_3of3(expand(tex0));\n",
    "!!TS1.0\ntexture_2d();\ndot_product_reflect_cube_map_eye_from_qs_1of3(expand(tex0));\ndot_product_reflect_cube_map_eye_from_qs_2of3(expand(tex0));\ndot_product_reflect_cube_map_eye_from_qs_3of3(expand(tex0));\n",
    "!!TS1.0\ntexture_2d();\ndot_product_reflect_cube_map_const_eye_1of3(expand(tex0), 0, 0, -1);\ndot_product_reflect_cube_map_const_eye_2of3(expand(tex0));\ndot_product_reflect_cube_map_const_eye_3of3(expand(tex0));\n",
    "!!TS1.0\ntexture_2d();\ndot_product_cube_map_and_reflect_cube_map_eye_from_qs_1of3(expand(tex0));\ndot_product_cube_map_and_reflect_cube_map_eye_from_qs_2of3(expand(tex0));\ndot_product_cube_map_and_reflect_cube_map_eye_from_qs_3of3(expand(tex0));\n",
    "!!TS1.0\ntexture_2d();\ndot_product_cube_map_and_reflect_cube_map_const_eye_1of3(tex0, 0.5, 0.5, -.5);\ndot_product_cube_map_and_reflect_cube_map_const_eye_2of3(tex0);\ndot_product_cube_map_and_reflect_cube_map_const_eye_3of3(tex0);\n",
];

#[test]
fn every_instruction_parses_prints_and_reads_back() {
    let mut used = std::collections::BTreeSet::new();
    let mut printed = String::new();
    for text in EVERY_INSTRUCTION {
        let program = ok(text);
        used.extend(program.stages.iter().map(Operation::name));
        let again = print(&program);
        assert_eq!(ok(&again), program, "{again}");
        printed.push_str(&again);
        printed.push('\n');
    }
    let all: std::collections::BTreeSet<String> = ts1::instruction_names().into_iter().collect();
    assert_eq!(used, all, "the programs above use every instruction");
    insta::assert_snapshot!("every_instruction_printed", printed);
}

#[test]
fn arguments_land_where_the_extension_puts_them() {
    let p = ok(EVERY_INSTRUCTION[2]);
    assert_eq!(
        p.stages[1],
        Operation::Offset { rectangle: false, previous: 0, matrix: [0.5, -0.25, 0.125, 1.0], scale: None }
    );
    assert_eq!(
        p.stages[2],
        Operation::Offset {
            rectangle: false,
            previous: 1,
            matrix: [1.0, 0.0, 0.0, 1.0],
            scale: Some((0.5, -0.25))
        }
    );
    let p = ok(EVERY_INSTRUCTION[12]);
    assert_eq!(
        p.stages[1],
        Operation::DotProduct {
            family: DotFamily::DiffuseReflectConstEye,
            step: 0,
            previous: 0,
            mapping: DotMapping::UnsignedIdentity,
            eye: Some([0.5, 0.5, -0.5]),
        }
    );
    let p = ok(EVERY_INSTRUCTION[1]);
    use CullCondition::*;
    assert_eq!(
        p.stages[3],
        Operation::CullFragment([GequalToZero, LessThanZero, GequalToZero, LessThanZero])
    );
    // Comments of all three kinds, as nvparse's lexer skips them.
    let p = ok("!!TS1.0 # a\ntexture_2d(); // b\n/* c\n */ nop();\n");
    assert_eq!(p.stages, vec![Operation::Texture2d, Operation::Nop]);
}

#[test]
fn syntax_errors_are_located_with_help() {
    check_error(
        "!!TS1.0\ntexture2d();\n",
        &["test.ts:2:1: error[syntax]: unknown texture-shader instruction `texture2d`"],
    );
    assert!(SourceFile::new("t", "")
        .render(&parse_file("!!TS1.0\ntexture2d();").unwrap_err(), false)
        .contains("did you mean `texture_2d`?"));
    check_error(
        "!!TS1.0\ntexture_2d();\ndependent_ar(tex3);\n",
        &["3:14: error[syntax]: `tex3` cannot be read"],
    );
    check_error("!!TS1.0\ntexture_2d()\nnop();\n", &["2:13: error[syntax]: expected `;`, found `nop`"]);
    check_error(
        "!!TS1.0\ntexture_2d();\noffset_2d(tex0, 1, 0, 0);\n",
        &["3:24: error[syntax]: too few arguments"],
    );
    check_error("!!TS1.0\ntexture_2d(tex0);\n", &["2:12: error[syntax]: expected `)`, found `tex0`"]);
    check_error(
        "!!TS1.0\ntexture_2d();\ndependent_ar(tex0, 1);\n",
        &["3:18: error[syntax]: too many arguments"],
    );
    check_error(
        "!!TS1.0\ncull_fragment(GEQUAL_TO_ZERO, LESS, GEQUAL_TO_ZERO, GEQUAL_TO_ZERO);\n",
        &["2:31: error[syntax]: expected `GEQUAL_TO_ZERO` or `LESS_THAN_ZERO`, found `LESS`"],
    );
    check_error("!!TS1.0\ncull_fragment(GEQUAL_TO_ZERO);\n", &["2:29: error[syntax]: too few arguments"]);
    check_error(
        "!!TS1.0\ntexture_2d();\ndependent_gb(expand(tex0));\n",
        &["3:14: error[syntax]: expected `tex0`, `tex1` or `tex2`, found `expand`"],
    );
    check_error(
        "!!TS1.0\ntexture_2d();\noffset_2d(tex0, 1.2.3, 0, 0, 1);\n",
        &["3:17: error[syntax]: malformed number `1.2.3`"],
    );
    check_error(
        "!!TS1.0\ntexture_2d();\noffset_2d(tex0, one, 0, 0, 1);\n",
        &["3:17: error[syntax]: expected a number, found `one`"],
    );
    check_error("!!TS1.0\ntexture_2d() @;\n", &["2:14: error[syntax]: unexpected character `@`"]);
    check_error("!!TS1.0\n/* open\ntexture_2d();\n", &["2:1: error[syntax]: unterminated `/*` comment"]);
    check_error("texture_2d();\n", &["1:1: error[syntax]: expected the `!!TS1.0` header"]);
}

#[test]
fn each_consistency_rule_is_a_located_error() {
    check_error(
        "!!TS1.0\ntexture_2d();\nnop();\nnop();\nnop();\ntexture_2d();\n",
        &["6:1: error[too-many-stages]: 5 texture-shader stages, but the geforce3 has 4 texture units"],
    );
    check_error(
        "!!TS1.0\ndependent_ar(tex0);\n",
        &["2:1: error[ts-dependent-stage-0]: `dependent_ar` reads a previous stage, but stage 0 has none"],
    );
    // The second stage of a pair with no first stage before it.
    check_error(
        "!!TS1.0\ntexture_2d();\ndot_product_2d_2of2(expand(tex0));\n",
        &["3:1: error[ts-group-incomplete]: `dot_product_2d_2of2` at unit 1 needs `dot_product_2d_1of2` at unit 0, found `texture_2d`"],
    );
    // Not enough units before it at all.
    check_error(
        "!!TS1.0\ntexture_2d();\ndot_product_3d_3of3(expand(tex0));\n",
        &["3:1: error[ts-group-incomplete]: `dot_product_3d_3of3` at unit 1 needs 2 earlier stage(s) of its family"],
    );
    // A stage of another family in the middle.
    check_error(
        "!!TS1.0\ntexture_2d();\ndot_product_3d_1of3(expand(tex0));\ndot_product_cube_map_2of3(expand(tex0));\n",
        &["4:1: error[ts-group-incomplete]: `dot_product_cube_map_2of3` at unit 2 needs `dot_product_cube_map_1of3` at unit 1, found `dot_product_3d_1of3`"],
    );
    // A dependent stage reading itself or a later unit.
    check_error(
        "!!TS1.0\ntexture_2d();\ndependent_ar(tex1);\n",
        &["3:14: error[ts-reads-later-stage]: `dependent_ar` at unit 1 reads `tex1`, which is not an earlier stage"],
    );
    // A dot product's later stage reading a unit inside its own group.
    check_error(
        "!!TS1.0\ntexture_2d();\ndot_product_2d_1of2(expand(tex0));\ndot_product_2d_2of2(expand(tex1));\n",
        &["4:21: error[ts-reads-later-stage]: `dot_product_2d_2of2` at unit 2 reads `tex1`"],
    );
    check_error(
        "!!TS1.0\nnop();\ntexture_2d();\ndependent_gb(tex0);\n",
        &["4:14: error[ts-reads-no-output]: `dependent_gb` reads `tex0`, but stage 0 (`nop`) writes no RGBA result"],
    );
    check_error(
        "!!TS1.0\ncull_fragment(GEQUAL_TO_ZERO, GEQUAL_TO_ZERO, GEQUAL_TO_ZERO, GEQUAL_TO_ZERO);\noffset_2d(tex0, 1, 0, 0, 1);\n",
        &["3:11: error[ts-reads-no-output]"],
    );
    check_error(
        "!!TS1.0\ntexture_2d();\ndot_product_3d_1of3(expand(tex0));\ndot_product_3d_2of3(expand(tex0));\ndependent_ar(tex2);\n",
        &["5:14: error[ts-reads-no-output]: `dependent_ar` reads `tex2`, but stage 2 (`dot_product_3d_2of3`) writes no RGBA result"],
    );
    // The diffuse cube map's middle stage does write a result.
    ok("!!TS1.0\ntexture_2d();\ndot_product_cube_map_and_reflect_cube_map_eye_from_qs_1of3(expand(tex0));\ndot_product_cube_map_and_reflect_cube_map_eye_from_qs_2of3(expand(tex0));\ndependent_ar(tex2);\n");
}

#[test]
fn a_texture_shader_in_front_of_combiners_is_parsed_and_validated() {
    let text = "!!TS1.0\ntexture_2d();\noffset_2d(tex0, 0.5, 0, 0, 0.5);\n!!RC1.0\nout.rgb = tex1;\n";
    let config = rc1::parse_and_validate(text, &CombinerLimits::GEFORCE3).unwrap();
    let program = config.texture_shader.clone().unwrap();
    assert_eq!(program.stages.len(), 2);
    // Printed as one text, read back the same.
    let again = rc1::print(&config);
    assert!(
        again.starts_with("!!TS1.0\ntexture_2d();\noffset_2d(tex0, 0.5, 0, 0, 0.5);\n!!RC1.0\n"),
        "{again}"
    );
    assert_eq!(rc1::parse_and_validate(&again, &CombinerLimits::GEFORCE3).unwrap(), config);
    // Junk inside the block is an error now, located in the whole file.
    let bad = "!!TS1.0\ntexture_2d();\njunk here;\n!!RC1.0\nout.rgb = tex1;\n";
    let d = rc1::parse_and_validate(bad, &CombinerLimits::GEFORCE3).unwrap_err();
    let short = SourceFile::new("pair.rc", bad).render_short(&d);
    assert!(
        short.contains("pair.rc:3:1: error[syntax]: unknown texture-shader instruction `junk`"),
        "{short}"
    );
    let bad = "!!TS1.0\ntexture_2d();\ndependent_ar(tex1);\n!!RC1.0\nout.rgb = tex1;\n";
    let d = rc1::parse_and_validate(bad, &CombinerLimits::GEFORCE3).unwrap_err();
    let short = SourceFile::new("pair.rc", bad).render_short(&d);
    assert!(short.contains("pair.rc:3:14: error[ts-reads-later-stage]"), "{short}");
}

// ---------------------------------------------------------------------------
// Print → parse over generated programs (any operation, valid or not).

fn operation() -> impl Strategy<Value = Operation> {
    let number = -1000.0f32..1000.0;
    let cond = prop_oneof![Just(CullCondition::GequalToZero), Just(CullCondition::LessThanZero)];
    let mapping = prop_oneof![Just(DotMapping::UnsignedIdentity), Just(DotMapping::ExpandNormal)];
    prop_oneof![
        prop_oneof![
            Just(Operation::Nop),
            Just(Operation::Texture1d),
            Just(Operation::Texture2d),
            Just(Operation::TextureRectangle),
            Just(Operation::Texture3d),
            Just(Operation::TextureCubeMap),
            Just(Operation::PassThrough),
        ],
        prop::array::uniform4(cond).prop_map(Operation::CullFragment),
        (
            any::<bool>(),
            0u8..3,
            prop::array::uniform4(number.clone()),
            prop::option::of((number.clone(), number.clone()))
        )
            .prop_map(|(rectangle, previous, matrix, scale)| Operation::Offset {
                rectangle,
                previous,
                matrix,
                scale
            }),
        (any::<bool>(), 0u8..3)
            .prop_map(|(green_blue, previous)| Operation::Dependent { green_blue, previous }),
        (
            prop::sample::select(DotFamily::ALL.to_vec()),
            0u8..3,
            0u8..3,
            mapping,
            prop::array::uniform3(number)
        )
            .prop_map(|(family, step, previous, mapping, eye)| {
                let step = step % family.stages();
                let eye = (step == 0 && family.has_const_eye()).then_some(eye);
                Operation::DotProduct { family, step, previous, mapping, eye }
            }),
    ]
}

proptest! {
    #[test]
    fn generated_programs_print_and_parse_back(stages in prop::collection::vec(operation(), 0..=4)) {
        let program = TextureShader { stages };
        let text = print(&program);
        let parsed = ts1::parse(&text["!!TS1.0".len()..], 7).map_err(|d| TestCaseError::fail(format!("{d:?}\n{text}")))?;
        prop_assert_eq!(parsed.program, program);
    }
}

// ---------------------------------------------------------------------------
// Emulation against references on real numbers.

fn image(w: u32, h: u32, seed: u64) -> Vec<u8> {
    Rng(seed).bytes((w * h * 4) as usize)
}

fn inputs<'a>(
    w: usize,
    h: usize,
    textures: [Option<Image<'a>>; 4],
    coords: [Option<&'a [u8]>; 4],
) -> TextureInputs<'a> {
    TextureInputs { width: w, height: h, textures, coords }
}

fn program(text: &str) -> TextureShader {
    ok(&format!("!!TS1.0\n{text}"))
}

/// The texel of an `n`-texel side at real coordinate `c`: nearest, clamped to the edge.
fn nearest(c: f64, n: u32) -> usize {
    (c * n as f64).floor().clamp(0.0, n as f64 - 1.0) as usize
}

fn texel(im: &Image, x: usize, y: usize) -> [u8; 4] {
    let at = (y * im.width as usize + x) * 4;
    im.rgba[at..at + 4].try_into().unwrap()
}

fn register(out: &[u8], w: usize, x: usize, y: usize) -> [u8; 4] {
    let at = (y * w + x) * 4;
    out[at..at + 4].try_into().unwrap()
}

#[test]
fn texture_2d_reads_pixel_centres() {
    let (w, h) = (6usize, 5usize);
    let same = image(6, 5, 1);
    let big = image(10, 15, 2);
    let t0 = Image { width: 6, height: 5, rgba: &same };
    let t1 = Image { width: 10, height: 15, rgba: &big };
    let p = program("texture_2d();\ntexture_2d();\n");
    let shaded = ts_emulate::shade(&p, &inputs(w, h, [Some(t0), Some(t1), None, None], [None; 4])).unwrap();
    // An image of the output's size is read texel for texel; the other one at
    // pixel centres (sizes chosen so that no centre lies on a texel edge).
    assert_eq!(shaded.textures[0], same);
    for y in 0..h {
        for x in 0..w {
            let (s, t) = ((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64);
            assert_eq!(register(&shaded.textures[1], w, x, y), texel(&t1, nearest(s, 10), nearest(t, 15)));
        }
    }
    // Units past the program's end are `nop`: (0, 0, 0, 0).
    assert!(shaded.textures[2].iter().chain(&shaded.textures[3]).all(|&b| b == 0));
}

#[test]
fn a_zero_offset_matrix_gives_the_plain_lookup() {
    let (w, h) = (9usize, 7usize);
    let bumps = image(9, 7, 3);
    let env = image(13, 11, 4);
    let t0 = Image { width: 9, height: 7, rgba: &bumps };
    let t1 = Image { width: 13, height: 11, rgba: &env };
    let textures = [Some(t0), Some(t1), None, None];
    let offset = program("texture_2d();\noffset_2d(tex0, 0, 0, 0, 0);\n");
    let plain = program("texture_2d();\ntexture_2d();\n");
    let a = ts_emulate::shade(&offset, &inputs(w, h, textures, [None; 4])).unwrap();
    let b = ts_emulate::shade(&plain, &inputs(w, h, textures, [None; 4])).unwrap();
    assert_eq!(a.textures[1], b.textures[1]);
    // And a non-zero one does move the lookup (the test above could not pass by ignoring offsets).
    let moved = ts_emulate::shade(
        &program("texture_2d();\noffset_2d(tex0, 0.5, 0, 0, 0.5);\n"),
        &inputs(w, h, textures, [None; 4]),
    )
    .unwrap();
    assert_ne!(moved.textures[1], b.textures[1]);
}

#[test]
fn offset_2d_adds_the_matrix_times_the_signed_dsdt_texel() {
    let (w, h) = (16usize, 16usize);
    // DSDT texel everywhere: ds = 64/127, dt = −32/127 (two's complement 224), mag 128.
    let dsdt = [64u8, 224, 128, 0].repeat(w * h);
    let env: Vec<u8> =
        (0..16 * 16).flat_map(|i| [(i % 16 * 16) as u8, (i / 16 * 16) as u8, 200, 255]).collect();
    let t0 = Image { width: 16, height: 16, rgba: &dsdt };
    let t1 = Image { width: 16, height: 16, rgba: &env };
    let textures = [Some(t0), Some(t1), None, None];
    let (m, scale, bias): ([f64; 4], f64, f64) = ([0.5, 0.0, 0.0, 0.25], 1.0, 0.0);
    let p = program("texture_2d();\noffset_2d_scale(tex0, 0.5, 0, 0, 0.25, 1, 0);\n");
    let shaded = ts_emulate::shade(&p, &inputs(w, h, textures, [None; 4])).unwrap();
    let (ds, dt) = (64.0 / 127.0, -32.0 / 127.0);
    let factor: f64 = (scale * 128.0 / 255.0 + bias).clamp(0.0, 1.0);
    for y in 0..h {
        for x in 0..w {
            let s = (x as f64 + 0.5) / 16.0 + m[0] * ds + m[2] * dt;
            let t = (y as f64 + 0.5) / 16.0 + m[1] * ds + m[3] * dt;
            let mut want = texel(&t1, nearest(s, 16), nearest(t, 16));
            for v in &mut want[..3] {
                *v = (*v as f64 * factor).round() as u8;
            }
            assert_eq!(register(&shaded.textures[1], w, x, y), want, "pixel ({x}, {y})");
        }
    }
}

#[test]
fn offset_rectangle_offsets_in_texels() {
    let (w, h) = (8usize, 8usize);
    let dsdt = [127u8, 129, 0, 0].repeat(w * h); // ds = 1, dt = −1 (129 = −127)
    let env = image(8, 8, 5);
    let t1 = Image { width: 8, height: 8, rgba: &env };
    let textures = [Some(Image { width: 8, height: 8, rgba: &dsdt }), Some(t1), None, None];
    let p = program("texture_2d();\noffset_rectangle(tex0, 2, 0, 0, 3);\n");
    let shaded = ts_emulate::shade(&p, &inputs(w, h, textures, [None; 4])).unwrap();
    for y in 0..h {
        for x in 0..w {
            // s in texels = x + ½ + 2·1, t = y + ½ + 3·(−1).
            let (s, t) = (x as f64 + 0.5 + 2.0, y as f64 + 0.5 - 3.0);
            let want = texel(&t1, (s.floor().clamp(0.0, 7.0)) as usize, (t.floor().clamp(0.0, 7.0)) as usize);
            assert_eq!(register(&shaded.textures[1], w, x, y), want, "pixel ({x}, {y})");
        }
    }
}

#[test]
fn dependent_lookups_read_alpha_red_and_green_blue() {
    let (w, h) = (10usize, 6usize);
    let first = image(10, 6, 6);
    let table = image(16, 16, 7);
    let t0 = Image { width: 10, height: 6, rgba: &first };
    let t = Image { width: 16, height: 16, rgba: &table };
    let p = program("texture_2d();\ndependent_ar(tex0);\ndependent_gb(tex0);\n");
    let shaded = ts_emulate::shade(&p, &inputs(w, h, [Some(t0), Some(t), Some(t), None], [None; 4])).unwrap();
    for y in 0..h {
        for x in 0..w {
            let [r, g, b, a] = texel(&t0, x, y).map(|k| k as f64 / 255.0);
            assert_eq!(register(&shaded.textures[1], w, x, y), texel(&t, nearest(a, 16), nearest(r, 16)));
            assert_eq!(register(&shaded.textures[2], w, x, y), texel(&t, nearest(g, 16), nearest(b, 16)));
        }
    }
}

#[test]
fn pass_through_and_cull_fragment_read_coordinate_images() {
    let (w, h) = (8usize, 4usize);
    let coords = image(8, 4, 8);
    let p = program(
        "pass_through();\ncull_fragment(GEQUAL_TO_ZERO, LESS_THAN_ZERO, GEQUAL_TO_ZERO, GEQUAL_TO_ZERO);\n",
    );
    let shaded =
        ts_emulate::shade(&p, &inputs(w, h, [None; 4], [Some(&coords), Some(&coords), None, None])).unwrap();
    // pass_through: the coordinate bytes come back (b/255 → round(·255)).
    assert_eq!(shaded.textures[0], coords);
    // cull_fragment reads directions: (2b − 255)/255 ≥ 0 ⇔ b ≥ 128.
    for (i, px) in coords.chunks(4).enumerate() {
        let keep = px[0] >= 128 && px[1] < 128 && px[2] >= 128 && px[3] >= 128;
        assert_eq!(shaded.culled[i], !keep, "pixel {i}: {px:?}");
    }
    assert!(shaded.textures[1].iter().all(|&b| b == 0), "cull_fragment has no RGBA result");
}

#[test]
fn dot_product_lookups_use_the_dots_of_their_stages() {
    let (w, h) = (12usize, 12usize);
    let normals = image(12, 12, 9);
    let table = image(16, 8, 10);
    let (c1, c2) = (image(12, 12, 11), image(12, 12, 12));
    let t0 = Image { width: 12, height: 12, rgba: &normals };
    let t = Image { width: 16, height: 8, rgba: &table };
    for (text, rectangle) in [
        ("texture_2d();\ndot_product_2d_1of2(expand(tex0));\ndot_product_2d_2of2(expand(tex0));\n", false),
        ("texture_2d();\ndot_product_rectangle_1of2(tex0);\ndot_product_rectangle_2of2(tex0);\n", true),
    ] {
        let p = program(text);
        let ins = inputs(w, h, [Some(t0), None, Some(t), None], [None, Some(&c1), Some(&c2), None]);
        let shaded = ts_emulate::shade(&p, &ins).unwrap();
        let mut checked = 0;
        for y in 0..h {
            for x in 0..w {
                let n = texel(&t0, x, y).map(|k| {
                    if rectangle {
                        k as f64 / 255.0
                    } else {
                        (2.0 * k as f64 - 255.0) / 255.0
                    }
                });
                let dot = |c: &[u8]| {
                    let at = (y * w + x) * 4;
                    (0..3).map(|k| (2.0 * c[at + k] as f64 - 255.0) / 255.0 * n[k]).sum::<f64>()
                };
                let (d1, d2) = (dot(&c1), dot(&c2));
                let (s, tt) = if rectangle { (d1, d2) } else { (d1 * 16.0, d2 * 8.0) };
                // Skip the few pixels whose dot lands within 1/100 texel of a texel edge.
                if [s, tt].iter().any(|v| (v - v.round()).abs() < 0.01) {
                    continue;
                }
                let want =
                    texel(&t, s.floor().clamp(0.0, 15.0) as usize, tt.floor().clamp(0.0, 7.0) as usize);
                assert_eq!(register(&shaded.textures[2], w, x, y), want, "{text} pixel ({x}, {y})");
                checked += 1;
            }
        }
        assert!(checked > 100, "{checked}");
        assert!(shaded.textures[1].iter().all(|&b| b == 0), "a first dot-product stage has no RGBA result");
    }
}

/// GL's cube map face selection and face coordinates (NV_texture_shader
/// refers to ARB_texture_cube_map's table) on real numbers: the face
/// (+X −X +Y −Y +Z −Z = 0..5) and its (s, t) in [0, 1].
fn cube_face(v: [f64; 3]) -> (usize, f64, f64) {
    let [x, y, z] = v;
    let (face, sc, tc, ma) = if x.abs() >= y.abs() && x.abs() >= z.abs() {
        if x >= 0.0 {
            (0, -z, -y, x.abs())
        } else {
            (1, z, -y, x.abs())
        }
    } else if y.abs() >= z.abs() {
        if y >= 0.0 {
            (2, x, z, y.abs())
        } else {
            (3, x, -z, y.abs())
        }
    } else if z >= 0.0 {
        (4, x, -y, z.abs())
    } else {
        (5, -x, -y, z.abs())
    };
    (face, (sc / ma + 1.0) / 2.0, (tc / ma + 1.0) / 2.0)
}

/// The reference's texel of a stacked cube map at direction v, or `None`
/// when v lies within `margin` texels of a face or texel edge (where 16-bit
/// coordinates may round either way).
fn cube_reference(cube: &Image, v: [f64; 3], margin: f64) -> Option<[u8; 4]> {
    let size = cube.width as usize;
    let (face, s, t) = cube_face(v);
    let sorted = {
        let mut a = v.map(f64::abs);
        a.sort_by(|p, q| q.partial_cmp(p).unwrap());
        a
    };
    if sorted[0] - sorted[1] < 1e-3 {
        return None;
    }
    let (fs, ft) = (s * size as f64, t * size as f64);
    if [fs, ft].iter().any(|f| (f - f.round()).abs() < margin) {
        return None;
    }
    Some(texel(cube, nearest(s, size as u32), face * size + nearest(t, size as u32)))
}

#[test]
fn texture_cube_map_reads_the_face_of_its_direction() {
    let (w, h) = (16usize, 16usize);
    let faces = image(8, 48, 14);
    let cube = Image { width: 8, height: 48, rgba: &faces };
    let coords = image(16, 16, 15);
    let p = program("texture_cube_map();\n");
    let shaded = ts_emulate::shade(
        &p,
        &inputs(w, h, [Some(cube), None, None, None], [Some(&coords), None, None, None]),
    )
    .unwrap();
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let at = (y * w + x) * 4;
            let v = [0, 1, 2].map(|k| (2.0 * coords[at + k] as f64 - 255.0) / 255.0);
            if let Some(want) = cube_reference(&cube, v, 0.01) {
                assert_eq!(register(&shaded.textures[0], w, x, y), want, "pixel ({x}, {y}) direction {v:?}");
                checked += 1;
            }
        }
    }
    assert!(checked > 200, "{checked}");
}

#[test]
fn dot_product_cube_maps_and_reflections_follow_the_extension() {
    let (w, h) = (12usize, 12usize);
    let normals = image(12, 12, 16);
    let faces = image(8, 48, 17);
    let cube = Image { width: 8, height: 48, rgba: &faces };
    let coords: Vec<Vec<u8>> = (0..3).map(|k| image(12, 12, 18 + k)).collect();
    let t0 = Image { width: 12, height: 12, rgba: &normals };
    let families = [
        "cube_map",
        "reflect_cube_map_eye_from_qs",
        "reflect_cube_map_const_eye",
        "cube_map_and_reflect_cube_map_const_eye",
    ];
    for family in families {
        let eye = if family.ends_with("const_eye") { ", 0.25, -0.5, 1" } else { "" };
        let text = format!(
            "texture_2d();\ndot_product_{family}_1of3(expand(tex0){eye});\ndot_product_{family}_2of3(expand(tex0));\ndot_product_{family}_3of3(expand(tex0));\n"
        );
        let p = program(&text);
        let ins = inputs(
            w,
            h,
            [Some(t0), None, Some(cube), Some(cube)],
            [None, Some(&coords[0]), Some(&coords[1]), Some(&coords[2])],
        );
        let shaded = ts_emulate::shade(&p, &ins).unwrap();
        let mut checked = 0;
        for y in 0..h {
            for x in 0..w {
                let at = (y * w + x) * 4;
                let n = texel(&t0, x, y).map(|k| (2.0 * k as f64 - 255.0) / 255.0);
                let c = |k: usize, i: usize| (2.0 * coords[k][at + i] as f64 - 255.0) / 255.0;
                let nv = [0, 1, 2].map(|k| (0..3).map(|i| c(k, i) * n[i]).sum::<f64>());
                let e = if family.ends_with("const_eye") {
                    [0.25, -0.5, 1.0]
                } else {
                    [c(0, 3), c(1, 3), c(2, 3)]
                };
                let direction = if family == "cube_map" {
                    nv
                } else {
                    let ne: f64 = (0..3).map(|k| nv[k] * e[k]).sum();
                    let nn: f64 = (0..3).map(|k| nv[k] * nv[k]).sum();
                    if nn < 0.05 {
                        continue; // nearly zero N: the reflection's direction is ill-conditioned
                    }
                    [0, 1, 2].map(|k| 2.0 * nv[k] * ne / nn - e[k])
                };
                // Wider margins for reflections: N and E keep 8 fractional bits.
                let margin = if family == "cube_map" { 0.02 } else { 0.15 };
                if let Some(want) = cube_reference(&cube, direction, margin) {
                    assert_eq!(register(&shaded.textures[3], w, x, y), want, "{family} pixel ({x}, {y})");
                    checked += 1;
                }
                if family.starts_with("cube_map_and") {
                    if let Some(want) = cube_reference(&cube, nv, 0.02) {
                        assert_eq!(
                            register(&shaded.textures[2], w, x, y),
                            want,
                            "diffuse stage, pixel ({x}, {y})"
                        );
                    }
                }
            }
        }
        assert!(checked > 40, "{family}: {checked}");
    }
}

#[test]
fn three_d_textures_read_stacked_slices() {
    let (w, h) = (10usize, 10usize);
    let slices = image(4, 20, 21); // 4×4 slices, depth 5
    let vol = Image { width: 4, height: 20, rgba: &slices };
    let coords = image(10, 10, 22);
    let p = program("texture_3d();\n");
    let shaded = ts_emulate::shade(
        &p,
        &inputs(w, h, [Some(vol), None, None, None], [Some(&coords), None, None, None]),
    )
    .unwrap();
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let at = (y * w + x) * 4;
            let [s, t, r, q] = [0, 1, 2, 3].map(|k| coords[at + k] as f64 / 255.0);
            if q < 0.2 {
                continue;
            }
            let (fs, ft, fr) = (s / q * 4.0, t / q * 4.0, r / q * 5.0);
            if [fs, ft, fr].iter().any(|f| (f - f.round()).abs() < 0.01) {
                continue;
            }
            let (ix, iy, iz) = (nearest(s / q, 4), nearest(t / q, 4), nearest(r / q, 5));
            assert_eq!(
                register(&shaded.textures[0], w, x, y),
                texel(&vol, ix, iz * 4 + iy),
                "pixel ({x}, {y})"
            );
            checked += 1;
        }
    }
    assert!(checked > 30, "{checked}");
}

#[test]
fn a_cube_map_of_the_wrong_shape_is_refused_by_stage() {
    let flat = image(4, 4, 23);
    let p = program("texture_2d();\ndot_product_cube_map_1of3(expand(tex0));\ndot_product_cube_map_2of3(expand(tex0));\ndot_product_cube_map_3of3(expand(tex0));\n");
    let t = Image { width: 4, height: 4, rgba: &flat };
    let err = ts_emulate::shade(&p, &inputs(2, 2, [Some(t), None, None, Some(t)], [None; 4])).err().unwrap();
    assert!(matches!(err, TsEmulateError::Unsupported { stage: 3, .. }), "{err}");
    assert!(err.to_string().contains("height = 6 × width"), "{err}");
}

#[test]
fn the_pair_runs_the_combiners_on_the_shaded_textures_and_culls() {
    let text = "!!TS1.0\ntexture_2d();\ncull_fragment(GEQUAL_TO_ZERO, GEQUAL_TO_ZERO, GEQUAL_TO_ZERO, GEQUAL_TO_ZERO);\n!!RC1.0\nout.rgb = tex0;\nout.a = tex0.a;\n";
    let config = rc1::parse_and_validate(text, &CombinerLimits::GEFORCE3).unwrap();
    let program = config.texture_shader.clone().unwrap();
    let tex = image(4, 2, 13);
    let coords: Vec<u8> = (0..8).flat_map(|i| if i % 2 == 0 { [255u8; 4] } else { [0u8; 4] }).collect();
    let ins = inputs(
        4,
        2,
        [Some(Image { width: 4, height: 2, rgba: &tex }), None, None, None],
        [None, Some(&coords), None, None],
    );
    let reg = Inputs { width: 4, height: 2, ..Inputs::default() };
    let out = ts_emulate::emulate(&config, &program, &reg, &ins, Precision::Fixed9).unwrap();
    for i in 0..8 {
        let want: &[u8] = if i % 2 == 0 { &tex[i * 4..i * 4 + 4] } else { &[0, 0, 0, 0] };
        assert_eq!(&out[i * 4..i * 4 + 4], want, "pixel {i}");
    }
}

// ---------------------------------------------------------------------------
// The command line.

fn data_dir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn png(dir: &Path, name: &str, w: u32, h: u32, rgba: Vec<u8>) -> PathBuf {
    let p = dir.join(name);
    image::RgbaImage::from_raw(w, h, rgba).unwrap().save(&p).unwrap();
    p
}

fn shadec(args: &[&std::ffi::OsStr]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shadec")).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

macro_rules! args {
    ($($a:expr),* $(,)?) => { &[$(std::ffi::OsStr::new($a)),*] };
}

#[test]
fn emulate_runs_a_pair_in_one_file_or_two() {
    let dir = data_dir();
    let d = dir.path();
    let ts = "!!TS1.0\ntexture_2d();\ndependent_ar(tex0);\n";
    let rc = "!!RC1.0\nout.rgb = tex1;\nout.a = one;\n";
    let pair = write(d, "pair.rc", &format!("{ts}{rc}"));
    let ts_file = write(d, "lut.ts", ts);
    let rc_file = write(d, "lut.rc", rc);
    // tex0: a ramp read as (alpha, red) into a 256×1 table that is its own index.
    let first: Vec<u8> = (0..16).flat_map(|i| [i * 16, 0, 0, 255 - i * 16]).collect();
    let table: Vec<u8> = (0..=255u8).flat_map(|i| [i, 255 - i, 7, 255]).collect();
    let t0 = png(d, "t0.png", 4, 4, first.clone());
    let t1 = png(d, "t1.png", 256, 1, table);
    let (out_a, out_b) = (d.join("a.png"), d.join("b.png"));
    let (code, _, err) = shadec(args!["emulate", &pair, "--tex0", &t0, "--tex1", &t1, "--out", &out_a]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = shadec(args![
        "emulate",
        &rc_file,
        "--texture-shader",
        &ts_file,
        "--tex0",
        &t0,
        "--tex1",
        &t1,
        "--out",
        &out_b
    ]);
    assert_eq!(code, 0, "{err}");
    let a = image::open(&out_a).unwrap().to_rgba8();
    assert_eq!(a, image::open(&out_b).unwrap().to_rgba8());
    assert_eq!(a.dimensions(), (4, 4), "the output takes the first texture's size");
    for (i, px) in a.pixels().enumerate() {
        // s = alpha/255 → texel ⌊alpha·256/255⌋ (clamped), whose red is that index.
        let alpha = first[i * 4 + 3] as usize;
        let k = (alpha * 256 / 255).min(255) as u8;
        assert_eq!(px.0, [k, 255 - k, 7, 255], "pixel {i}");
    }
}

#[test]
fn emulate_reports_texture_shader_errors_and_misuse() {
    let dir = data_dir();
    let d = dir.path();
    let t0 = png(d, "t0.png", 2, 2, vec![9; 16]);
    let out = d.join("o.png");
    let bad = write(d, "bad.ts", "!!TS1.0\ntexture_2d();\ndependent_ar(tex2);\n");
    let rc = write(d, "ok.rc", "!!RC1.0\nout.rgb = tex1;\n");
    let (code, _, err) =
        shadec(args!["emulate", &rc, "--texture-shader", &bad, "--tex0", &t0, "--out", &out]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("bad.ts:3:14") && err.contains("ts-reads-later-stage") && err.contains("help:"),
        "{err}"
    );
    let pair = write(d, "pair.rc", "!!TS1.0\ntexture_2d();\n!!RC1.0\nout.rgb = tex0;\n");
    let good = write(d, "good.ts", "!!TS1.0\ntexture_2d();\n");
    let (code, _, err) =
        shadec(args!["emulate", &pair, "--texture-shader", &good, "--tex0", &t0, "--out", &out]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("already starts with a `!!TS1.0` program"), "{err}");
    let (code, _, err) = shadec(args!["emulate", &rc, "--coord0", &t0, "--tex0", &t0, "--out", &out]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("coordinates are read only by a texture shader"), "{err}");
    let cube = write(d, "cube.rc", "!!TS1.0\ntexture_cube_map();\n!!RC1.0\nout.rgb = tex0;\n");
    let (code, _, err) = shadec(args!["emulate", &cube, "--tex0", &t0, "--out", &out]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("`texture_cube_map` cannot read its texture image (a cube map is six square faces"),
        "{err}"
    );
    assert!(!out.exists(), "no output on failure");
}

#[test]
fn translate_writes_the_texture_shader_stages() {
    let dir = data_dir();
    let d = dir.path();
    let pair = write(
        d,
        "embm.rc",
        "!!TS1.0\ntexture_2d();\noffset_2d(tex0, 0.5, 0, 0, 0.5);\n!!RC1.0\nout.rgb = tex1;\n",
    );
    let (code, wgsl, err) = shadec(args!["translate", &pair]);
    assert_eq!(code, 0, "{err}");
    assert!(wgsl.contains("// Unit 1: offset_2d(tex0, 0.5, 0, 0, 0.5);"), "{wgsl}");
    assert!(wgsl.contains("ts_offset(2048, 0,"), "the matrix in units of 1/4096: {wgsl}");
    let volume =
        write(d, "volume.rc", "!!TS1.0\ntexture_3d();\ntexture_cube_map();\n!!RC1.0\nout.rgb = tex0;\n");
    let (code, wgsl, err) = shadec(args!["translate", &volume]);
    assert_eq!(code, 0, "{err}");
    assert!(wgsl.contains("tex0 = ts_volume(texture0_image, c0.xyz, c0.w);"), "{wgsl}");
    assert!(wgsl.contains("tex1 = ts_cube(texture1_image, c1.xyz);"), "{wgsl}");
}

// ---------------------------------------------------------------------------
// The code generator (item 4): EMBM on geforce3 through `!!TS1.0`.

fn embm_on_geforce3() -> shadec::backends::combiners::CombinerConfig {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/embm.shd");
    let source = std::fs::read_to_string(path).unwrap();
    let profile = shadec::profile::Profile::resolve("geforce3").unwrap();
    let c = shadec::driver::compile(&source, &profile, &shadec::driver::PlanOptions::default())
        .unwrap_or_else(|d| panic!("{d:?}"));
    assert_eq!(c.planned.plan.passes.len(), 1);
    shadec::backends::combiners::setup::of(&c.planned, 0).unwrap().config.clone()
}

#[test]
fn the_generator_writes_embm_as_an_offset_2d_texture_shader_that_reads_back() {
    let config = embm_on_geforce3();
    let program = config.texture_shader.clone().expect("EMBM's dependent lookup needs a texture shader");
    // seeds/001 (8): T′ (unit 0, signed) offsets T's coordinates (unit 1) by the identity.
    assert_eq!(
        program.stages,
        vec![
            Operation::Texture2d,
            Operation::Offset { rectangle: false, previous: 0, matrix: [1.0, 0.0, 0.0, 1.0], scale: None }
        ]
    );
    let text = rc1::print(&config);
    assert_eq!(rc1::parse_and_validate(&text, &CombinerLimits::GEFORCE3).unwrap(), config, "{text}");
}

#[test]
fn plain_texturing_generates_no_texture_shader() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/kilgard_bump_mapping.shd");
    let source = std::fs::read_to_string(path).unwrap();
    let profile = shadec::profile::Profile::resolve("geforce3").unwrap();
    let c = shadec::driver::compile(&source, &profile, &shadec::driver::PlanOptions::default()).unwrap();
    assert!(!c.planned.plan.passes.is_empty());
    for i in 0..c.planned.plan.passes.len() {
        let g = shadec::backends::combiners::setup::of(&c.planned, i).unwrap();
        assert_eq!(g.config.texture_shader, None, "pass {i}");
    }
}

#[test]
fn embm_emits_emulates_and_translates_through_the_texture_shader() {
    let dir = data_dir();
    let d = dir.path();
    let shd = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/embm.shd");
    let rc = d.join("embm.rc");
    let (code, _, err) = shadec(args![
        "compile",
        "--stand-ins",
        &shd,
        "--target",
        "geforce3",
        "--emit",
        "combiners",
        "-o",
        &rc
    ]);
    assert_eq!(code, 0, "{err}");
    let text = std::fs::read_to_string(&rc).unwrap();
    assert!(text.starts_with("!!TS1.0\n# ==== pass 1 of 1"), "{text}");
    // A constant bump (ds = 40/127, dt = −20/127) moves every lookup of a 32×32 environment.
    let (w, h) = (16usize, 16usize);
    let dsdt = [40u8, 236, 0, 255].repeat(w * h);
    let env: Vec<u8> = (0..32 * 32).flat_map(|i| [(i % 32 * 8) as u8, (i / 32 * 8) as u8, 77, 255]).collect();
    let t0 = png(d, "bump.png", 16, 16, dsdt);
    let t1 = png(d, "env.png", 32, 32, env.clone());
    let out = d.join("out.png");
    let (code, _, err) = shadec(args!["emulate", &rc, "--tex0", &t0, "--tex1", &t1, "--out", &out]);
    assert_eq!(code, 0, "{err}");
    let img = image::open(&out).unwrap().to_rgba8();
    let env_image = Image { width: 32, height: 32, rgba: &env };
    for (x, y, px) in img.enumerate_pixels() {
        let s = (x as f64 + 0.5) / 16.0 + 40.0 / 127.0;
        let t = (y as f64 + 0.5) / 16.0 - 20.0 / 127.0;
        let want = texel(&env_image, nearest(s, 32), nearest(t, 32));
        assert_eq!(px.0, want, "pixel ({x}, {y})");
    }
    let (code, wgsl, err) = shadec(args!["translate", &rc]);
    assert_eq!(code, 0, "{err}");
    assert!(wgsl.contains("// Unit 1: offset_2d(tex0, 1, 0, 0, 1);"), "{wgsl}");
}

/// Token soup from the language's own words: parsing never panics, and what
/// parses and validates also shades without panicking (errors are fine).
fn token() -> impl Strategy<Value = String> {
    let mut words: Vec<String> = ts1::instruction_names();
    words.extend(
        [
            "tex0",
            "tex1",
            "tex2",
            "tex3",
            "expand",
            "GEQUAL_TO_ZERO",
            "LESS_THAN_ZERO",
            "(",
            ")",
            ";",
            ",",
            "-",
            "0",
            "1.5",
            "-2",
            "1e9",
            "99999999999999999999999999999999999999999",
            "dot_product_2d_0of2",
            "#",
            "\n",
            "/*",
            "*/",
        ]
        .map(String::from),
    );
    prop::sample::select(words)
}

proptest! {
    #[test]
    fn nothing_panics_on_any_token_soup(tokens in prop::collection::vec(token(), 0..40), sizes in prop::array::uniform4((1u32..5, 1u32..13))) {
        let text = format!("!!TS1.0\n{}", tokens.join(" "));
        if let Ok(p) = parse_file(&text) {
            let images: Vec<Vec<u8>> = sizes.iter().enumerate().map(|(k, &(w, h))| image(w, h, k as u64 + 1)).collect();
            let textures = [0, 1, 2, 3].map(|k| Some(Image { width: sizes[k].0, height: sizes[k].1, rgba: &images[k] }));
            let coords = image(3, 2, 9);
            let _ = ts_emulate::shade(&p, &inputs(3, 2, textures, [Some(&coords), None, Some(&coords), None]));
        }
    }
}

proptest! {
    /// Generated programs (any operations): the consistent ones shade
    /// without panicking on images of any shape (a wrong cube or 3-D shape
    /// is an error, not a crash).
    #[test]
    fn consistent_generated_programs_shade(stages in prop::collection::vec(operation(), 1..=4), sizes in prop::array::uniform4((1u32..5, 1u32..25))) {
        let program = TextureShader { stages };
        if ts1::validate(&program).is_empty() {
            let images: Vec<Vec<u8>> = sizes.iter().enumerate().map(|(k, &(w, h))| image(w, h, k as u64 + 1)).collect();
            let textures = [0, 1, 2, 3].map(|k| Some(Image { width: sizes[k].0, height: sizes[k].1, rgba: &images[k] }));
            let coords = image(3, 2, 9);
            match ts_emulate::shade(&program, &inputs(3, 2, textures, [Some(&coords), None, Some(&coords), None])) {
                Ok(s) => prop_assert!(s.textures.iter().all(|t| t.len() == 24)),
                Err(e) => prop_assert!(matches!(e, TsEmulateError::Unsupported { .. }), "{e}"),
            }
        }
    }
}

// ---------------------------------------------------------------------------
// A cube map at an expanded normal-map texel (DOT_PRODUCT_TEXTURE_CUBE_MAP),
// and the invariant that every dependent lookup of a planned pass has the
// texture-shader stage that performs it.

/// `Ncube vec3(t.x, t.y, t.z)`, t an 8-bit normal map's expanded texel.
const CUBE_AT_TEXEL: &str = "texture Tn : 2d rgb8 mipmap trilinear repeat = bumps(4);\n\
     texture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);\n\
     let t = expand(Tn δu x);\n\
     C δπx ← Ncube vec3(t.x, t.y, t.z);\n";

/// The filtered normal renormalized, lit by an interpolated light vector.
const NORMALIZED_TEXEL: &str = "vector L : light(0) in tangent;\n\
     texture Tn : 2d rgb8 mipmap trilinear repeat = bumps(4);\n\
     C δπx ← max(0, normalize(expand(Tn δu x)) · δ (L s x));\n";

fn planned_on(
    source: &str,
    target: &str,
) -> Result<shadec::pipeline::Planned, Vec<shadec::diag::Diagnostic>> {
    let profile = shadec::profile::Profile::resolve(target).unwrap();
    shadec::driver::compile(source, &profile, &shadec::driver::PlanOptions::default()).map(|c| c.planned)
}

/// `texture_2d(); dot_product_cube_map_1of3/2of3/3of3(expand(tex0));`.
fn cube_at_texel_program() -> Vec<Operation> {
    let dot = |step| Operation::DotProduct {
        family: DotFamily::CubeMap,
        step,
        previous: 0,
        mapping: DotMapping::ExpandNormal,
        eye: None,
    };
    vec![Operation::Texture2d, dot(0), dot(1), dot(2)]
}

/// Whether `h` reads a texel (or a framebuffer) per fragment: computed
/// from the IR here, not by the planner's check.
fn reads_a_texel(m: &shadec::ir::Module, h: shadec::ir::Handle<shadec::ir::Expr>) -> bool {
    use shadec::ir::Expr;
    m.reachable(&[h])
        .iter()
        .any(|x| matches!(m.exprs[*x], Expr::Lookup { .. } | Expr::FramebufferRead { .. }))
}

/// The invariant, checked on a plan: every texture unit of every pass
/// whose coordinates read another unit's texel has, in the pass's
/// generated setup, a `!!TS1.0` stage on its hardware unit that reads an
/// earlier stage (offset_2d, dependent_ar/gb or a dot-product family's
/// last stage) — the lookup the card performs. Err says which unit does not.
pub fn dependent_units_are_realized(planned: &shadec::pipeline::Planned) -> Result<usize, String> {
    use shadec::ir::Expr;
    let m = &planned.module;
    let mut dependent = 0;
    for (i, pass) in planned.plan.passes.iter().enumerate() {
        let units: Vec<_> = pass.textures.iter().map(|t| planned.handle(t.lookup)).collect();
        for (k, &u) in units.iter().enumerate() {
            let Expr::Lookup { coords, .. } = m.exprs[u] else { continue };
            if !reads_a_texel(m, coords) {
                continue;
            }
            dependent += 1;
            let g = shadec::backends::combiners::setup::of(planned, i).map_err(|e| {
                format!("pass {}: unit {k} is dependent and the pass has no setup: {e}", i + 1)
            })?;
            let ts = g.config.texture_shader.as_ref().ok_or_else(|| {
                format!("pass {}: unit {k} is a dependent lookup and the pass has no !!TS1.0 program", i + 1)
            })?;
            let hw = shadec::planner::hilo::hardware_unit(m, &units, k);
            let op = ts.stage(hw);
            let reads_earlier = op.previous().is_some_and(|p| usize::from(p) < hw) && op.has_output();
            if !reads_earlier {
                return Err(format!(
                    "pass {}: unit {k} (hardware {hw}) is dependent but runs {}",
                    i + 1,
                    op.name()
                ));
            }
        }
    }
    Ok(dependent)
}

/// Before: planned as one pass with no `!!TS1.0` program, the cube map
/// looked up at interpolated coordinates — a pass the card could not run.
/// Now four units: the normal map, then the three dot products of its
/// expanded texel with the identity's rows, the last sampling the cube map.
#[test]
fn a_cube_lookup_at_an_expanded_texel_plans_on_geforce3_as_dot_product_cube_map() {
    let planned = planned_on(CUBE_AT_TEXEL, "geforce3").unwrap_or_else(|d| panic!("{d:?}"));
    assert_eq!(planned.plan.passes.len(), 1);
    let g = shadec::backends::combiners::setup::of(&planned, 0).unwrap();
    let ts = g.config.texture_shader.as_ref().expect("a texture-shader program");
    assert_eq!(ts.stages, cube_at_texel_program());
    assert!(ts1::validate(ts).is_empty(), "{:?}", ts1::validate(ts));
    let text = rc1::print(&g.config);
    let back =
        rc1::parse_and_validate(&text, &CombinerLimits::GEFORCE3).unwrap_or_else(|d| panic!("{d:?}\n{text}"));
    assert_eq!(back.texture_shader.as_ref(), Some(ts));
    // The combiners read the cube map's texel, texture 3, and nothing else.
    let rc = &text[text.find("!!RC1.0").unwrap()..];
    assert!(rc.contains("tex3") && !rc.contains("tex0") && !rc.contains("tex1"), "{rc}");
    // The vertex program writes u x to unit 0 and the rows to units 1-3.
    let pi = shadec::pipeline::PassInterface::of(&planned, 0);
    let outputs = shadec::backends::vertex_program::emit::outputs_for(&planned, 0, &pi);
    let want: Vec<_> = (0..4).map(shadec::backends::vertex_program::program::Output::tex).collect();
    assert_eq!(outputs, want);
    assert_eq!(dependent_units_are_realized(&planned), Ok(1));
    insta::assert_snapshot!("cube_at_texel_geforce3_ts1_rc1", text);
}

/// `normalize(expand(Tn δu x))` was refused ("needs `normalize` per
/// fragment"); now the filtered normal is renormalized through an 8-bit
/// normalization cube map by the same stages, an approximation recorded
/// with the map's bound.
#[test]
fn normalize_of_a_filtered_normal_plans_on_geforce3_through_a_normalization_cube_map() {
    let planned = planned_on(NORMALIZED_TEXEL, "geforce3").unwrap_or_else(|d| panic!("{d:?}"));
    let rules: Vec<&str> = planned.plan.approximations.iter().map(|a| a.rule.as_str()).collect();
    assert!(rules.contains(&"texel_cube_map"), "{rules:?}");
    let bound = planned.plan.approximations.iter().find(|a| a.rule == "texel_cube_map").unwrap().error_bound;
    assert!(bound.is_some_and(|b| b > 0.0 && b < 0.01), "{bound:?}");
    assert_eq!(planned.plan.passes.len(), 1);
    let g = shadec::backends::combiners::setup::of(&planned, 0).unwrap();
    assert_eq!(g.config.texture_shader.as_ref().map(|t| t.stages.clone()), Some(cube_at_texel_program()));
    let cube = &planned.plan.passes[0].textures[1];
    let texture = planned.module.textures.iter().find(|t| t.name == cube.texture).unwrap();
    assert_eq!(texture.format, shadec::parser::ast::TextureFormat::Rgb8, "{texture:?}");
    assert_eq!(dependent_units_are_realized(&planned), Ok(1));
}

/// The CPU renders of the plan against the program's meaning (which
/// evaluates `normalize` and samples the written cube map itself): the
/// cube lookup at the texel is the same value (the rows are the identity),
/// so f32 is within a float rounding of the meaning; `normalize` through
/// the 8-bit map within the approximations' stated output bounds; fixed9
/// (8-bit registers, 9-bit combiner arithmetic) within 2/255 of f32.
#[test]
fn the_cube_lookup_at_a_texel_renders_within_bounds_of_its_meaning() {
    use shadec::numerics::Precision as P;
    use shadec::renderer::plan::{compare, PlanRenderer};
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    let scene =
        shadec::scene::Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap();
    let assets = scene.build().unwrap();
    for (source, tolerance) in [(CUBE_AT_TEXEL, None), (NORMALIZED_TEXEL, Some(()))] {
        let planned = planned_on(source, "geforce3").unwrap();
        let (program, _) = shadec::parser::check(source);
        let (written, _) = shadec::ir::lower(&program);
        let meaning = shadec::meaning::plan(&written, scene.lights.len()).unwrap();
        let render = |p: &shadec::pipeline::Planned, mode| {
            PlanRenderer::new(p, &program, &scene, &assets)
                .unwrap()
                .render(mode, 160, 120, &mut |_, _| {})
                .unwrap()
        };
        let meant = render(&meaning, P::F32);
        let f32_ = render(&planned, P::F32);
        let fixed = render(&planned, P::Fixed9);
        assert!(f32_.stats.shaded > 1000, "{:?}", f32_.stats);
        let e = compare(&meant.image, &f32_.image);
        let bound: f64 = planned.plan.approximations.iter().filter_map(|a| a.output_bound).sum();
        let allowed = if tolerance.is_some() { bound + 1e-4 } else { 1e-4 };
        eprintln!("{source}: f32 against the meaning {e:?}, allowed {allowed}");
        assert!((e.max_abs as f64) <= allowed, "f32 against the meaning: {e:?}, allowed {allowed}");
        // fixed9 loads texture 3 rounded to 8 bits (the cube texel
        // filtered in f32: ½ step, plus the output's own rounding); with
        // `normalize` the combiners also dot it with the interpolated L
        // loaded at 8 bits: each expanded vector off by ≤ 1/255 a
        // component, ≤ √3/255 on the dot product each, plus the 9-bit
        // result's ½ step: 4/255.
        let e9 = compare(&f32_.image, &fixed.image);
        let allowed9 = if tolerance.is_some() { 4.0 / 255.0 } else { 2.0 / 255.0 };
        eprintln!("fixed9 against f32 {e9:?}, allowed {allowed9}");
        assert!(e9.max_abs <= allowed9 + 1e-6, "fixed9 against f32: {e9:?}");
    }
}

/// A check over `source` on `target` with the CLI, run in a folder of its
/// own so that the diagnostic names the file alone: (exit code, stderr).
fn check_in_folder(name: &str, source: &str, target: &str) -> (i32, String) {
    let dir = data_dir();
    std::fs::write(dir.path().join(name), source).unwrap();
    let r = crate::common::shadec_in(dir.path(), &["check", name, "--target", target]);
    (r.code, r.stderr)
}

/// A 2-D map looked up at an expanded texel's (x, y): no NV_texture_shader
/// operation computes that coordinate (offset_2d adds a signed texel to
/// interpolated coordinates; the dot-product families need interpolated
/// rows), and no lowering makes it either (a texel has no per-vertex
/// value): refused, located at the lookup, with what the stages can do.
#[test]
fn a_dependent_lookup_the_texture_shader_cannot_do_is_refused_located() {
    let source = "texture Tn : 2d rgb8 mipmap trilinear repeat = bumps(4);\n\
         texture T : 2d rgb8 bilinear clamp = bumps(8);\n\
         let t = expand(Tn δu x);\n\
         C δπx ← T vec2(t.x, t.y);\n";
    let (code, stderr) = check_in_folder("texel_coords.shd", source, "geforce3");
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("texel_coords.shd:4:"), "{stderr}");
    assert!(stderr.contains("which no NV_texture_shader operation computes"), "{stderr}");
    insta::assert_snapshot!("dependent_lookup_without_a_texture_shader_operation_geforce3", stderr);
}

/// GeForce 256 has no texture shaders: the cube lookup at a texel is
/// refused at the lookup, saying so (not planned without its stages).
#[test]
fn geforce256_refuses_the_cube_lookup_at_a_texel_located() {
    let (code, stderr) = check_in_folder("cube_at_texel.shd", CUBE_AT_TEXEL, "geforce256");
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("cube_at_texel.shd:4:9"), "{stderr}");
    assert!(stderr.contains("dependent lookup"), "{stderr}");
    insta::assert_snapshot!("cube_at_texel_geforce256", stderr);
    let (code, stderr) = check_in_folder("normalized_texel.shd", NORMALIZED_TEXEL, "geforce256");
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("normalized_texel.shd:3:"), "{stderr}");
}

/// One small program with a dependent lookup: a normal map's expanded
/// texel `t`, a coordinate made of it (`form`), the texture it indexes,
/// and `extra` further plain lookups in the same statement.
fn dependent_program(form: usize, extra: usize, scale: bool) -> String {
    let (decl, coords) = match form {
        0 => ("texture D : cube rgb8 bilinear clamp = normalize_cube(16);", "vec3(t.x, t.y, t.z)"),
        1 => ("texture D : 2d rgb8 bilinear clamp = bumps(8);", "vec2(t.x, t.y)"),
        2 => ("texture D : 2d rgb8 bilinear clamp = bumps(8);", "(δu x) + (S δu x)"),
        3 => ("texture D : cube rgb8 bilinear clamp = normalize_cube(16);", "vec3(t.x, t.y, t.z) * 2"),
        _ => ("texture D : 1d r8 bilinear clamp = exponent_table(8);", "t.z"),
    };
    let mut s = String::from(
        "texture Tn : 2d rgb8 mipmap trilinear repeat = bumps(4);\n\
         texture S : 2d signed8 repeat = bumps(8);\n\
         texture E : 2d rgb8 bilinear clamp = bumps(8);\n",
    );
    s += decl;
    s += "\nlet t = expand(Tn δu x);\n";
    let value = if scale { format!("D {coords} * 0.5") } else { format!("D {coords}") };
    let extras: String = (0..extra).map(|k| format!(" * E δ(u x * {})", k + 2)).collect();
    s += &format!("C δπx ← rgb({value}){extras};\n");
    s
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    /// Over generated programs with dependent lookups, on geforce3 and
    /// geforce256: a plan has every dependent unit realized by a
    /// texture-shader stage; a refusal is located and says what to do.
    #[test]
    fn every_planned_dependent_lookup_has_its_texture_shader_stage(form in 0usize..5, extra in 0usize..3, scale: bool) {
        let source = dependent_program(form, extra, scale);
        for target in ["geforce3", "geforce256"] {
            match planned_on(&source, target) {
                Ok(planned) => {
                    let realized = dependent_units_are_realized(&planned);
                    prop_assert!(realized.is_ok(), "{target}: {realized:?}\n{source}");
                }
                Err(errors) => {
                    prop_assert!(!errors.is_empty());
                    for d in &errors {
                        prop_assert!(d.primary.span.end > d.primary.span.start, "{target}: unlocated {d:?}\n{source}");
                        prop_assert!(d.help.as_ref().is_some_and(|h| !h.is_empty()), "{target}: no help {d:?}");
                    }
                }
            }
        }
    }
}

/// With `--no-approx` the lowering does not run, so the cube lookup at the
/// texel as written is refused — saying that the rewrite is exact and that
/// `--max-error 0` allows it, which then plans the four stages.
#[test]
fn the_cube_lookup_at_a_texel_as_written_names_the_exact_rewrite() {
    let dir = data_dir();
    std::fs::write(dir.path().join("cube_at_texel.shd"), CUBE_AT_TEXEL).unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["compile", "cube_at_texel.shd", "--target", "geforce3", "--emit", "combiners"];
        args.extend_from_slice(extra);
        crate::common::shadec_in(dir.path(), &args)
    };
    let refused = run(&["--no-approx"]);
    assert_eq!(refused.code, 1, "{}", refused.stderr);
    assert!(refused.stderr.contains("cube_at_texel.shd:4:"), "{}", refused.stderr);
    assert!(refused.stderr.contains("--max-error 0"), "{}", refused.stderr);
    let planned = run(&["--max-error", "0"]);
    assert_eq!(planned.code, 0, "{}", planned.stderr);
    assert!(planned.stdout.contains("dot_product_cube_map_3of3(expand(tex0));"), "{}", planned.stdout);
}

#[cfg(feature = "gpu")]
mod cube_at_texel_gpu {
    use super::*;
    use shadec::gpu::scene_run::ScenePlan;
    use shadec::numerics::Precision as P;
    use shadec::renderer::plan::PlanRenderer;

    const W: u32 = 320;
    const H: u32 = 240;

    /// (largest channel difference, compared pixels) on the torus off the
    /// triangle-edge mask, the CPU's render of the plan against the plan's
    /// WGSL on wgpu, both in `precision`.
    fn difference(gpu: &shadec::gpu::runner::Gpu, source: &str, precision: P) -> (u8, usize) {
        let planned = planned_on(source, "geforce3").unwrap();
        let (program, _) = shadec::parser::check(source);
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron"))
            .unwrap();
        let scene =
            shadec::scene::Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron"))
                .unwrap();
        let assets = scene.build().unwrap();
        let cpu = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
        let cpu = cpu.render(precision, W, H, &mut |_, _| {}).unwrap().image.to_rgba8();
        let target = if precision == P::Fixed9 {
            shadec::gpu::runner::Target::new(W, H)
        } else {
            shadec::gpu::runner::Target::float(W, H)
        };
        let run = ScenePlan::new(&planned, &program, Some(source), precision, &scene, &assets).unwrap();
        let wgpu = run.render_into(gpu, &target).unwrap().into_raw();
        let ids = shadec::bench::gpu_check::triangle_ids(gpu, &scene, &assets, (W, H)).unwrap();
        let mask = shadec::bench::gpu_check::edge_mask(&ids, (W, H));
        let (mut max, mut compared) = (0u8, 0);
        for i in (0..(W * H) as usize).filter(|&i| !mask[i] && ids[i] != 0) {
            let d = (0..3).map(|c| cpu[4 * i + c].abs_diff(wgpu[4 * i + c])).max().unwrap();
            max = max.max(d);
            compared += 1;
        }
        eprintln!("{precision:?}: CPU against wgpu max {max}/255 over {compared} pixels");
        (max, compared)
    }

    /// The CPU and the WGSL compute the same lookups in f32 from the same
    /// 8-bit texels (the cube map at the expanded texel; `normalize`
    /// through the 8-bit map), and in fixed9 load the same registers: at
    /// most one 8-bit step apart, where a rounding goes either way.
    #[test]
    fn the_cube_lookup_at_a_texel_agrees_with_wgsl_within_one_step() {
        let Some(gpu) = crate::common::gpu::gpu() else { return };
        for source in [CUBE_AT_TEXEL, NORMALIZED_TEXEL] {
            for precision in [P::F32, P::Fixed9] {
                let (max, compared) = difference(&gpu, source, precision);
                assert!(compared > 2000, "{compared}");
                assert!(max <= 1, "{precision:?}: CPU and wgpu differ by {max}/255\n{source}");
            }
        }
    }
}
