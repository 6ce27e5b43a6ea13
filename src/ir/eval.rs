//! The meaning of every IR operation, and an interpreter of IR nodes for one
//! sample (a pixel, texel or vertex) at a time.
//!
//! # One semantics
//!
//! [`apply`] is *the* definition of what a computation node does to its
//! operands' values. Everything that needs numbers from the IR goes through
//! it: the constant folder (`valid::fold`, which keeps only finite results),
//! the [`Evaluator`] (the CPU renderer's `exact` and `f32` shading modes, the
//! pass planner's split-correctness checks, GPU agreement tests). A backend
//! that computes a node differently from `apply` is wrong by definition.
//!
//! # Values
//!
//! A [`Value`] is four `f64` lanes holding `ty.width()` components. A scalar
//! is *splatted* into all four lanes, so componentwise operations broadcast a
//! scalar operand without looking at its type (`kd * max(0, N·L)`: an `rgb`
//! times a scalar); lanes past a vector's width are zero. Every value `apply`
//! and the evaluator produce is in this canonical layout ([`canonical`]),
//! and operands given to `apply` must be too ([`value`] converts a
//! [`Constant`]). Bundles (three components per member, seeds/001 (5)) do not
//! fit in a value: a [`Expr::Bundle`] evaluates to NaN — evaluate its members.
//!
//! # Leaves
//!
//! What the IR cannot compute by itself for the current sample (uniforms,
//! interpolated values, texels, framebuffer pixels, the vertex attributes of
//! the vertex stage) comes from an [`Env`]. `δ e` ([`Expr::Interpolate`]) is
//! a leaf too: the rasterizer interpolates; the per-vertex `e` is evaluated
//! by a second evaluator over the vertices (roots: [`Evaluator::interpolants`]).
//! An unanswered leaf is NaN ([`NAN`]) so that a missing input shows instead
//! of passing for a plausible number.

use super::{
    BinaryOp, Constant, Expr, FbChannel, FramebufferId, Frequency, Handle, MathFunction, Module, Projection, Site,
    TexCoordId, TextureId, Ty, UnaryOp, UniformId, VectorId, VertexId,
};
use crate::parser::ast::CombineMode;

/// The value of a node for one sample: see the module doc for the layout.
pub type Value = [f64; 4];

/// What an unknown leaf, a bundle, a failed `c ? a` or a leaf given to
/// [`apply`] evaluates to.
pub const NAN: Value = [f64::NAN; 4];

/// OpenGL's `GL_TEXTURE_ENV_COLOR`, the constant colour `Cc` of the blend
/// texture environment: (0, 0, 0, 0) by default (OpenGL 1.2.1 §3.8.9), and
/// the notation has no way to set it, so `⊕[blend]` always sees this.
pub const TEXTURE_ENV_COLOR: Value = [0.0; 4];

/// A constant's value in the canonical layout (a scalar splatted).
pub fn value(c: &Constant) -> Value {
    canonical(c.ty, c.components)
}

/// `v` in the canonical layout for `ty`: a scalar's lane 0 splatted, lanes
/// past a vector's width zeroed.
#[inline]
pub fn canonical(ty: Ty, mut v: Value) -> Value {
    match ty.width() {
        1 => [v[0]; 4],
        w @ 2..=4 => {
            for x in &mut v[w..] {
                *x = 0.0;
            }
            v
        }
        _ => NAN,
    }
}

/// Whether `apply` computes `e` from its operands (rather than `e` being a
/// leaf that an [`Env`] supplies).
pub fn is_computation(e: &Expr) -> bool {
    matches!(
        e,
        Expr::Unary { .. }
            | Expr::Binary { .. }
            | Expr::Combine { .. }
            | Expr::Math { .. }
            | Expr::Swizzle { .. }
            | Expr::Compose { .. }
            | Expr::Convert { .. }
            | Expr::Select { .. }
    )
}

#[inline]
fn lanes(f: impl Fn(usize) -> f64) -> Value {
    [f(0), f(1), f(2), f(3)]
}

fn bool(x: bool) -> f64 {
    if x {
        1.0
    } else {
        0.0
    }
}

