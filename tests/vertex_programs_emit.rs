//! Every GeForce3 pass's per-vertex part emitted as a `!!VP1.0` program
//! (`vertex_program::emit`): each program validates against the spec's
//! limits, reads back from its text, and — run by the CPU interpreter on
//! random vertices — computes what the host computes for the same vertex
//! (`ir::eval::Evaluator` in f64, the renderer's vertex stage, with the
//! scene binder's `project_by` for projections), within f32 rounding.
//! On the examples and on generated programs.

use glam::Mat4;
use shadec::backends::vertex_program::{self as vp, emit, emulate, Output};
use shadec::driver::{self, PlanOptions};
use shadec::ir::eval::{canonical, Env, Evaluator, Value};
use shadec::ir::{Expr, Handle, Module, Projection, Ty};
use shadec::numerics::Precision;
use shadec::pipeline::PassInterface;
use shadec::profile::Profile;

/// f32 against f64: a few roundings per instruction through a dozen
/// instructions, on values of magnitude about 1 (LIT's power: its
/// exponent times the base's relative error).
const TOLERANCE: f64 = 2.0e-4;

struct Leaves {
    values: Vec<(Expr, Value)>,
    matrices: Vec<(Projection, Mat4)>,
}

fn hash(mut x: u64) -> f64 {
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51afd7ed558ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ceb9fe1a85ec53);
    x ^= x >> 33;
    (x % 2_000_001) as f64 / 1_000_000.0 - 1.0
}

fn leaf_value(ty: Ty, seed: u64) -> Value {
    let mut v = [0, 1, 2, 3].map(|k| hash(seed * 8 + k));
    if ty == Ty::Position {
        v = [2.0 * v[0], 2.0 * v[1], 2.0 * v[2], 1.0];
    }
    canonical(ty, v)
}

impl Leaves {
    fn new(m: &Module, nodes: &[Handle<Expr>], vertex: u64) -> Leaves {
        let mut values = Vec::new();
        let mut matrices = Vec::new();
        for &n in nodes {
            let e = &m.exprs[n];
            let per_vertex = m.info(n).freq == shadec::ir::Frequency::Vertex;
            match e {
                Expr::VertexPosition(_) | Expr::TexCoord { .. } | Expr::Vector { .. } | Expr::Uniform(_) => {
                    let seed = n.index() as u64 * 1000 + if per_vertex { vertex } else { 0 };
                    values.push((e.clone(), leaf_value(m.info(n).ty, seed)));
                }
                Expr::Project { projection, .. } if !matrices.iter().any(|(p, _)| p == projection) => {
                    let s = 7919 * (matrices.len() as u64 + 1);
                    let cols: [f32; 16] = std::array::from_fn(|k| {
                        let diagonal = if k % 5 == 0 { 1.5 } else { 0.0 };
                        (diagonal + 0.5 * hash(s + k as u64)) as f32
                    });
                    matrices.push((projection.clone(), Mat4::from_cols_array(&cols)));
                }
                _ => {}
            }
        }
        Leaves { values, matrices }
    }

    fn get(&self, e: &Expr) -> Value {
        self.values.iter().find(|(x, _)| x == e).map_or([f64::NAN; 4], |(_, v)| *v)
    }

    fn matrix(&self, p: &Projection) -> Mat4 {
        self.matrices.iter().find(|(q, _)| q == p).map_or(Mat4::IDENTITY, |(_, m)| *m)
    }
}

impl Env for Leaves {
    fn uniform(&mut self, id: shadec::ir::UniformId) -> Option<Value> {
        Some(self.get(&Expr::Uniform(id)))
    }
    fn vertex_position(&mut self, vertex: shadec::ir::VertexId) -> Value {
        self.get(&Expr::VertexPosition(vertex))
    }
    fn tex_coord(&mut self, set: shadec::ir::TexCoordId, vertex: shadec::ir::VertexId) -> Value {
        self.get(&Expr::TexCoord { set, vertex })
    }
    fn vector(&mut self, vector: shadec::ir::VectorId, site: shadec::ir::Site) -> Value {
        self.get(&Expr::Vector { vector, site })
    }
    fn project(&mut self, projection: &Projection, value: Value, ty: Ty) -> Value {
        if ty == Ty::Vec3 {
            let [x, y, z, _] = value;
            let m = 2.0 * (x * x + y * y + (z + 1.0) * (z + 1.0)).sqrt();
            return [x / m + 0.5, y / m + 0.5, 0.0, 0.0];
        }
        shadec::scene::bind::project_by(self.matrix(projection), projection.inverse, value, ty)
    }
}

fn rows(m: Mat4) -> [[f32; 4]; 4] {
    let c = m.to_cols_array_2d();
    std::array::from_fn(|r| [c[0][r], c[1][r], c[2][r], c[3][r]])
}

