//! The interpreter: an [`Evaluator`] runs the nodes below its roots, in
//! order, for one sample at a time, asking an [`Env`] for the leaves and
//! [`apply`] for every computation, and rounding to the [`Precision`] it
//! models.
//!
//! Apart from the semantics (`apply`, in the parent module) because it is
//! the only stateful part: the schedule of nodes and their values.

use super::*;

/// The leaves of one sample: what the IR cannot compute by itself. Every
/// method has a default, so an `Env` answers only what its stage has; the
/// defaults answer [`NAN`] (a uniform: its declared default, then NaN), so
/// that a leaf nobody supplied shows in the output. Values may be returned
/// in any layout with the components first: the evaluator makes them
/// canonical (splats scalars) and, in `f32` precision, rounds them.
#[allow(unused_variables)]
pub trait Env {
    /// The value of uniform `id` for this object; `None` takes the
    /// uniform's declared default (`uniform g : scalar = 0.25`), else NaN.
    fn uniform(&mut self, id: UniformId) -> Option<Value> {
        None
    }

    /// `δ e` at this sample: node `node` interpolates the per-vertex `value`
    /// (perspective-correct) to frequency `to`. The rasterizer's job: it
    /// evaluates `value` at the triangle's vertices (see
    /// [`Evaluator::interpolants`]) and interpolates.
    fn interpolate(&mut self, node: Handle<Expr>, value: Handle<Expr>, to: Frequency) -> Value {
        NAN
    }

    /// `T e`: the filtered texel of texture `texture` at the evaluated
    /// coordinates (a scalar, vec2, vec3 or, for a 2-D texture indexed by a
    /// screen position, a position: `coords_ty` says which).
    fn lookup(&mut self, texture: TextureId, coords: Value, coords_ty: Ty) -> Value {
        NAN
    }

    /// `C p`, `α C p`, `z C p`, `σ C p`: a channel of framebuffer
    /// `framebuffer` at the evaluated position.
    fn framebuffer(&mut self, framebuffer: FramebufferId, channel: FbChannel, position: Value) -> Value {
        NAN
    }

    /// `δu` of texture shading: the coordinate of the texel being computed.
    fn texel_coord(&mut self) -> Value {
        NAN
    }

    /// `xs` (`freq` screen) or `δ xs` (`freq` fragment): the current pixel.
    fn pixel(&mut self, freq: Frequency) -> Value {
        NAN
    }

    /// Member `member` of the shading-parameter vector stored in the fat
    /// texel of `texture` at `coords` (Pipeline Grammar, eq. (5), (14)).
    fn fat_member(&mut self, texture: TextureId, coords: Value, member: u8) -> Value {
        NAN
    }

    /// The depth of an evaluated position (`z δπx`); its convention is the
    /// one the `Env`'s positions follow.
    fn depth(&mut self, position: Value) -> Value {
        NAN
    }

    // The vertex stage.

    /// `x`: the model-space position of the current vertex of stream `vertex`.
    fn vertex_position(&mut self, vertex: VertexId) -> Value {
        NAN
    }

    /// `u x`: texture-coordinate set `set` of the current vertex.
    fn tex_coord(&mut self, set: TexCoordId, vertex: VertexId) -> Value {
        NAN
    }

    /// A role-declared shading vector (`vector N : normal`) at the current
    /// vertex, or at the current texel for texture shading (`s δu`).
    fn vector(&mut self, vector: VectorId, site: Site) -> Value {
        NAN
    }

    /// `π v`: a projection of an evaluated point (`ty` position) or of a
    /// direction (`ty` vec3, `πR`: sphere-map coordinates, Pipeline Grammar, eq. (7)).
    fn project(&mut self, projection: &Projection, value: Value, ty: Ty) -> Value {
        NAN
    }
}

/// An `Env` that answers nothing: every leaf NaN, uniforms their defaults.
impl Env for () {}

// The arithmetic the evaluator models: `Exact` keeps f64 throughout (the
// reference); otherwise every node's result, leaves included, is rounded to
// f32 — what a float GPU computes (an operation on f32 operands done in f64
// and rounded once is the correctly rounded f32 operation for + − × ÷ √).
// `Fixed9` evaluates as f32 here: the register model's clamps and 9-bit
// rounding happen at register writes, which only the executors know
// (`numerics::fixed9`).
use crate::numerics::Precision;

