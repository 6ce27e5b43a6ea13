//! The program's own meaning: the reference every plan is measured against
//! (DESIGN.md, "Reference, speed and error").
//!
//! Pipeline Grammar defines a program as its statements run in order, each one
//! table assignment `T i ← v` over every sample of its index (Section 3):
//! the value `v` is computed in full and stored, and a read of the target
//! (`C δπx` on the right, (9)) is the target's value before the statement —
//! as the target stores it: an `rgba8` framebuffer reads back clamped to
//! [0, 1] (GL §2.13.9, §4.1.8) — in `Precision::Exact` unrounded (the
//! renderer's `ColorFormat::Unorm`: the program in ideal arithmetic, so
//! that an 8-bit store between a plan's passes is a loss measured against
//! it), in `f32` rounded to k/255 as GL and wgpu store it.
//! The meaning does exactly that with unlimited resources: one pass per
//! statement, the statement's whole value written with `replace`, no
//! blend read off it, no split, no fusion, no specialization, no light
//! culling — so a plan that loses, duplicates or reorders a term differs
//! from it. Rendered in `Precision::Exact` (f64 arithmetic, ideal filtering,
//! unit vectors renormalized, true `pow`), it is what `render` and `bench`
//! report error against, and what the differential tests compare every
//! plan with.
//!
//! What it shares with plans: the rasterizer, the scene binder and the
//! IR's one semantics of each operation (`ir::eval`). What it does not:
//! the planner's blends, splits, temporaries, fusion, depth-state choice
//! and specialization — the parts that decide whether a plan computes
//! what the program says.

use crate::diag::Diagnostic;
use crate::ir::{Expr, FbChannel, Frequency, Handle, Module, Statement, Table, Usage};
use crate::pipeline::{
    BlendMode, FragmentWork, Geometry, Pass, PassPlan, Planned, RenderTarget, TextureBinding, VertexWork,
};
use crate::pipeline::{BlendState, CullMode, DepthState, RenderState, StencilState};
use crate::planner::{self};

/// The name the meaning's plan carries as its target.
pub const TARGET: &str = "meaning";

/// The program as a plan of one whole-value pass per statement. `lights` is
/// the number of scene lights: a program written for light 0 means one
/// term per light (docs/pass-plan.md, "per-light passes"), as every plan
/// for the scene does.
pub fn plan(module: &Module, lights: usize) -> Result<Planned, Vec<Diagnostic>> {
    let mut m = module.clone();
    if lights > 1 {
        planner::lights::expand(&mut m, lights, &|_| "-".to_string());
    }
    let mut passes = Vec::new();
    let mut errors = Vec::new();
    // (target, index) of the mesh draws so far: the first draw of an index
    // into a target resolves visibility (depth `Less`, written), later ones
    // shade the visible surface again (`Equal`).
    let mut drawn: Vec<(Table, Handle<Expr>)> = Vec::new();
    for (i, st) in m.statements.clone().iter().enumerate() {
        if matches!(st.table, Table::TexCoords(_)) {
            continue; // texgen: vertex work of the passes that read it
        }
        match statement_pass(&mut m, i, st, &mut drawn) {
            Ok(Some(pass)) => passes.push(pass),
            Ok(None) => {}
            Err(d) => errors.push(d),
        }
    }
    errors.extend(crate::planner::shadow_volumes::unbound_uses(&m));
    if !errors.is_empty() {
        return Err(errors);
    }
    let _ = crate::planner::shadow_volumes::count_by_facing(&m, &mut passes, true);
    Ok(Planned {
        module: m,
        plan: PassPlan {
            target: TARGET.into(),
            passes,
            removed: Vec::new(),
            values: Vec::new(),
            approximations: Vec::new(),
            predicted: None,
            measured: None,
        },
        combiners: None,
        vertex_programs: false,
        setups: Vec::new(),
    }
    .resolved())
}

/// Where a statement of the meaning draws: the geometry its index walks
/// (Pipeline Grammar, Section 3: the samples of the table's index), the
/// vertex position a mesh is projected from, and the depth test that keeps
/// one surface per sample.
struct Placement {
    /// A mesh is rasterized (a fragment, or a texel reached through the
    /// vertices: rendering into texture space).
    mesh: bool,
    /// The mesh is unwrapped over its texture coordinates, not projected.
    in_texture_space: bool,
    /// The vertex position the mesh is drawn at.
    position: Handle<Expr>,
    geometry: Geometry,
    depth: DepthState,
}