/// Emits, validates and compares one pass on `vertices` vertices; the
/// largest difference, or why the host keeps the pass's vertices.
fn check_pass(
    m: &Module,
    pi: &PassInterface,
    planned: Option<(&shadec::pipeline::Planned, usize)>,
    what: &str,
    vertices: u64,
) -> Result<f64, String> {
    let e = match planned {
        Some((planned, index)) => emit::emit_pass(planned, index),
        None => emit::emit(m, pi),
    }
    .map_err(|e| e.reason)?;
    let errors = vp::validate(&e.program);
    assert!(
        errors.is_empty(),
        "{what}: the emitted program breaks the spec: {errors:?}\n{}",
        vp::print(&e.program)
    );
    let text = vp::print(&e.program);
    assert_eq!(vp::parse_file(&text).unwrap_or_else(|d| panic!("{what}: {d:?}\n{text}")), e.program);
    let wgsl = vp::wgsl::translate(&e.program, what);
    let module = naga::front::wgsl::parse_str(&wgsl)
        .unwrap_or_else(|d| panic!("{what}: {}\n{wgsl}", d.emit_to_string(&wgsl)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap_or_else(|d| panic!("{what}: {d:?}\n{wgsl}"));
    let values: Vec<Handle<Expr>> = pi
        .interpolants
        .iter()
        .map(|&h| match m.exprs[h] {
            Expr::Interpolate { value, .. } => value,
            _ => h,
        })
        .collect();
    let mut roots = values.clone();
    roots.extend(pi.position);
    let nodes = m.reachable(&roots);
    let mut worst = 0.0f64;
    for vertex in 0..vertices {
        let mut leaves = Leaves::new(m, &nodes, vertex);
        let mut ev = Evaluator::new(m, &roots, Precision::Exact);
        let want: Vec<Value> = ev.eval(&mut leaves).values.to_vec();
        let mut attributes = [[0.0f32; 4]; 16];
        for (k, &h) in e.attributes.iter().enumerate() {
            attributes[k] = leaves.get(&m.exprs[h]).map(|x| x as f32);
        }
        let matrices: Vec<(Projection, Mat4)> = leaves.matrices.clone();
        let params = emit::parameter_values(
            &e,
            |h| {
                let mut ev = Evaluator::new(m, &[h], Precision::Exact);
                ev.eval(&mut leaves).values[0].map(|x| x as f32)
            },
            |p| rows(matrices.iter().find(|(q, _)| q == p).map_or(Mat4::IDENTITY, |(_, m)| *m)),
        );
        let got = emulate::run(&e.program, &attributes, &params);
        let mut compare = |name: String, w: Value, g: [f32; 4]| {
            for k in 0..4 {
                let d = (w[k] - f64::from(g[k])).abs() / (1.0 + w[k].abs());
                worst = worst.max(if d.is_nan() { f64::INFINITY } else { d });
                assert!(
                    d <= TOLERANCE || (w[k].is_nan() && g[k].is_nan()),
                    "{what}: {name}.{k} host {} vertex program {}\n{text}",
                    w[k],
                    g[k]
                );
            }
        };
        for (k, w) in want.iter().take(values.len()).enumerate() {
            let o = e.outputs[k];
            // Coordinates without a q of their own get q = 1: a texture
            // unit divides by it (NV_texture_shader's texture_2d, (s/q, t/q)).
            let mut w = *w;
            if o.is_texture() && (2..4).contains(&m.info(values[k]).ty.width()) {
                w[3] = 1.0;
            }
            compare(format!("o[{}]", o.name()), w, got.get(o));
        }
        if let Some(p) = pi.position {
            let w = want[values.len()];
            let w = if m.info(p).ty == Ty::Vec2 { [2.0 * w[0] - 1.0, 1.0 - 2.0 * w[1], 0.0, 1.0] } else { w };
            compare("o[HPOS]".into(), w, got.get(Output::HPOS));
        }
    }
    Ok(worst)
}

/// Every pass of `source` planned on geforce3: (emitted, refused reasons, worst).
fn check_program(source: &str, what: &str) -> Option<(usize, Vec<String>, f64)> {
    let profile = Profile::builtin("geforce3").unwrap();
    let c = driver::compile(source, &profile, &PlanOptions::default()).ok()?;
    let planned = &c.planned;
    let (mut emitted, mut refused, mut worst) = (0, Vec::new(), 0.0f64);
    for (i, pass) in planned.plan.passes.iter().enumerate() {
        if pass.baked {
            continue;
        }
        let pi = PassInterface::of(planned, i);
        let through = if i % 2 == 0 { Some((planned, i)) } else { None };
        match check_pass(&planned.module, &pi, through, &format!("{what} pass {i}"), 16) {
            Ok(w) => {
                emitted += 1;
                worst = worst.max(w);
            }
            Err(reason) => refused.push(format!("{what} pass {i}: {reason}")),
        }
    }
    Some((emitted, refused, worst))
}

#[test]
fn the_examples_geforce3_passes_emit_vertex_programs_that_agree_with_the_host() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut entries: Vec<_> =
        std::fs::read_dir(&dir).unwrap().filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    let (mut emitted, mut refused, mut worst) = (0, Vec::new(), 0.0f64);
    for path in entries.iter().filter(|p| p.extension().is_some_and(|e| e == "shd")) {
        let text = std::fs::read_to_string(path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if let Some((e, r, w)) = check_program(&text, &name) {
            emitted += e;
            refused.extend(r);
            worst = worst.max(w);
        }
    }
    eprintln!("examples on geforce3: {emitted} passes as vertex programs, worst relative difference {worst:e}; the host keeps {}:", refused.len());
    for r in &refused {
        eprintln!("  {r}");
    }
    assert!(emitted >= 20, "only {emitted} passes emitted; refused: {refused:#?}");
}

const SCALARS: [&str; 12] = [
    "max(0, N·L)",
    "N·V",
    "saturate(N·H)",
    "max(0, N·H)^8",
    "k",
    "length(L)",
    "clamp(N·L, 0.2, 0.9)",
    "abs(V·L)",
    "(N·L + 1)/2",
    "max(0, reflect(-L, N)·V)^4",
    "normalize(N + L)·V",
    "cross(N, L)·V",
];

fn scalar(seed: &mut u64, depth: u32) -> String {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let pick = (*seed >> 33) as usize;
    if depth == 0 {
        return SCALARS[pick % SCALARS.len()].to_string();
    }
    let (a, b) = (scalar(seed, depth - 1), scalar(seed, depth - 1));
    match pick % 6 {
        0 => format!("({a} + {b})"),
        1 => format!("({a} * {b})"),
        2 => format!("({a} - {b})"),
        3 => format!("max({a}, {b})"),
        4 => format!("min({a}, 0.5 * {b})"),
        _ => format!("saturate({a})"),
    }
}

#[test]
fn generated_per_vertex_programs_emit_vertex_programs_that_agree_with_the_host() {
    let mut seed = 0x9e3779b97f4a7c15u64;
    let mut emitted = 0;
    let mut worst = 0.0f64;
    for case in 0..24 {
        let (r, g, b) = (scalar(&mut seed, 2), scalar(&mut seed, 1), scalar(&mut seed, 2));
        let source = format!(
            "vector N : normal;\nvector L : light(0);\nvector V : view;\nvector H = normalize(L + V);\nuniform k : scalar = 0.5;\nconst kd : rgb = (0.8, 0.6, 0.4);\n\nshader p : s → c = kd * rgb({r}, {g}, {b});\nC δπx ← δ p s x;\n"
        );
        let Some((e, refused, w)) = check_program(&source, &format!("generated {case}")) else {
            panic!("generated program {case} does not plan on geforce3:\n{source}");
        };
        assert!(refused.is_empty(), "{refused:?}\n{source}");
        emitted += e;
        worst = worst.max(w);
    }
    eprintln!("generated programs: {emitted} passes as vertex programs, worst relative difference {worst:e}");
    assert!(emitted >= 24);
}

/// Each texture unit reads its own `o[TEXu]` (NV_vertex_program, Section
/// 2.14.1.3): two units at the same coordinates (a decal and a gloss map
/// both at `δu x`) get them both, and 2-D coordinates get q = 1, which a
/// unit divides by. Before, only the first unit's set was written, and q
/// was 0.
#[test]
fn units_sharing_coordinates_each_get_their_set_with_q_one() {
    let source = "texture A, B : 2d rgb8 = image(\"layer.png\");\nC δπx ← (A δu x) * (B δu x);\n";
    let profile = Profile::builtin("geforce3").unwrap();
    let planned = driver::compile(source, &profile, &PlanOptions::default()).unwrap().planned;
    assert_eq!(planned.plan.passes.len(), 1);
    assert_eq!(planned.plan.passes[0].textures.len(), 2, "two units");
    let e = emit::of(&planned, 0).unwrap();
    let text = vp::print(&e.program);
    let mut attributes = [[0.0f32; 4]; 16];
    for (k, &h) in e.attributes.iter().enumerate() {
        attributes[k] = match planned.module.exprs[h] {
            Expr::TexCoord { .. } => [0.25, 0.75, 0.0, 0.0],
            _ => [0.1, 0.2, 0.3, 1.0],
        };
    }
    let parameters = emit::parameter_values(&e, |_| [0.0; 4], |_| rows(Mat4::IDENTITY));
    let results = emulate::run(&e.program, &attributes, &parameters);
    for unit in 0..2 {
        let tex = results.get(Output::tex(unit));
        assert_eq!(&tex[..2], &[0.25, 0.75], "o[TEX{unit}] holds u x\n{text}");
        assert_eq!(tex[3], 1.0, "o[TEX{unit}].w is q = 1\n{text}");
    }
}
