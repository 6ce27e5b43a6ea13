//! The `!!RC1.0` setups the combiner code generator writes for the
//! examples (issue 4): one insta snapshot per example and register-combiner
//! profile (geforce256, geforce3) with every planned pass — the generated
//! setup as nvparse text (seeds/003 Appendix B's notation, printed by
//! `rc1::print`), or the planner's located reason why the pass is not
//! generated. `INSTA_UPDATE=always cargo test --test combiners_snapshots`
//! re-blesses.
//!
//! Each setup in a snapshot parses back (`rc1::parse_and_validate`) to the
//! identical config, and runs in the emulator (f32) to what the IR computes
//! for the pass on random inputs.

use crate::combiners_common;
use crate::common;

use std::fmt::Write as _;

use combiners_common::Rng;

use shadec::backends::combiners::emulator::{Inputs, PixelEmulator, PixelRegisters};
use shadec::backends::combiners::{generate, rc1, CombinerLimits, Generated, PassInput};
use shadec::ir::eval::{Env, Evaluator, Value};
use shadec::ir::{Expr, FbChannel, Frequency, Handle, Module, Ty};
use shadec::numerics::Precision;
use shadec::pipeline::Planned;
use shadec::profile::Profile;

const PROFILES: [&str; 2] = ["geforce256", "geforce3"];

/// The header of each pass's section in a snapshot.
const SECTION: &str = "# ==== pass ";

fn examples() -> Vec<(String, String)> {
    common::examples()
        .into_iter()
        .map(|p| {
            (p.file_stem().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&p).unwrap())
        })
        .collect()
}

/// A snapshot document: per pass, a header and the setup (or why none).
/// `None` when no pass of the example is generated.
fn document(
    planned: &Planned,
    limits: &CombinerLimits,
    checked: &mut Vec<String>,
    name: &str,
) -> Option<String> {
    let n = planned.plan.passes.len();
    let mut doc = String::new();
    let mut any = false;
    for (i, pass) in planned.plan.passes.iter().enumerate() {
        let units: Vec<Handle<Expr>> = pass.textures.iter().map(|t| planned.handle(t.lookup)).collect();
        let value = planned.handle(pass.fragment.output);
        let statements = pass.statements.iter().map(|s| (s + 1).to_string()).collect::<Vec<_>>().join(", ");
        let _ = write!(
            doc,
            "{SECTION}{} of {n} (statement {statements} at {}, {} texture units)",
            i + 1,
            pass.at,
            units.len()
        );
        if pass.baked {
            let _ = writeln!(doc, ": a `bake` table, computed by the compiler");
            continue;
        }
        match generate(&PassInput { module: &planned.module, value, units: &units }, limits) {
            Ok(g) => {
                assert_eq!(
                    planned.setups[i].combiners().map(|c| c.stages() as usize),
                    Some(g.stages),
                    "{name} pass {}: the plan and the generator disagree",
                    i + 1
                );
                let _ = writeln!(doc, ": {} general combiners", g.stages);
                doc += &rc1::print(&g.config);
                any = true;
                if let Some(why) =
                    agrees(&planned.module, value, &units, &g, &format!("{name} pass {}", i + 1))
                {
                    checked.push(format!("{name} pass {}: {why}", i + 1));
                }
            }
            Err(e) => {
                panic!("{name} pass {}: the plan says generated, the generator: {e}", i + 1)
            }
        }
    }
    any.then_some(doc)
}

/// The sections of a document: (header, `!!RC1.0` text or `None`).
fn sections(doc: &str) -> Vec<(String, Option<String>)> {
    doc.split(SECTION)
        .skip(1)
        .map(|s| {
            let (header, body) = s.split_once('\n').unwrap_or((s, ""));
            (header.to_string(), (!body.is_empty()).then(|| body.to_string()))
        })
        .collect()
}

#[test]
fn generated_setups_of_the_examples() {
    let mut skipped = Vec::new();
    let mut snapshots = 0;
    for profile in PROFILES {
        let p = Profile::builtin(profile).unwrap();
        let limits = p.combiner_limits().unwrap();
        for (name, src) in examples() {
            let Ok(planned) = shadec::driver::compile(&src, &p, &Default::default()).map(|c| c.planned)
            else {
                continue;
            };
            let Some(doc) = document(&planned, &limits, &mut skipped, &format!("{profile} {name}")) else {
                continue;
            };
            // The snapshot's own text parses back to the generated configs.
            let secs = sections(&doc);
            assert_eq!(secs.len(), planned.plan.passes.len());
            for (i, (header, body)) in secs.iter().enumerate() {
                let Some(body) = body else { continue };
                let pass = &planned.plan.passes[i];
                assert!(!pass.baked, "{profile} {name} {header}");
                let units: Vec<Handle<Expr>> =
                    pass.textures.iter().map(|t| planned.handle(t.lookup)).collect();
                let g = generate(
                    &PassInput {
                        module: &planned.module,
                        value: planned.handle(pass.fragment.output),
                        units: &units,
                    },
                    &limits,
                )
                .unwrap();
                let back = rc1::parse_and_validate(body, &limits)
                    .unwrap_or_else(|d| panic!("{profile} {name} {header}: {d:#?}\n{body}"));
                assert_eq!(back, g.config, "{profile} {name} {header}: the text does not round-trip");
            }
            insta::assert_snapshot!(format!("{profile}__{name}"), doc);
            snapshots += 1;
        }
    }
    // Every example with a generated pass has a snapshot; the count is a floor.
    assert!(snapshots >= 23, "{snapshots} snapshots");
    for s in &skipped {
        eprintln!("not compared with the IR: {s}");
    }
}