/// The placement of statement `st`, whose whole form draws at `drawn_at`
/// with depth state `depth` when it decides them itself; `drawn` is the
/// mesh draws so far, and gains this one when it resolves visibility.
fn place(
    m: &Module,
    st: &Statement,
    drawn_at: Option<Handle<Expr>>,
    depth: Option<DepthState>,
    drawn: &mut Vec<(Table, Handle<Expr>)>,
) -> Result<Placement, Diagnostic> {
    let in_texture_space = st.freq == Frequency::Texel
        && m.reachable(&[st.index]).iter().any(|h| m.info(*h).freq == Frequency::Vertex);
    let mesh = st.freq == Frequency::Fragment || in_texture_space;
    // Pipeline Grammar (10): a statement at the pixel reuses the vertices
    // the last statement into the same framebuffer projected.
    let at_pixel = mesh && drawn_at.is_none() && matches!(m.exprs[st.index], Expr::Pixel { .. });
    let reused = at_pixel
        .then(|| drawn.iter().rev().find(|(t, _)| same_target(t, &st.table)).map(|(_, h)| *h))
        .flatten();
    if at_pixel && reused.is_none() {
        return Err(Diagnostic::error("no-projected-vertices", "this statement at the pixel interpolates per-vertex values, but no earlier statement projects the mesh", st.span, "here").with_help("write a statement `C δπx ← …` into this framebuffer first (Pipeline Grammar, eq. (10))"));
    }
    let position = reused.or(drawn_at).unwrap_or(st.index);
    let geometry = match (st.freq, mesh) {
        (Frequency::Screen, _) => Geometry::Screen,
        (_, true) => Geometry::Mesh { projection: if in_texture_space { "u".into() } else { "π".into() } },
        _ => Geometry::Texels,
    };
    // `δπ* x` draws `δπ x`'s surface (`planner::depth_key`).
    let key = (st.table.depth_target(), crate::planner::depth_key(m, position));
    let decided = match (&geometry, depth) {
        (_, Some(d)) => d,
        (Geometry::Mesh { .. }, None) if in_texture_space => DepthState::DISABLED,
        (Geometry::Mesh { .. }, None) if drawn.contains(&key) => DepthState::EQUAL_NO_WRITE,
        (Geometry::Mesh { .. }, None) => DepthState::LESS_WRITE,
        _ => DepthState::DISABLED,
    };
    if matches!(geometry, Geometry::Mesh { .. }) && depth.is_none() && !drawn.contains(&key) {
        drawn.push(key);
    }
    Ok(Placement { mesh, in_texture_space, position, geometry, depth: decided })
}

/// Statement `i` as one pass of the meaning: its whole value, written with
/// `replace` where [`place`] puts it. `None` for a statement whose value
/// leaves nothing to compute.
fn statement_pass(
    m: &mut Module,
    i: usize,
    st: &Statement,
    drawn: &mut Vec<(Table, Handle<Expr>)>,
) -> Result<Option<Pass>, Diagnostic> {
    let form = planner::whole_form(m, st, st.value)?;
    let Placement { mesh, in_texture_space, position, geometry, depth } =
        place(m, st, form.drawn_at, form.depth, drawn)?;
    let (target, mask) = target_of(m, &st.table);
    // The stencil update's fragment computes nothing: the depth test
    // and the stencil operation are the statement.
    let output = if form.channels == "stencil" { constant_one(m, st.value) } else { Some(form.value) };
    let Some(output) = output else { return Ok(None) };
    let usage = Usage::of_value(m, output);
    let textures = texture_bindings(m, &usage);
    Ok(Some(Pass {
        statements: vec![i],
        light: None,
        objects: None,
        object_major: None,
        at: "-".into(),
        reason: format!("statement {} as written (the program's meaning)", i + 1),
        target,
        vertex: VertexWork {
            position: mesh.then_some(position.index() as u32),
            interpolants: usage.interpolants.iter().map(|h| h.index() as u32).collect(),
            texgen: Vec::new(),
        },
        textures,
        fragment: FragmentWork {
            output: output.index() as u32,
            operations: 0,
            condition: form.condition.map(|c| c.index() as u32),
            general_combiners: None,
            depth: None,
        },
        blend: BlendMode::Replace,
        state: RenderState {
            cull: if matches!(geometry, Geometry::Mesh { .. }) && !in_texture_space {
                CullMode::Back
            } else {
                CullMode::None
            },
            depth,
            stencil: form.stencil.unwrap_or(StencilState::DISABLED),
            blend: BlendState::REPLACE.with_write_mask(mask),
            alpha_test: crate::pipeline::AlphaTest::DISABLED,
        },
        geometry,
        baked: m.is_baked(st),
        predicted: None,
    }))
}

/// Where a statement writes, and the channels it writes.
fn target_of(m: &Module, table: &Table) -> (RenderTarget, [bool; 4]) {
    match *table {
        Table::Framebuffer { id, channel } => {
            let (channels, mask) = match channel {
                FbChannel::Alpha => ("a", [false, false, false, true]),
                FbChannel::Stencil => ("stencil", [false; 4]),
                _ => ("rgba", [true; 4]),
            };
            let name = m.framebuffers[id as usize].name.clone();
            (RenderTarget::Framebuffer { name, channels: channels.into() }, mask)
        }
        Table::Texture(id) => {
            (RenderTarget::Texture { name: m.textures[id as usize].name.clone() }, [true; 4])
        }
        Table::TexCoords(_) => unreachable!("texgen statements are vertex work, not passes"),
    }
}

/// Texture unit i holds the value's i-th lookup.
fn texture_bindings(m: &Module, usage: &Usage) -> Vec<TextureBinding> {
    usage
        .lookups
        .iter()
        .enumerate()
        .filter_map(|(unit, &h)| match m.exprs[h] {
            Expr::Lookup { texture, coords } => Some(TextureBinding {
                unit: unit as u32,
                texture: m.textures[texture as usize].name.clone(),
                lookup: h.index() as u32,
                coords: coords.index() as u32,
            }),
            _ => None,
        })
        .collect()
}

fn constant_one(m: &mut Module, near: Handle<Expr>) -> Option<Handle<Expr>> {
    let span = m.span(near);
    m.intern(Expr::Constant(crate::ir::Constant::scalar(1.0)), span).ok()
}

fn same_target(a: &Table, b: &Table) -> bool {
    matches!((a, b), (Table::Framebuffer { id: x, .. }, Table::Framebuffer { id: y, .. }) if x == y)
}