/// The value of computation node `expr` of type `ty` (its inferred type,
/// `module.info`) given its operands' values, in `expr.operands()` order and
/// in the canonical layout. `module` gives the operands' types where an
/// operation depends on them (a dot product's width, `rgb` → `rgba`).
///
/// Semantics, in f64 (the [`Evaluator`] rounds afterwards for `f32`):
///
/// - Arithmetic, `^` and the built-in functions componentwise, scalars
///   broadcast; `a · b` sums over the operands' width (of two scalars: their
///   product). `expand(x) = 2x − 1`, `half_bias(x) = x − ½` and
///   `compress(x) = (x + 1)/2` are the register-combiner range mappings of
///   seeds/003 Table 3 (`GL_EXPAND_NORMAL`, `GL_HALF_BIAS_NORMAL`) and their
///   inverse, the range compression of seeds/003 Section 5.3.
///   `step(e, x) = x < e ? 0 : 1`, `smoothstep(e0, e1, x)` and
///   `mix(a, b, t) = a(1 − t) + bt` as in GLSL; `cross(a, b)` the cross
///   product and `reflect(I, N) = I − 2(N·I)N` as GLSL's (N unit).
/// - Comparisons and `∧ ∨ not` give 0 or 1; any nonzero value is true.
/// - `c ? a : b` is `a` where `c ≠ 0`, else `b`. `c ? a` (no `b`) keeps the
///   destination where `c = 0` (the shadow-volume pass, seeds/001 Section
///   3.5): that is not a value, so `apply` gives [`NAN`] and the
///   [`Evaluator`] reports the sample as discarded.
/// - Swizzles select lanes, `(a, b, …)` concatenates, `rgb` → `rgba` sets
///   alpha 1, a scalar converted to a vector is splatted.
/// - `⊕` modes: see [`combine`].
///
/// Leaves (`Constant`, `Uniform`, lookups, `δ`, …) and bundles give
/// [`NAN`]: their values come from an [`Env`].
pub fn apply(module: &Module, expr: &Expr, ty: Ty, operands: &[Value]) -> Value {
    let o = operands;
    let v = match expr {
        Expr::Unary { op, .. } => match op {
            UnaryOp::Neg => lanes(|i| -o[0][i]),
            UnaryOp::Not => [bool(o[0][0] == 0.0); 4],
        },
        Expr::Binary { op, lhs, .. } => {
            let (a, b) = (o[0], o[1]);
            use BinaryOp::*;
            match op {
                Dot => [dot(&a, &b, module.info(*lhs).ty.width()); 4],
                Add => lanes(|i| a[i] + b[i]),
                Sub => lanes(|i| a[i] - b[i]),
                Mul => lanes(|i| a[i] * b[i]),
                Div => lanes(|i| a[i] / b[i]),
                Pow => lanes(|i| a[i].powf(b[i])),
                Lt => [bool(a[0] < b[0]); 4],
                Le => [bool(a[0] <= b[0]); 4],
                Gt => [bool(a[0] > b[0]); 4],
                Ge => [bool(a[0] >= b[0]); 4],
                Eq => [bool(a[0] == b[0]); 4],
                Ne => [bool(a[0] != b[0]); 4],
                And => [bool(a[0] != 0.0 && b[0] != 0.0); 4],
                Or => [bool(a[0] != 0.0 || b[0] != 0.0); 4],
            }
        }
        Expr::Combine { mode, lhs, .. } => {
            // An rgb texture widened to rgba (alpha 1) by lowering has no alpha of its own.
            let lhs_rgb = matches!(&module.exprs[*lhs], Expr::Convert { value, to: Ty::Rgba } if module.info(*value).ty == Ty::Rgb);
            combine(*mode, ty.width(), &o[0], &o[1], lhs_rgb)
        }
        Expr::Math { fun, args } => math(module, *fun, args, ty, o),
        Expr::Swizzle { pattern, len, .. } => {
            let mut v = [0.0; 4];
            for (k, &i) in pattern[..*len as usize].iter().enumerate() {
                v[k] = o[0][i as usize & 3];
            }
            v
        }
        Expr::Compose { components, .. } => {
            let mut v = [0.0; 4];
            let mut k = 0;
            for (h, c) in components.iter().zip(o) {
                for &x in &c[..module.info(*h).ty.width().min(4)] {
                    if k < 4 {
                        v[k] = x;
                    }
                    k += 1;
                }
            }
            v
        }
        Expr::Convert { value, to } => {
            if module.info(*value).ty == Ty::Rgb && *to == Ty::Rgba {
                [o[0][0], o[0][1], o[0][2], 1.0]
            } else {
                o[0]
            }
        }
        Expr::Select { reject, .. } => {
            if o[0][0] != 0.0 {
                o[1]
            } else if reject.is_some() {
                o[2]
            } else {
                NAN
            }
        }
        _ => NAN,
    };
    canonical(ty, v)
}

