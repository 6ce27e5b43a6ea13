//! Rule `alpha_ramp_shadow_map`: Williams 1978's shadow-map test on a
//! register-combiner target without depth textures (the GeForce 256),
//! as Kilgard's "shadow mapping with today's OpenGL hardware" (GDC 2000)
//! ran it on the GeForce 1 and 2: both depths from the light encoded into
//! an 8-bit alpha ramp and compared in the combiners.
//!
//! The program (Pipeline Grammar, Section 3.5, with Williams's test):
//!
//! ```text
//! Cl δπl x ← δ x                                  depth from the light
//! α C xs ← (z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b
//! ```
//!
//! becomes
//!
//! ```text
//! R δu ← 1 − ⌊256 (δu).x⌋/255                     the ramp: 256 texels, 8 bits, nearest
//! α Cl δπl x ← R (z δπl x)                        light pass: texgen s = depth from the light
//! α C δπx ← ½·(R (z δπl x − b) + (1 − α Cl δπl x)) < ½
//! ```
//!
//! The light pass writes the ramp's texel at each fragment's depth from
//! the light into `Cl`'s alpha (8 bits: a colour buffer the camera pass
//! reads as a texture). The camera pass draws the meshes again (depth
//! test `Equal`, as the GeForce3 redraw does, `planner::shadow_map`):
//! unit 0 reads the ramp at the fragment's own depth from the light less
//! the bias (texgen with the light's matrices; the unit divides s by q),
//! unit 1 reads `Cl`'s alpha projected with the light's texgen, and one
//! general combiner sums the first with the second inverted
//! (`unsigned_invert`), scaled by ½; the second combiner's mux, which
//! tests ≥ ½ (Kilgard 2000, Section 4.2.2), selects the shadow below it.
//! The ramp falls (depth 0 is 255/255, the far plane 0), so a point is
//! farther than the stored one where its encoding is below: written as
//! `< ½` the test is strict where the meaning's `>` is, and equal
//! encodings (a surface against its own stored depth) are lit on the
//! hardware as in the IR: ½·(a + 1 − c) at a = c is 127.5/255, which the
//! register write rounds up to 128/255 ≥ ½.
//! Two units and two general combiners: what the GeForce 256 had.
//!
//! The error: a point is in shadow in the approximation only if its
//! quantized depth `⌊256(z − b)⌋` exceeds the stored `⌊256 d⌋` (inside
//! the light's view; outside it, and where the light pass drew nothing,
//! the stored 0 is the far plane, as the meaning's cleared depth), which
//! implies `z − b > d`: it never shadows a point the meaning lights, and it
//! lights the points whose `z − b` is above `d` by less than one ramp
//! step (1/256 of the depth range) in the same step. A shadow's edge or
//! contact where the depths are that close is lost. Its value at the
//! output is a step (0 or the whole shadow), so the rule states no bound;
//! the plan is measured against the program's meaning on the scene.

use super::Rewriter;
use crate::ir::{BinaryOp, Constant, Expr, FbChannel, Frequency, Handle, Statement, Table, Texture, Ty};
use crate::parser::ast::{FramebufferChannel, TextureFormat, TextureKind};
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// The rule's name in plans and warnings.
pub const RULE: &str = "alpha_ramp_shadow_map";

/// The name of the ramp texture the rule adds (the planner's redraw
/// recognises the compare by it).
pub const RAMP: &str = "alpha_ramp";

/// Texels of the ramp: one per 8-bit value.
pub const RAMP_TEXELS: usize = 256;

/// Williams's test at the pixel, as the rule finds it.
struct Test {
    /// The statement of the test and the one writing the light's depth.
    statement: usize,
    light: usize,
    /// The light's depth framebuffer `Cl`.
    depth_fb: u32,
    /// The bias `b` (0 without one).
    bias: f64,
    /// `δπx` of the last earlier statement drawing meshes into the test's
    /// framebuffer, and its vertex `x`.
    mesh_index: Handle<Expr>,
    vertex: Handle<Expr>,
    /// The light's projection `πl`.
    projection: crate::ir::Projection,
}

/// Rewrites every Williams test of the program into the alpha-ramp
/// passes, on a combiner target without depth textures.
pub fn apply(r: &mut Rewriter) {
    if !r.combiners() || r.profile.depth_textures {
        return;
    }
    let mut i = 0;
    while i < r.m.statements.len() {
        if let Some(test) = find(r, i) {
            if rewrite(r, &test).is_none() {
                return;
            }
        }
        i += 1;
    }
}