#[inline]
pub(super) fn round(precision: Precision, v: Value) -> Value {
    if precision.rounds_to_f32() {
        lanes(|i| v[i] as f32 as f64)
    } else {
        v
    }
}

pub(super) const NONE: u32 = u32::MAX;

/// A reachable non-constant node: its operands' slots.
#[derive(Clone, Debug)]
pub(super) struct Step<'m> {
    node: Handle<Expr>,
    expr: &'m Expr,
    ty: Ty,
    slot: u32,
    ops: [u32; 4],
    n_ops: u8,
    /// For a fat member: the texel lookup's texture and coordinate slot.
    fat: Option<(TextureId, u32)>,
}

/// One sample's results: the roots' values, in the order given to
/// [`Evaluator::new`], and whether each root is *discarded* for this sample
/// (it depends on a `c ? a` whose `c` failed: keep the destination).
#[derive(Clone, Copy, Debug)]
pub struct EvalResult<'a> {
    pub values: &'a [Value],
    pub discard: &'a [bool],
}

/// Evaluates the nodes reachable from some roots, one sample at a time,
/// without allocating.
///
/// Built once: the reachable nodes in arena order (operands precede users,
/// so that is a topological order), each with a dense slot; constants are
/// written into their slots once. Reachability stops at `δ`
/// ([`Expr::Interpolate`] is a leaf): the per-vertex side runs in another
/// evaluator, over the vertices.
#[derive(Clone, Debug)]
pub struct Evaluator<'m> {
    module: &'m Module,
    precision: Precision,
    steps: Vec<Step<'m>>,
    slots: Vec<Value>,
    discards: Vec<bool>,
    /// Slot of each arena index, or `NONE`.
    slot_of: Vec<u32>,
    roots: Vec<u32>,
    values: Vec<Value>,
    discard: Vec<bool>,
    /// Some reachable `c ? a` can discard: track discards per slot.
    can_discard: bool,
    interpolants: Vec<(Handle<Expr>, Handle<Expr>)>,
}