#[inline]
fn dot(a: &Value, b: &Value, width: usize) -> f64 {
    (0..width.min(4)).map(|i| a[i] * b[i]).sum()
}

fn math(module: &Module, fun: MathFunction, args: &[Handle<Expr>], ty: Ty, o: &[Value]) -> Value {
    use MathFunction::*;
    let a = o[0];
    let f1 = |f: fn(f64) -> f64| lanes(|i| f(a[i]));
    match fun {
        Normalize => {
            let n = dot(&a, &a, ty.width()).sqrt();
            lanes(|i| a[i] / n)
        }
        Length => [dot(&a, &a, module.info(args[0]).ty.width()).sqrt(); 4],
        Cross => {
            let b = o[1];
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0], 0.0]
        }
        Reflect => {
            // GLSL reflect(I, N) = I − 2·dot(N, I)·N.
            let n = o[1];
            let d = dot(&n, &a, 3);
            lanes(|i| a[i] - 2.0 * d * n[i])
        }
        Max => lanes(|i| a[i].max(o[1][i])),
        Min => lanes(|i| a[i].min(o[1][i])),
        Clamp => lanes(|i| a[i].max(o[1][i]).min(o[2][i])),
        Saturate => f1(|x| x.clamp(0.0, 1.0)),
        Abs => f1(f64::abs),
        Sign => f1(f64::signum),
        Sqrt => f1(f64::sqrt),
        Rsqrt => f1(|x| 1.0 / x.sqrt()),
        Exp => f1(f64::exp),
        Log => f1(f64::ln),
        Sin => f1(f64::sin),
        Cos => f1(f64::cos),
        Floor => f1(f64::floor),
        Fract => f1(|x| x - x.floor()),
        Expand => f1(|x| 2.0 * x - 1.0),
        HalfBias => f1(|x| x - 0.5),
        Compress => f1(|x| (x + 1.0) / 2.0),
        Step => lanes(|i| if o[1][i] < a[i] { 0.0 } else { 1.0 }),
        Mix => lanes(|i| a[i] * (1.0 - o[2][i]) + o[1][i] * o[2][i]),
        Smoothstep => lanes(|i| {
            let t = ((o[2][i] - a[i]) / (o[1][i] - a[i])).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }),
    }
}