// ---------------------------------------------------------------------------
// Agreement with the IR on random inputs.

/// What a texture unit holds, as the evaluator asks for it: a texture at
/// some coordinates, or a framebuffer channel at some position. Coordinates
/// come from `Leaves`' markers, the same for every sample.
#[derive(Clone, Debug, PartialEq)]
enum Key {
    Texture(u32, [u64; 4]),
    Framebuffer(u32, FbChannel, [u64; 4]),
}

fn bits(v: Value) -> [u64; 4] {
    v.map(f64::to_bits)
}

/// The leaves of a pass for one sample: texture units hold `texels`, the
/// primary and secondary colours `colors`; every other per-fragment leaf (an
/// interpolated coordinate, the pixel) is a marker that tells units apart.
struct Leaves<'a> {
    m: &'a Module,
    keys: &'a [(Key, Ty)],
    texels: Vec<Value>,
    colors: [(Option<Handle<Expr>>, Value); 2],
}

/// An RGBA value as a node of type `ty` reads it: the combiners read a
/// scalar from alpha (docs/combiners.md, "Code generation").
fn shaped(ty: Ty, v: Value) -> Value {
    match ty {
        Ty::Scalar => [v[3]; 4],
        Ty::Rgba => v,
        _ => [v[0], v[1], v[2], 0.0],
    }
}

impl Env for Leaves<'_> {
    fn interpolate(&mut self, node: Handle<Expr>, _value: Handle<Expr>, _to: Frequency) -> Value {
        for (h, c) in self.colors {
            if h == Some(node) {
                return shaped(self.m.info(node).ty, c);
            }
        }
        [node.index() as f64 + 0.25, 0.5, 0.75, 1.0]
    }

    fn pixel(&mut self, _freq: Frequency) -> Value {
        [-1.0, -2.0, -3.0, -4.0]
    }

    fn lookup(&mut self, texture: u32, coords: Value, _ty: Ty) -> Value {
        let key = Key::Texture(texture, bits(coords));
        let i = self.keys.iter().position(|(k, _)| *k == key).expect("a lookup bound to a unit");
        shaped(self.keys[i].1, self.texels[i])
    }

    fn framebuffer(&mut self, framebuffer: u32, channel: FbChannel, position: Value) -> Value {
        let key = Key::Framebuffer(framebuffer, channel, bits(position));
        let i = self.keys.iter().position(|(k, _)| *k == key).expect("a framebuffer read bound to a unit");
        shaped(self.keys[i].1, self.texels[i])
    }
}

/// A random texel whose rgb is a range-compressed vector of length at most
/// 1 after `expand` (as a normalization cube map or normal map stores,
/// seeds/003 Section 5.2), and any alpha: valid for colour textures too, and
/// dot products of such vectors stay in [−1, 1], as the IR assumes.
fn texel(rng: &mut Rng) -> [u8; 4] {
    loop {
        let v = [0; 3].map(|_| rng.unit() * 2.0 - 1.0);
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if !(0.05..=1.0).contains(&len) {
            continue;
        }
        let scale = 0.1 + 0.89 * rng.unit();
        let b = v.map(|x| ((x / len * scale + 1.0) / 2.0 * 255.0).round() as u8);
        let e = b.map(|x| 2.0 * f64::from(x) / 255.0 - 1.0);
        if e[0] * e[0] + e[1] * e[1] + e[2] * e[2] <= 1.0 {
            return [b[0], b[1], b[2], rng.byte()];
        }
    }
}