impl<'m> Evaluator<'m> {
    pub fn new(module: &'m Module, roots: &[Handle<Expr>], precision: Precision) -> Evaluator<'m> {
        let n = module.exprs.len();
        let mut reach = vec![false; n];
        for r in roots {
            reach[r.index()] = true;
        }
        // Operands precede users: one backward sweep marks everything reachable.
        for i in (0..n).rev() {
            if !reach[i] {
                continue;
            }
            let e = &module.exprs[Handle::new(i)];
            if matches!(e, Expr::Interpolate { .. }) {
                continue;
            }
            for h in e.operands() {
                reach[h.index()] = true;
            }
        }
        let mut slot_of = vec![NONE; n];
        let mut slots = Vec::new();
        let mut steps = Vec::new();
        let mut can_discard = false;
        let mut interpolants = Vec::new();
        for i in (0..n).filter(|&i| reach[i]) {
            let h = Handle::new(i);
            let expr = &module.exprs[h];
            let ty = module.info(h).ty;
            let slot = slots.len() as u32;
            slot_of[i] = slot;
            if let Expr::Constant(c) = expr {
                slots.push(round(precision, value(c)));
                continue;
            }
            slots.push(NAN);
            let mut ops = [NONE; 4];
            let mut n_ops = 0;
            let mut fat = None;
            match expr {
                Expr::Interpolate { value, .. } => interpolants.push((h, *value)),
                Expr::Bundle(_) => {}
                Expr::FatMember { texel, .. } => {
                    if let Expr::Lookup { texture, coords } = &module.exprs[*texel] {
                        fat = Some((*texture, slot_of[coords.index()]));
                    }
                }
                _ => {
                    let operands = expr.operands();
                    assert!(operands.len() <= 4, "an IR computation has at most four operands");
                    for (k, o) in operands.iter().enumerate() {
                        ops[k] = slot_of[o.index()];
                    }
                    n_ops = operands.len() as u8;
                }
            }
            can_discard |= matches!(expr, Expr::Select { reject: None, .. });
            steps.push(Step { node: h, expr, ty, slot, ops, n_ops, fat });
        }
        let n_slots = slots.len();
        let roots: Vec<u32> = roots.iter().map(|r| slot_of[r.index()]).collect();
        Evaluator {
            module,
            precision,
            steps,
            slots,
            discards: vec![false; n_slots],
            slot_of,
            values: vec![NAN; roots.len()],
            discard: vec![false; roots.len()],
            roots,
            can_discard,
            interpolants,
        }
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// The `δ` nodes the roots read, each with the per-vertex value it
    /// interpolates: the roots of the vertex-stage evaluator, and what
    /// [`Env::interpolate`] will be asked for.
    pub fn interpolants(&self) -> &[(Handle<Expr>, Handle<Expr>)] {
        &self.interpolants
    }

    /// Evaluates every reachable node for the sample `env` describes.
    pub fn eval(&mut self, env: &mut impl Env) -> EvalResult<'_> {
        let m = self.module;
        for s in &self.steps {
            let ops = &s.ops[..s.n_ops as usize];
            let v = match s.expr {
                Expr::Uniform(id) => match env.uniform(*id) {
                    Some(v) => v,
                    None => m.uniforms[*id as usize].default.as_ref().map_or(NAN, value),
                },
                Expr::VertexPosition(x) => env.vertex_position(*x),
                Expr::TexCoord { set, vertex } => env.tex_coord(*set, *vertex),
                Expr::Vector { vector, site } => env.vector(*vector, *site),
                Expr::TexelCoord => env.texel_coord(),
                Expr::Pixel { freq } => env.pixel(*freq),
                Expr::Interpolate { value, to } => env.interpolate(s.node, *value, *to),
                Expr::Project { projection, value } => {
                    env.project(projection, self.slots[ops[0] as usize], m.info(*value).ty)
                }
                Expr::Lookup { texture, coords } => {
                    env.lookup(*texture, self.slots[ops[0] as usize], m.info(*coords).ty)
                }
                Expr::FramebufferRead { framebuffer, channel, .. } => {
                    env.framebuffer(*framebuffer, *channel, self.slots[ops[0] as usize])
                }
                Expr::Depth(_) => env.depth(self.slots[ops[0] as usize]),
                Expr::FatMember { member, .. } => match s.fat {
                    Some((texture, coords)) => env.fat_member(texture, self.slots[coords as usize], *member),
                    None => NAN,
                },
                Expr::Bundle(_) | Expr::Constant(_) => NAN,
                e => {
                    let mut buf = [[0.0; 4]; 4];
                    for (b, &o) in buf.iter_mut().zip(ops) {
                        *b = self.slots[o as usize];
                    }
                    apply(m, e, s.ty, &buf[..ops.len()])
                }
            };
            self.slots[s.slot as usize] = round(self.precision, canonical(s.ty, v));
            if self.can_discard {
                // A `c ? a` whose `c` fails discards; a selection passes on
                // only the discards of the branch it takes.
                let d = &self.discards;
                let any = |ops: &[u32]| ops.iter().any(|&o| d[o as usize]);
                let discarded = match s.expr {
                    Expr::Select { .. } => {
                        let cond = self.slots[ops[0] as usize][0] != 0.0;
                        match (cond, ops.len()) {
                            (true, _) => any(&ops[..2]),
                            (false, 2) => true,
                            (false, _) => any(&[ops[0], ops[2]]),
                        }
                    }
                    _ => any(ops),
                };
                self.discards[s.slot as usize] = discarded;
            }
        }
        for (k, &r) in self.roots.iter().enumerate() {
            self.values[k] = self.slots[r as usize];
            self.discard[k] = self.can_discard && self.discards[r as usize];
        }
        EvalResult { values: &self.values, discard: &self.discard }
    }

    /// The value node `h` had in the last [`eval`](Self::eval), if it is
    /// reachable from the roots (the planner reads the values of cut nodes).
    pub fn value(&self, h: Handle<Expr>) -> Option<Value> {
        match self.slot_of.get(h.index()) {
            Some(&s) if s != NONE => Some(self.slots[s as usize]),
            _ => None,
        }
    }

    /// Whether node `h` was discarded in the last [`eval`](Self::eval).
    pub fn discarded(&self, h: Handle<Expr>) -> Option<bool> {
        match self.slot_of.get(h.index()) {
            Some(&s) if s != NONE => Some(self.discards[s as usize]),
            _ => None,
        }
    }

    /// How many nodes one sample evaluates (constants excluded).
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }
}
