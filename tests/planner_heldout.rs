//! Held-out programs for the planner (issue 34): realistic shading
//! programs written for this battery, not taken from `examples/` — light
//! maps and detail, splatting, dot3 bumps, toon ramps, cookies, Fresnel,
//! gloss in alpha, several lights, lerps of lerps, products of five and
//! six textures, sums of products that each take several passes, written
//! in one statement or accumulated over several. Each file in
//! `tests/data/planner_heldout/` says, in its header, the scene it is
//! rendered on and, per target, what must happen:
//!
//! - `// expect TARGET: plans` — it plans on TARGET; every pass is
//!   realized on the target (`differential::validate_plan`); its f32
//!   render agrees with the independent reference (`shadec::oracle`,
//!   read as `three_way::verdict` reads it: at most 3/255 off on all but
//!   2 % of the covered pixels, plus the plan's stated approximation
//!   bound); and, on an 8-bit target, its fixed9 render (the hardware's
//!   arithmetic) is within `// fixed9 within: N` 255ths of the reference
//!   on all but 2 % of the covered pixels;
//! - `// expect TARGET: refused CODE at LINE:COL` — it is refused with
//!   that code, located there, with a help line.

use std::path::{Path, PathBuf};

use shadec::numerics::Precision;
use shadec::profile::Profile;

use crate::three_way::{difference, render_three, scene, Difference};

const FOLDER: &str = "tests/data/planner_heldout";

pub(crate) enum Expect {
    Plans,
    Refused { code: String, at: (usize, usize) },
}

pub(crate) struct Case {
    pub(crate) name: String,
    pub(crate) source: String,
    scene: String,
    fixed9_within: u8,
    pub(crate) expect: Vec<(String, Expect)>,
}

pub(crate) fn header(source: &str, key: &str) -> Vec<String> {
    source
        .lines()
        .filter_map(|l| l.strip_prefix(&format!("// {key}")).map(|r| r.trim().to_string()))
        .collect()
}

fn case(path: &Path) -> Case {
    let source = std::fs::read_to_string(path).unwrap();
    let name = path.file_stem().unwrap().to_string_lossy().into_owned();
    let scene = header(&source, "scene:").pop().unwrap_or_else(|| panic!("{name}: no `// scene:`"));
    let fixed9_within =
        header(&source, "fixed9 within:").pop().map_or(3, |n| n.parse().expect("a number of 255ths"));
    let expect = header(&source, "expect ")
        .into_iter()
        .map(|line| {
            let (target, what) = line.split_once(':').unwrap_or_else(|| panic!("{name}: `{line}`"));
            let words: Vec<&str> = what.split_whitespace().collect();
            let e = match words.as_slice() {
                ["plans"] => Expect::Plans,
                ["refused", code, "at", at] => {
                    let (l, c) = at.split_once(':').unwrap();
                    Expect::Refused { code: code.to_string(), at: (l.parse().unwrap(), c.parse().unwrap()) }
                }
                _ => panic!("{name}: cannot read `{line}`"),
            };
            (target.trim().to_string(), e)
        })
        .collect::<Vec<_>>();
    assert!(!expect.is_empty(), "{name}: no `// expect` line");
    Case { name, source, scene, fixed9_within, expect }
}

fn cases() -> Vec<Case> {
    cases_in(FOLDER)
}

/// The programs of a held-out folder (`tests/data/…`), in name order.
pub(crate) fn cases_in(folder: &str) -> Vec<Case> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(folder);
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .collect();
    paths.sort();
    paths.iter().map(|p| case(p)).collect()
}

/// Where the render and the reference differ beyond `within` 255ths on
/// more than 2 % of the covered pixels, in the first `channels` channels
/// (3 for a framebuffer declared `rgb8`, which stores no alpha to compare:
/// the reference reads it 1, as GL does, an executor keeps what it
/// cleared): how they differ; `None` when within.
fn off(cpu: &[u8], oracle: &[u8], covered: &[bool], within: u8, channels: usize) -> Option<Difference> {
    let (mut n, mut beyond) = (0usize, 0usize);
    for (i, &c) in covered.iter().enumerate() {
        if c {
            n += 1;
            let d = (0..channels).map(|k| cpu[4 * i + k].abs_diff(oracle[4 * i + k])).max().unwrap_or(0);
            beyond += usize::from(d > within);
        }
    }
    let d = difference(&opaque(cpu, channels), &opaque(oracle, channels), covered);
    (beyond as f64 > 0.02 * n.max(1) as f64).then_some(d)
}