/// Statement `i` as Williams's test `(z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b`
/// whose `Cl` a depth-only light pass wrote, after a mesh pass into the
/// test's framebuffer.
fn find(r: &Rewriter, i: usize) -> Option<Test> {
    let m = &r.m;
    let st = &m.statements[i];
    let Table::Framebuffer { id, channel: FbChannel::Alpha } = st.table else { return None };
    let Expr::Pixel { freq: Frequency::Screen } = m.exprs[st.index] else { return None };
    let Expr::Binary { op: BinaryOp::Gt, lhs, rhs } = m.exprs[st.value] else { return None };
    let (read, bias) = match m.exprs[rhs] {
        Expr::Binary { op: BinaryOp::Add, lhs: d, rhs: b } => match &m.exprs[b] {
            Expr::Constant(c) if c.ty == Ty::Scalar => (d, c.components[0]),
            _ => return None,
        },
        _ => (rhs, 0.0),
    };
    let Expr::Depth(p) = m.exprs[lhs] else { return None };
    let Expr::FramebufferRead { framebuffer, channel: FbChannel::Depth, position } = m.exprs[read] else {
        return None;
    };
    // `p` is `πl π⁻¹ xs`, read at the same place.
    let Expr::Project { ref projection, value: back } = m.exprs[p] else { return None };
    let Expr::Project { projection: ref inverse, value: pixel } = m.exprs[back] else { return None };
    if position != p || projection.inverse || !inverse.inverse || pixel != st.index {
        return None;
    }
    let light = light_pass(r, i, framebuffer, projection)?;
    let (mesh_index, vertex) = mesh_pass(r, i, id)?;
    Some(Test {
        statement: i,
        light,
        depth_fb: framebuffer,
        bias,
        mesh_index,
        vertex,
        projection: projection.clone(),
    })
}

/// The earlier statement drawing the meshes into depth-only framebuffer
/// `fb` from projection `light`.
fn light_pass(r: &Rewriter, i: usize, fb: u32, light: &crate::ir::Projection) -> Option<usize> {
    let m = &r.m;
    let depth_only = m.framebuffers[fb as usize]
        .channels
        .iter()
        .all(|c| matches!(c, FramebufferChannel::Depth | FramebufferChannel::Stencil));
    if !depth_only {
        return None;
    }
    (0..i).rev().find(|&j| {
        let s = &m.statements[j];
        matches!(s.table, Table::Framebuffer { id, .. } if id == fb)
            && matches!(m.exprs[s.index], Expr::Interpolate { value, .. }
                if matches!(m.exprs[value], Expr::Project { ref projection, .. } if projection == light))
    })
}

/// `δπx` and `x` of the last statement before `i` drawing meshes into
/// framebuffer `fb`.
fn mesh_pass(r: &Rewriter, i: usize, fb: u32) -> Option<(Handle<Expr>, Handle<Expr>)> {
    let m = &r.m;
    m.statements[..i].iter().rev().find_map(|s| match s.table {
        Table::Framebuffer { id, .. } if id == fb => match m.exprs[s.index] {
            Expr::Interpolate { value: clip, .. } => match m.exprs[clip] {
                Expr::Project { value, .. } => Some((s.index, value)),
                _ => None,
            },
            _ => None,
        },
        _ => None,
    })
}