/// `t ⊕[mode] f`: OpenGL 1.2.1's texture environment (§3.8.9, Table 3.22)
/// and ARB_texture_env_combine, on values of `width` 1 (a scalar: one colour
/// channel), 3 (`rgb`) or 4 (`rgba`, alpha in lane 3).
///
/// **Which operand is the texture.** seeds/001 (12) writes chained
/// multitexturing as `C δπx ← T‴ δu‴ x ⊕ (T″ δu″ x ⊕ (T′ δu′ x ⊕ T δu x))`:
/// each texture unit applies its texture over the colour coming from the
/// units before it, so the **left operand is the texture** (`Ct`, `At`) and
/// the **right operand the incoming fragment colour** (`Cf`, `Af`). For the
/// symmetric modes this does not matter; for `decal`, `blend`, `replace`,
/// `interpolate` and `subtract` it does.
///
/// | mode | colour | alpha (rgba) |
/// |---|---|---|
/// | `modulate` (default) | `Ct·Cf` | `At·Af` |
/// | `add` | `Ct + Cf` | `At + Af` |
/// | `add_signed` | `Ct + Cf − ½` | `At + Af − ½` |
/// | `subtract` | `Ct − Cf` | `At − Af` |
/// | `decal` | `Cf(1 − At) + Ct·At` | `Af` |
/// | `blend` | `Cf(1 − Ct) + Cc·Ct` | `Af·At` |
/// | `replace` | `Ct` | `At` (`Af` for an rgb texture) |
/// | `interpolate` | `Ct·At + Cf(1 − At)` | `At·At + Af(1 − At)` |
/// | `dot3_rgb` | `4((Ct − ½)·(Cf − ½))` in r, g, b | `At·Af` |
/// | `dot3_rgba` | `4((Ct − ½)·(Cf − ½))` in r, g, b, a | |
///
/// - `add`, `add_signed`, `subtract` are the combine extension's functions
///   with the same function for `COMBINE_RGB` and `COMBINE_ALPHA` (so
///   alpha adds; the older `GL_ADD` environment multiplies alphas). That is
///   also what framebuffer blending `C ← C ⊕[add] …` (`glBlendFunc(ONE,
///   ONE)`) does to alpha.
/// - `Cc` is [`TEXTURE_ENV_COLOR`], GL's default (0, 0, 0, 0): `blend`
///   gives `Cf(1 − Ct)`, the texture as an opacity darkening the fragment.
/// - A texture without alpha (an `rgb` operand, or one lowering widened to
///   `rgba` with alpha 1) has `At = 1`, so `decal` and `interpolate` give
///   `Ct`; for `replace`, `lhs_rgb` says the texture was widened and GL's
///   RGB base format keeps `Af`.
/// - `interpolate` is the combine extension's `Arg0·Arg2 + Arg1(1 − Arg2)`
///   with `Arg0 = Ct`, `Arg1 = Cf` and `Arg2 = At` (source texture, operand
///   `SRC_ALPHA`): GL's default third source is the constant colour, whose
///   alpha 0 would make the mode return `Cf` unchanged, and ⊕ has only two
///   operands.
/// - `dot3` (ARB_texture_env_dot3) sums over r, g, b only and splats the
///   result; for `dot3_rgb` the alpha function is the default `MODULATE`.
///   Of two scalars it is `4(t − ½)(f − ½)`.
///
/// Results are **not clamped** to [0, 1] here, although GL clamps every
/// texture-environment result: clamping belongs to the hardware model (the
/// combiner emulator, an 8-bit framebuffer), so that the planner can see the
/// exact value a split would have to store.
pub fn combine(mode: CombineMode, width: usize, t: &Value, f: &Value, lhs_rgb: bool) -> Value {
    let has_alpha = width == 4;
    let at = if has_alpha { t[3] } else { 1.0 };
    let cc = TEXTURE_ENV_COLOR;
    let with_alpha = |rgb: Value, alpha: f64| if has_alpha { [rgb[0], rgb[1], rgb[2], alpha] } else { rgb };
    let dot3 = || {
        if width == 1 {
            4.0 * (t[0] - 0.5) * (f[0] - 0.5)
        } else {
            4.0 * (0..3).map(|i| (t[i] - 0.5) * (f[i] - 0.5)).sum::<f64>()
        }
    };
    match mode {
        CombineMode::Modulate => lanes(|i| t[i] * f[i]),
        CombineMode::Add => lanes(|i| t[i] + f[i]),
        CombineMode::AddSigned => lanes(|i| t[i] + f[i] - 0.5),
        CombineMode::Subtract => lanes(|i| t[i] - f[i]),
        CombineMode::Decal => with_alpha(lanes(|i| f[i] * (1.0 - at) + t[i] * at), f[3]),
        CombineMode::Blend => with_alpha(lanes(|i| f[i] * (1.0 - t[i]) + cc[i] * t[i]), t[3] * f[3]),
        CombineMode::Replace => with_alpha(*t, if lhs_rgb { f[3] } else { t[3] }),
        CombineMode::Interpolate => lanes(|i| t[i] * at + f[i] * (1.0 - at)),
        CombineMode::Dot3Rgb => with_alpha([dot3(); 4], t[3] * f[3]),
        CombineMode::Dot3Rgba => [dot3(); 4],
    }
}

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
    /// texel of `texture` at `coords` (seeds/001 (5), (14)).
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
    /// direction (`ty` vec3, `πR`: sphere-map coordinates, seeds/001 (7)).
    fn project(&mut self, projection: &Projection, value: Value, ty: Ty) -> Value {
        NAN
    }
}

/// An `Env` that answers nothing: every leaf NaN, uniforms their defaults.
impl Env for () {}

/// The arithmetic the evaluator models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Precision {
    /// f64 throughout: the reference.
    #[default]
    Exact,
    /// Every node's result, leaves included, rounded to f32: what a float
    /// GPU computes (an operation on f32 operands done in f64 and rounded
    /// once is the correctly rounded f32 operation for + − × ÷ √).
    F32,
}

#[inline]
fn round(precision: Precision, v: Value) -> Value {
    match precision {
        Precision::Exact => v,
        Precision::F32 => lanes(|i| v[i] as f32 as f64),
    }
}

const NONE: u32 = u32::MAX;

/// A reachable non-constant node: its operands' slots.
#[derive(Clone, Debug)]
struct Step<'m> {
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
                Expr::Lookup { texture, coords } => env.lookup(*texture, self.slots[ops[0] as usize], m.info(*coords).ty),
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