/// `rgba` with its alpha set to 255 where only `channels` < 4 are compared.
fn opaque(rgba: &[u8], channels: usize) -> Vec<u8> {
    let mut v = rgba.to_vec();
    if channels < 4 {
        v.chunks_exact_mut(4).for_each(|p| p[3] = 255);
    }
    v
}

/// The channels a program's framebuffer `C` stores: 3 where it is
/// declared `rgb8`.
fn stored_channels(source: &str) -> usize {
    if source.lines().any(|l| l.starts_with("framebuffer C : rgb8")) {
        3
    } else {
        4
    }
}

fn plans(case: &Case, target: &str) -> Result<String, String> {
    let profile = Profile::builtin(target).unwrap();
    let compiled = shadec::driver::compile(&case.source, &profile, &Default::default())
        .map_err(|d| format!("refused: {:?}", d.iter().map(|d| d.message.clone()).collect::<Vec<_>>()))?;
    crate::differential::validate_plan(&compiled.planned, &profile)
        .map_err(|e| format!("not realizable: {e}"))?;
    let passes = compiled.planned.plan.passes.len();
    let scene = scene(&case.scene);
    let f32 = render_three(&case.source, target, &scene, Precision::F32, None)?;
    let slack = f32.approximation_bound.unwrap_or(0.0);
    let slack = (slack * 255.0).ceil() as u8;
    let channels = stored_channels(&case.source);
    if let Some(d) = off(&f32.cpu, &f32.oracle, &f32.covered, 3 + slack, channels) {
        return Err(format!("f32 render off the reference: {d:?}"));
    }
    let mut fixed9 = String::from("-");
    if target != "wgsl" {
        let p = render_three(&case.source, target, &scene, Precision::Fixed9, None)?;
        if let Some(d) = off(&p.cpu, &p.oracle, &p.covered, case.fixed9_within + slack, channels) {
            return Err(format!("fixed9 render off the reference beyond {}/255: {d:?}", case.fixed9_within));
        }
        fixed9 = format!(
            "{}/255",
            difference(&opaque(&p.cpu, channels), &opaque(&p.oracle, channels), &p.covered).max
        );
    }
    Ok(format!(
        "{passes} passes, f32 max {}/255, fixed9 max {fixed9}",
        difference(&opaque(&f32.cpu, channels), &opaque(&f32.oracle, channels), &f32.covered).max
    ))
}

fn refused(case: &Case, target: &str, code: &str, at: (usize, usize)) -> Result<String, String> {
    let profile = Profile::builtin(target).unwrap();
    let errors = match shadec::driver::compile(&case.source, &profile, &Default::default()) {
        Ok(c) => {
            return Err(format!("planned in {} passes, expected a refusal", c.planned.plan.passes.len()))
        }
        Err(e) => e,
    };
    let d = errors.iter().find(|d| d.is_error()).ok_or("no error")?;
    let index = shadec::span::LineIndex::new(&case.source);
    let shadec::span::LineCol { line, col } = index.line_col(&case.source, d.primary.span.start as usize);
    if d.code != code || (line, col) != at {
        return Err(format!("refused {} at {line}:{col}: {}", d.code, d.message));
    }
    if d.help.as_deref().is_none_or(str::is_empty) {
        return Err(format!("refused without a help line: {}", d.message));
    }
    Ok(format!("refused {code} at {line}:{col}"))
}

/// The outcome of held-out program `file` (in `tests/data/planner_heldout/`)
/// on each target its header names: `Err` where it does not do what the
/// header says (the named tests of `planner_rewrites` read it).
pub(crate) fn outcomes(file: &str) -> Vec<(String, Result<String, String>)> {
    outcomes_in(FOLDER, file)
}

/// [`outcomes`] of a program in another held-out folder.
pub(crate) fn outcomes_in(folder: &str, file: &str) -> Vec<(String, Result<String, String>)> {
    let case = case(&Path::new(env!("CARGO_MANIFEST_DIR")).join(folder).join(file));
    outcomes_of(&case)
}