/// Runs `g` in the emulator (f32: rounding only at the output) on random
/// texels and colours and compares with the IR's value of the pass, the
/// 8-bit target's `saturate(value)` (alpha 1 unless the value is rgba).
/// `Some(why)` when the pass cannot be compared this way.
fn agrees(
    m: &Module,
    value: Handle<Expr>,
    units: &[Handle<Expr>],
    g: &Generated,
    what: &str,
) -> Option<String> {
    // Unit coordinates from the markers: the same for every sample unless a
    // unit's coordinates depend on another unit (a dependent lookup).
    let mut keys = Vec::new();
    if matches!(m.exprs[value], Expr::Depth(_)) {
        return Some("the depth a depth-only pass writes (the depth test stores it; no colour)".into());
    }
    for &u in units {
        if shadec::planner::shadow_map::depth_texture_read(m, u).is_some() {
            return Some(
                "a depth texture: its register holds the comparison, not a texel (tests/shadow_map.rs)"
                    .into(),
            );
        }
        let coords = match &m.exprs[u] {
            Expr::Lookup { coords, .. } => *coords,
            Expr::FramebufferRead { position, .. } => *position,
            e => return Some(format!("unit bound to {e:?}")),
        };
        if m.reachable(&[coords])
            .iter()
            .any(|h| matches!(m.exprs[*h], Expr::Lookup { .. } | Expr::FramebufferRead { .. }))
        {
            return Some("dependent texture lookup (texture shader)".into());
        }
        let mut ev = Evaluator::new(m, &[coords], shadec::numerics::Precision::Exact);
        let mut env =
            Leaves { m, keys: &[], texels: vec![], colors: [(g.primary, [0.0; 4]), (g.secondary, [0.0; 4])] };
        let c = bits(ev.eval(&mut env).values[0]);
        keys.push((
            match &m.exprs[u] {
                Expr::Lookup { texture, .. } => Key::Texture(*texture, c),
                Expr::FramebufferRead { framebuffer, channel, .. } => {
                    Key::Framebuffer(*framebuffer, *channel, c)
                }
                _ => unreachable!(),
            },
            m.info(u).ty,
        ));
    }
    for (i, k) in keys.iter().enumerate() {
        assert!(!keys[..i].iter().any(|(o, _)| *o == k.0), "two units answer the same leaf");
    }
    let (w, h) = (64, 16);
    let n = w * h;
    let mut rng = Rng(0x00c0_ffee_5eed ^ value.index() as u64);
    let imgs: Vec<Vec<u8>> =
        (0..units.len() + 2).map(|_| (0..n).flat_map(|_| texel(&mut rng)).collect()).collect();
    // Uniforms take their defaults (the generator's colours); one with no
    // default would be the caller's to bind.
    for c in g.constants.iter().flatten() {
        if let Expr::Uniform(id) = &m.exprs[*c] {
            if m.uniforms[*id as usize].default.is_none() {
                return Some(format!("uniform `{}` has no default", m.uniforms[*id as usize].name));
            }
        }
    }
    // A signed texel (a HILO normalization map) is its expanded vector, in
    // the 9-bit register and in the IR alike; an unsigned one as stored.
    let signed: Vec<bool> = units.iter().map(|&u| m.info(u).interval.lo < 0.0).collect();
    let register = |k: usize, p: usize| -> [i16; 4] {
        [0, 1, 2, 3].map(|c| {
            let b = i16::from(imgs[k][p * 4 + c]);
            if signed[k] {
                2 * b - 255
            } else {
                b
            }
        })
    };
    let d = Inputs::default();
    let machine = PixelEmulator::new(&g.config, d.constant0, d.constant1, d.fog, Precision::F32).unwrap();
    let colour = |k: usize, p: usize| -> [u8; 4] { imgs[k][p * 4..p * 4 + 4].try_into().unwrap() };
    let out: Vec<u8> = (0..n)
        .flat_map(|p| {
            let mut textures = [[0i16; 4]; 4];
            for (k, t) in textures.iter_mut().enumerate().take(units.len()) {
                *t = register(k, p);
            }
            let regs = PixelRegisters {
                textures,
                primary: colour(units.len(), p),
                secondary: colour(units.len() + 1, p),
            };
            machine.run(&regs)
        })
        .collect();
    let rgba = |img: &[u8], p: usize| [0, 1, 2, 3].map(|c| f64::from(img[p * 4 + c]) / 255.0);
    let mut ev = Evaluator::new(m, &[value], shadec::numerics::Precision::Exact);
    let ty = m.info(value).ty;
    for p in 0..n {
        let mut env = Leaves {
            m,
            keys: &keys,
            texels: (0..units.len()).map(|k| register(k, p).map(|v| f64::from(v) / 255.0)).collect(),
            colors: [
                (g.primary, rgba(&imgs[units.len()], p)),
                (g.secondary, rgba(&imgs[units.len() + 1], p)),
            ],
        };
        let v = ev.eval(&mut env).values[0];
        let want =
            if ty == Ty::Rgba { v } else { [v[0], v[1], v[2], 1.0] }.map(|c| c.clamp(0.0, 1.0) * 255.0);
        for c in 0..4 {
            let got = f64::from(out[p * 4 + c]);
            assert!(
                (got - want[c]).abs() <= 0.5 + 1e-3,
                "{what}: pixel {p} channel {c}: emulated {got}, the IR {:.3}\n{}",
                want[c],
                rc1::print(&g.config)
            );
        }
    }
    None
}