/// The three statements of the rule's doc in place of the light pass and
/// the test.
fn rewrite(r: &mut Rewriter, t: &Test) -> Option<()> {
    let span = r.m.statements[t.statement].span;
    let value_span = r.m.span(r.m.statements[t.statement].value);
    let ramp = add_ramp(r, r.m.statements[t.light].span)?;
    // The light's clip position per vertex, interpolated (texgen `πl x`).
    let clip = r.node(Expr::Project { projection: t.projection.clone(), value: t.vertex }, span)?;
    let at_light = r.node(Expr::Interpolate { value: clip, to: Frequency::Fragment }, span)?;
    let depth = r.node(Expr::Depth(at_light), span)?;
    // Light pass: `α Cl δπl x ← R (z δπl x)` at the light pass's own fragments.
    let light_index = r.m.statements[t.light].index;
    let light_depth = r.node(Expr::Depth(light_index), span)?;
    let stored = r.node(Expr::Lookup { texture: ramp.id, coords: light_depth }, span)?;
    // Camera pass: `½·(R (z δπl x − b) + (1 − α Cl δπl x)) < ½`.
    let b = r.node(Expr::Constant(Constant::scalar(t.bias)), span)?;
    let shifted = r.node(Expr::Binary { op: BinaryOp::Sub, lhs: depth, rhs: b }, span)?;
    let own = r.node(Expr::Lookup { texture: ramp.id, coords: shifted }, span)?;
    let read = r.node(
        Expr::FramebufferRead { framebuffer: t.depth_fb, channel: FbChannel::Alpha, position: at_light },
        span,
    )?;
    let one = r.node(Expr::Constant(Constant::scalar(1.0)), span)?;
    let half = r.node(Expr::Constant(Constant::scalar(0.5)), span)?;
    let inverted = r.node(Expr::Binary { op: BinaryOp::Sub, lhs: one, rhs: read }, span)?;
    let sum = r.node(Expr::Binary { op: BinaryOp::Add, lhs: own, rhs: inverted }, span)?;
    let scaled = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: half, rhs: sum }, span)?;
    let test = r.node(Expr::Binary { op: BinaryOp::Lt, lhs: scaled, rhs: half }, value_span)?;
    // `Cl` keeps its depth (the light pass's hidden surfaces) and gains
    // an 8-bit colour buffer for the encoded depth.
    r.m.framebuffers[t.depth_fb as usize].channels.insert(0, FramebufferChannel::Rgba8);
    let light = &mut r.m.statements[t.light];
    light.table = Table::Framebuffer { id: t.depth_fb, channel: FbChannel::Alpha };
    light.value = stored;
    let st = &mut r.m.statements[t.statement];
    st.index = t.mesh_index;
    st.freq = Frequency::Fragment;
    st.value = test;
    r.m.statements.insert(t.light, ramp.statement);
    r.record(
        RULE,
        value_span,
        Some(test),
        format!(
            "geforce256 has no depth textures: both depths from the light are encoded into an 8-bit alpha ramp \
             ({RAMP_TEXELS} texels, texgen s = depth from the light) and compared in the combiners, the light pass \
             rendered to a texture; a point whose depth exceeds the stored one by the bias and less than one ramp \
             step (1/{RAMP_TEXELS}) is lit"
        ),
        ApproximationCost { texture_units: 2, passes: 0, general_combiners: 2, texels: RAMP_TEXELS as u64 },
        None,
    );
    Some(())
}

/// The ramp texture and its texel statement.
struct Ramp {
    id: u32,
    statement: Statement,
}

/// A 1-D 8-bit table whose texel i holds (255 − i)/255, sampled nearest
/// and clamped, baked by the compiler: the depth s is encoded as
/// 1 − ⌊256 s⌋/255, so that 0 — the light pass's cleared colour, and
/// what a read outside its texture returns — is the far plane (depth 1,
/// no occluder), as the meaning's cleared depth is.
fn add_ramp(r: &mut Rewriter, span: Span) -> Option<Ramp> {
    let texel = r.node(Expr::TexelCoord, span)?;
    let s = r.node(Expr::Swizzle { value: texel, pattern: [0, 0, 0, 0], len: 1, ty: Ty::Scalar }, span)?;
    // (255 − i)/255 at texel i = ⌊256 s⌋: exact in 8 bits, one value a texel.
    let n = r.node(Expr::Constant(Constant::scalar(RAMP_TEXELS as f64)), span)?;
    let step = r.node(Expr::Constant(Constant::scalar(1.0 / 255.0)), span)?;
    let one = r.node(Expr::Constant(Constant::scalar(1.0)), span)?;
    let scaled = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: s, rhs: n }, span)?;
    let i = r.node(Expr::Math { fun: crate::ir::MathFunction::Floor, args: vec![scaled] }, span)?;
    let fraction = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: i, rhs: step }, span)?;
    let value = r.node(Expr::Binary { op: BinaryOp::Sub, lhs: one, rhs: fraction }, span)?;
    let value = r.node(Expr::Math { fun: crate::ir::MathFunction::Saturate, args: vec![value] }, span)?;
    let k = r.m.textures.iter().filter(|t| t.name.starts_with(RAMP)).count();
    r.m.textures.push(Texture {
        name: if k == 0 { RAMP.to_string() } else { format!("{RAMP}{k}") },
        kind: TextureKind::Tex1d,
        format: TextureFormat::R8,
        rendered: true,
        baked: true,
        declaration: None,
        copy_of: None,
        tabulates: None,
        sampling: crate::ir::Sampling {
            filter: crate::textures::Filter::Nearest,
            wrap: crate::textures::Wrap::ClampToEdge,
            mipmap: false,
        },
        span: Span::DETACHED,
    });
    let id = (r.m.textures.len() - 1) as u32;
    let statement = Statement {
        table: Table::Texture(id),
        index: texel,
        freq: Frequency::Texel,
        value,
        span,
        target_span: span,
    };
    Some(Ramp { id, statement })
}