/// What `case` does on each target its header names.
pub(crate) fn outcomes_of(case: &Case) -> Vec<(String, Result<String, String>)> {
    case.expect
        .iter()
        .map(|(target, expect)| {
            let outcome = match expect {
                Expect::Plans => plans(case, target),
                Expect::Refused { code, at } => refused(case, target, code, *at),
            };
            (target.clone(), outcome)
        })
        .collect()
}

/// Every held-out program plans where its header says, rendering within
/// the stated bounds of the reference, and is refused elsewhere with the
/// stated code and location. Prints the outcome table.
#[test]
fn held_out_programs_plan_on_their_targets_and_render_within_bounds() {
    let cases = cases();
    assert!(cases.len() >= 15, "{} programs", cases.len());
    let mut failures = Vec::new();
    for case in &cases {
        for (target, expect) in &case.expect {
            let outcome = match expect {
                Expect::Plans => plans(case, target),
                Expect::Refused { code, at } => refused(case, target, code, *at),
            };
            match outcome {
                Ok(row) => eprintln!("| {} | {target} | {row} |", case.name),
                Err(e) => {
                    eprintln!("| {} | {target} | FAILS: {e} |", case.name);
                    failures.push(format!("{} on {target}: {e}", case.name));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---- the planner's refusals, read as a new user reads them ---------------

/// The first error of `source` on `target`, rendered as people see it.
fn refusal(source: &str, target: &str) -> (shadec::diag::Diagnostic, String) {
    let profile = Profile::builtin(target).unwrap();
    let errors = shadec::driver::compile(source, &profile, &Default::default()).err().expect("a refusal");
    let d = errors.into_iter().find(|d| d.is_error()).expect("an error");
    let human = shadec::diag::SourceFile::new("refused.shd", source).render(std::slice::from_ref(&d), false);
    (d, human)
}

fn plans_on(source: &str, target: &str) -> bool {
    let profile = Profile::builtin(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).is_ok()
}

/// Each refusal the planner's blend forms and splits give: located (not
/// the detached span), with a help line, snapshotted; where the help
/// names a rewrite or another target, that plans.
#[test]
fn planner_refusals_are_located_and_their_help_plans() {
    let t = "texture T : 2d rgba8 = image(\"t.png\");\n";
    let cases: &[(&str, String, &str, Option<String>)] = &[
        (
            "refusal_alpha_write_reading_the_framebuffer",
            format!("{t}C δπx ← T δu x;\nα C δπx ← (α C δπx) * (T δu x).a;\n"),
            "geforce3",
            Some(format!("{t}C δπx ← T δu x;\nC δπx ← (C δπx) ⊕ rgba((1, 1, 1), (T δu x).a);\n")),
        ),
        (
            "refusal_depth_write",
            "z C δπx ← 0.5;\n".into(),
            "wgsl",
            Some("framebuffer Cl : depth;\nCl δπl x ← δ x;\n".into()),
        ),
        ("refusal_colour_read_non_linearly", "C δπx ← (C δπx) * (C δπx);\n".into(), "geforce3", None),
        (
            "refusal_float_framebuffer_on_an_8_bit_target",
            format!("framebuffer E : rgba16f, depth;\n{t}E δπx ← 3 * T δu x;\nC δπx ← 0.25 * E δπx;\n"),
            "geforce256",
            // The help: divide by 3 where written, multiply by 3 where read.
            Some(format!(
                "framebuffer E : rgba16f, depth;\n{t}E δπx ← 3 * T δu x / 3;\nC δπx ← 0.25 * 3 * E δπx;\n"
            )),
        ),
    ];
    for (name, source, target, fixed) in cases {
        let (d, human) = refusal(source, target);
        assert_ne!(d.primary.span, shadec::span::Span::DETACHED, "{name}: not located\n{human}");
        assert!(d.help.as_deref().is_some_and(|h| !h.is_empty()), "{name}: no help\n{human}");
        insta::assert_snapshot!(*name, human);
        match fixed.as_deref() {
            Some("wgsl") => assert!(plans_on(source, "wgsl"), "{name}: the help's wgsl refuses it too"),
            Some(fixed) => {
                assert!(plans_on(fixed, target), "{name}: the help's rewrite does not plan:\n{fixed}")
            }
            None => {}
        }
    }
}
