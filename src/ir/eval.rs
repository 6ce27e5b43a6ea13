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
//! [`Constant`]). Bundles (three components per member, Pipeline Grammar, eq. (5)) do not
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
    BinaryOp, Constant, Expr, FbChannel, FramebufferId, Frequency, Handle, MathFunction, Module, Projection,
    Site, TexCoordId, TextureId, Ty, UnaryOp, UniformId, VectorId, VertexId,
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
///   Kilgard 2000, Table 3 (`GL_EXPAND_NORMAL`, `GL_HALF_BIAS_NORMAL`) and their
///   inverse, the range compression of Kilgard 2000, Section 5.3.
///   `step(e, x) = x < e ? 0 : 1`, `smoothstep(e0, e1, x)` and
///   `mix(a, b, t) = a(1 − t) + bt` as in GLSL; `cross(a, b)` the cross
///   product and `reflect(I, N) = I − 2(N·I)N` as GLSL's (N unit).
/// - Comparisons and `∧ ∨ not` give 0 or 1; any nonzero value is true.
/// - `c ? a : b` is `a` where `c ≠ 0`, else `b`. `c ? a` (no `b`) keeps the
///   destination where `c = 0` (the shadow-volume pass, Pipeline Grammar, Section
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
            // normalize(0) has no direction. GLSL leaves it undefined (NaN on
            // most GPUs); we define it as the zero vector, as glam's
            // `normalize_or_zero` in the scene binder does: every dot product
            // with it is 0, so a zero-length interpolated normal and the half
            // vector of L = −V (seeds/003 Eq. 16, H = (L + V)/|L + V|) light
            // nothing — what GL's lighting gives there, since its specular
            // term is 0 wherever N·L ≤ 0. docs/numerics.md lists the cases.
            let n = dot(&a, &a, ty.width()).sqrt();
            if n == 0.0 {
                return [0.0; 4];
            }
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
/// **Which operand is the texture.** Pipeline Grammar, eq. (12) writes chained
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
fn round(precision: Precision, v: Value) -> Value {
    if precision.rounds_to_f32() {
        lanes(|i| v[i] as f32 as f64)
    } else {
        v
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{valid, FbChannel, Statement, Uniform};
    use crate::span::Span;
    use proptest::prelude::*;

    fn node(m: &mut Module, e: Expr) -> Handle<Expr> {
        let info = valid::infer(m, &e).unwrap_or_else(|err| panic!("{e:?}: {err:?}"));
        let (h, new) = m.exprs.insert(e, Span::DETACHED);
        if new {
            m.info.push(info);
        }
        h
    }

    fn k(m: &mut Module, ty: Ty, v: &[f64]) -> Handle<Expr> {
        node(m, Expr::Constant(Constant::new(ty, v)))
    }

    fn uniform(m: &mut Module, name: &str, ty: Ty) -> Handle<Expr> {
        m.uniforms.push(Uniform { name: name.into(), ty, default: None, span: Span::DETACHED });
        node(m, Expr::Uniform(m.uniforms.len() as u32 - 1))
    }

    /// `apply` on a node whose operands are constants, and what `fold` makes of it.
    fn ap(m: &Module, e: &Expr) -> (Value, Option<Constant>) {
        let ty = valid::infer(m, e).unwrap().ty;
        let ops: Vec<Value> = e
            .operands()
            .iter()
            .map(|h| match &m.exprs[*h] {
                Expr::Constant(c) => value(c),
                _ => panic!("not a constant"),
            })
            .collect();
        (apply(m, e, ty, &ops), valid::fold(m, e, ty))
    }

    #[track_caller]
    fn close(a: &[f64], b: &[f64]) {
        assert_eq!(a.len(), b.len(), "{a:?} vs {b:?}");
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() < 1e-12, "{a:?} vs {b:?}");
        }
    }

    /// `apply`'s value, checked against `fold`'s constant (which must exist).
    #[track_caller]
    fn folds(m: &Module, e: Expr, want: &[f64]) {
        let (v, c) = ap(m, &e);
        close(&v[..want.len()], want);
        let c = c.unwrap_or_else(|| panic!("{e:?} does not fold"));
        close(c.values(), want);
    }

    fn math(fun: MathFunction, args: &[Handle<Expr>]) -> Expr {
        Expr::Math { fun, args: args.to_vec() }
    }

    #[test]
    fn range_mappings_of_seeds_003_table_3() {
        let mut m = Module::default();
        let x = k(&mut m, Ty::Scalar, &[0.75]);
        folds(&m, math(MathFunction::Expand, &[x]), &[0.5]);
        folds(&m, math(MathFunction::HalfBias, &[x]), &[0.25]);
        folds(&m, math(MathFunction::Compress, &[x]), &[0.875]);
        let c = k(&mut m, Ty::Rgb, &[0.0, 0.5, 1.0]);
        folds(&m, math(MathFunction::Expand, &[c]), &[-1.0, 0.0, 1.0]);
    }

    #[test]
    fn arithmetic_broadcasts_scalars_and_dot_sums_the_width() {
        let mut m = Module::default();
        let kd = k(&mut m, Ty::Rgb, &[0.8, 0.6, 0.4]);
        let half = k(&mut m, Ty::Scalar, &[0.5]);
        let two = k(&mut m, Ty::Scalar, &[2.0]);
        folds(&m, Expr::Binary { op: BinaryOp::Mul, lhs: kd, rhs: half }, &[0.4, 0.3, 0.2]);
        folds(&m, Expr::Binary { op: BinaryOp::Sub, lhs: half, rhs: kd }, &[-0.3, -0.1, 0.1]);
        folds(&m, Expr::Binary { op: BinaryOp::Pow, lhs: kd, rhs: two }, &[0.64, 0.36, 0.16]);
        folds(&m, Expr::Binary { op: BinaryOp::Dot, lhs: kd, rhs: kd }, &[0.64 + 0.36 + 0.16]);
        folds(&m, Expr::Binary { op: BinaryOp::Dot, lhs: half, rhs: two }, &[1.0]);
        folds(&m, Expr::Unary { op: UnaryOp::Neg, value: kd }, &[-0.8, -0.6, -0.4]);
        folds(&m, math(MathFunction::Max, &[half, kd]), &[0.8, 0.6, 0.5]);
        let hi = k(&mut m, Ty::Scalar, &[0.7]);
        folds(&m, math(MathFunction::Clamp, &[kd, half, hi]), &[0.7, 0.6, 0.5]);
        folds(&m, math(MathFunction::Mix, &[kd, half, half]), &[0.65, 0.55, 0.45]);
        folds(&m, math(MathFunction::Step, &[half, kd]), &[1.0, 1.0, 0.0]);
        let v = k(&mut m, Ty::Vec3, &[3.0, 0.0, 4.0]);
        folds(&m, math(MathFunction::Length, &[v]), &[5.0]);
        folds(&m, math(MathFunction::Normalize, &[v]), &[0.6, 0.0, 0.8]);
        // A scalar result is splatted in every lane (the layout of `Value`).
        let (d, _) = ap(&m, &math(MathFunction::Length, &[v]));
        assert_eq!(d, [5.0; 4]);
        // 1/0 is an operation, not a constant: fold keeps only finite results.
        let zero = k(&mut m, Ty::Scalar, &[0.0]);
        let (inf, c) = ap(&m, &Expr::Binary { op: BinaryOp::Div, lhs: two, rhs: zero });
        assert_eq!((inf[0], c), (f64::INFINITY, None));
    }

    #[test]
    fn cross_and_glsl_reflect() {
        let mut m = Module::default();
        let x = k(&mut m, Ty::Vec3, &[1.0, 0.0, 0.0]);
        let y = k(&mut m, Ty::Vec3, &[0.0, 1.0, 0.0]);
        folds(&m, math(MathFunction::Cross, &[x, y]), &[0.0, 0.0, 1.0]);
        folds(&m, math(MathFunction::Cross, &[y, x]), &[0.0, 0.0, -1.0]);
        // reflect(I, N) = I − 2(N·I)N: a ray going down bounces up off a floor.
        let i = k(&mut m, Ty::Vec3, &[1.0, -1.0, 0.5]);
        folds(&m, math(MathFunction::Reflect, &[i, y]), &[1.0, 1.0, 0.5]);
        let n = k(&mut m, Ty::Vec3, &[0.6, 0.8, 0.0]);
        let d = 0.6 - 0.8;
        folds(&m, math(MathFunction::Reflect, &[i, n]), &[1.0 - 2.0 * d * 0.6, -1.0 - 2.0 * d * 0.8, 0.5]);
    }

    #[test]
    fn comparisons_logic_and_selection_are_zero_or_one() {
        let mut m = Module::default();
        let a = k(&mut m, Ty::Scalar, &[0.25]);
        let b = k(&mut m, Ty::Scalar, &[0.75]);
        let zero = k(&mut m, Ty::Scalar, &[0.0]);
        for (op, want) in [
            (BinaryOp::Lt, 1.0),
            (BinaryOp::Le, 1.0),
            (BinaryOp::Gt, 0.0),
            (BinaryOp::Ge, 0.0),
            (BinaryOp::Eq, 0.0),
            (BinaryOp::Ne, 1.0),
            (BinaryOp::And, 1.0),
            (BinaryOp::Or, 1.0),
        ] {
            folds(&m, Expr::Binary { op, lhs: a, rhs: b }, &[want]);
        }
        folds(&m, Expr::Binary { op: BinaryOp::And, lhs: a, rhs: zero }, &[0.0]);
        folds(&m, Expr::Unary { op: UnaryOp::Not, value: zero }, &[1.0]);
        folds(&m, Expr::Unary { op: UnaryOp::Not, value: b }, &[0.0]);
        let c = k(&mut m, Ty::Rgb, &[0.1, 0.2, 0.3]);
        folds(&m, Expr::Select { cond: a, accept: c, reject: Some(b) }, &[0.1, 0.2, 0.3]);
        folds(&m, Expr::Select { cond: zero, accept: c, reject: Some(b) }, &[0.75, 0.75, 0.75]);
        // `c ? a` keeps the destination where c fails: no value, and never folded.
        let (v, f) = ap(&m, &Expr::Select { cond: zero, accept: c, reject: None });
        assert!(v[..3].iter().all(|x| x.is_nan()) && f.is_none());
        let (v, f) = ap(&m, &Expr::Select { cond: a, accept: c, reject: None });
        close(&v[..3], &[0.1, 0.2, 0.3]);
        assert!(f.is_none());
    }

    #[test]
    fn normalize_of_zero_is_zero() {
        // docs/numerics.md: the half vector of L = −V, a zero-length normal.
        let m = Module::default();
        let h = Handle::new(0);
        assert_eq!(super::math(&m, MathFunction::Normalize, &[h], Ty::Vec3, &[[0.0; 4]]), [0.0; 4]);
        let v = super::math(&m, MathFunction::Normalize, &[h], Ty::Vec3, &[[3.0, 0.0, 4.0, 0.0]]);
        close(&v[..3], &[0.6, 0.0, 0.8]);
    }

    #[test]
    fn swizzle_compose_convert() {
        let mut m = Module::default();
        let c = k(&mut m, Ty::Rgba, &[0.1, 0.2, 0.3, 0.4]);
        let s = k(&mut m, Ty::Scalar, &[0.5]);
        folds(&m, Expr::Swizzle { value: c, pattern: [3, 2, 0, 0], len: 2, ty: Ty::Vec2 }, &[0.4, 0.3]);
        folds(&m, Expr::Swizzle { value: c, pattern: [3, 0, 0, 0], len: 1, ty: Ty::Scalar }, &[0.4]);
        let rgb = k(&mut m, Ty::Rgb, &[0.1, 0.2, 0.3]);
        folds(&m, Expr::Compose { ty: Ty::Rgba, components: vec![rgb, s] }, &[0.1, 0.2, 0.3, 0.5]);
        folds(&m, Expr::Compose { ty: Ty::Vec3, components: vec![s, s, s] }, &[0.5, 0.5, 0.5]);
        folds(&m, Expr::Convert { value: rgb, to: Ty::Rgba }, &[0.1, 0.2, 0.3, 1.0]);
        folds(&m, Expr::Convert { value: s, to: Ty::Rgb }, &[0.5, 0.5, 0.5]);
    }

    #[test]
    fn combine_modes_follow_the_texture_environment() {
        use CombineMode::*;
        let mut m = Module::default();
        // Left: the texture (Ct, At); right: the incoming fragment (Cf, Af).
        let t = k(&mut m, Ty::Rgba, &[0.2, 0.4, 0.6, 0.25]);
        let f = k(&mut m, Ty::Rgba, &[1.0, 0.8, 0.4, 0.5]);
        let comb = |mode| Expr::Combine { mode, lhs: t, rhs: f };
        folds(&m, comb(Modulate), &[0.2, 0.32, 0.24, 0.125]);
        folds(&m, comb(Add), &[1.2, 1.2, 1.0, 0.75]);
        folds(&m, comb(AddSigned), &[0.7, 0.7, 0.5, 0.25]);
        folds(&m, comb(Subtract), &[-0.8, -0.4, 0.2, -0.25]);
        // decal: Cf(1 − At) + Ct·At, Af.
        folds(&m, comb(Decal), &[0.8, 0.7, 0.45, 0.5]);
        // blend: Cf(1 − Ct) + Cc·Ct with GL's default Cc = 0; Af·At.
        folds(&m, comb(Blend), &[0.8, 0.48, 0.16, 0.125]);
        folds(&m, comb(Replace), &[0.2, 0.4, 0.6, 0.25]);
        // interpolate: Ct·At + Cf(1 − At), in every lane.
        folds(&m, comb(Interpolate), &[0.8, 0.7, 0.45, 0.25 * 0.25 + 0.5 * 0.75]);
        // dot3: 4((Ct − ½)·(Cf − ½)) over r, g, b, splatted; dot3_rgb keeps At·Af.
        let d = 4.0 * (-0.3 * 0.5 + -0.1 * 0.3 + 0.1 * -0.1);
        folds(&m, comb(Dot3Rgb), &[d, d, d, 0.125]);
        folds(&m, comb(Dot3Rgba), &[d, d, d, d]);
        let t3 = k(&mut m, Ty::Rgb, &[1.0, 0.5, 0.75]);
        let f3 = k(&mut m, Ty::Rgb, &[1.0, 1.0, 0.25]);
        folds(&m, Expr::Combine { mode: Dot3Rgb, lhs: t3, rhs: f3 }, &[0.75, 0.75, 0.75]);
        // No alpha: At = 1, so decal and interpolate give the texture.
        folds(&m, Expr::Combine { mode: Decal, lhs: t3, rhs: f3 }, &[1.0, 0.5, 0.75]);
        folds(&m, Expr::Combine { mode: Interpolate, lhs: t3, rhs: f3 }, &[1.0, 0.5, 0.75]);
        // replace with an rgb texture widened to rgba keeps the fragment's alpha (GL's RGB base format).
        // (A constant would fold to an rgba constant first: take an rgb texel, here a uniform.)
        let texel = uniform(&mut m, "texel", Ty::Rgb);
        let wide = node(&mut m, Expr::Convert { value: texel, to: Ty::Rgba });
        let t1 = [1.0, 0.5, 0.75, 1.0];
        let fv = [1.0, 0.8, 0.4, 0.5];
        for (mode, want) in [
            (Replace, [1.0, 0.5, 0.75, 0.5]),
            (Decal, [1.0, 0.5, 0.75, 0.5]),
            (Modulate, [1.0, 0.4, 0.3, 0.5]),
        ] {
            let v = apply(&m, &Expr::Combine { mode, lhs: wide, rhs: f }, Ty::Rgba, &[t1, fv]);
            close(&v, &want);
        }
        let v = apply(&m, &Expr::Combine { mode: Replace, lhs: t, rhs: f }, Ty::Rgba, &[t1, fv]);
        close(&v, &t1);
        // A scalar broadcasts (Kilgard's `C ⊕[add] (α C) * specular`); results are not clamped.
        let s = k(&mut m, Ty::Scalar, &[0.75]);
        folds(&m, Expr::Combine { mode: Add, lhs: f, rhs: s }, &[1.75, 1.55, 1.15, 1.25]);
    }

    #[test]
    fn select_without_reject_discards_per_root() {
        let mut m = Module::default();
        let c = uniform(&mut m, "c", Ty::Scalar);
        let a = uniform(&mut m, "a", Ty::Rgb);
        let b = k(&mut m, Ty::Rgb, &[0.0, 0.0, 1.0]);
        let keep = node(&mut m, Expr::Select { cond: c, accept: a, reject: None });
        let not_c = node(&mut m, Expr::Unary { op: UnaryOp::Not, value: c });
        // Takes `keep` only where c holds, so never discards.
        let guarded = node(&mut m, Expr::Select { cond: not_c, accept: b, reject: Some(keep) });
        let sum = node(&mut m, Expr::Binary { op: BinaryOp::Add, lhs: keep, rhs: b });
        let mut ev = Evaluator::new(&m, &[keep, guarded, sum, b], Precision::Exact);
        struct U(f64);
        impl Env for U {
            fn uniform(&mut self, id: UniformId) -> Option<Value> {
                Some(if id == 0 { [self.0, 0.0, 0.0, 0.0] } else { [0.1, 0.2, 0.3, 0.0] })
            }
        }
        let r = ev.eval(&mut U(1.0));
        assert_eq!(r.discard, &[false, false, false, false]);
        close(&r.values[0][..3], &[0.1, 0.2, 0.3]);
        close(&r.values[2][..3], &[0.1, 0.2, 1.3]);
        let r = ev.eval(&mut U(0.0));
        assert_eq!(r.discard, &[true, false, true, false]);
        assert!(r.values[0][0].is_nan());
        close(&r.values[1][..3], &[0.0, 0.0, 1.0]);
        assert_eq!(ev.discarded(keep), Some(true));
        assert_eq!(ev.value(c), Some([0.0; 4]), "scalars are splatted");
    }

    #[test]
    fn unanswered_leaves_are_nan_and_uniforms_default() {
        let (program, d) = crate::parser::check("uniform g : scalar = 0.25;\ntexture T : 2d rgba8;\nframebuffer C : rgba8;\nC δπx ← (T δu x) * g;\n");
        assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
        let (m, d) = crate::ir::lower(&program);
        assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
        let g = m.exprs.find(&Expr::Uniform(0)).unwrap();
        let mut ev = Evaluator::new(&m, &[m.statements[0].value, g], Precision::Exact);
        let r = ev.eval(&mut ());
        assert!(r.values[0].iter().all(|x| x.is_nan()));
        assert_eq!(r.values[1], [0.25; 4]);
        // Only the fragment side is reachable: δ stops the walk.
        assert_eq!(ev.interpolants().len(), 1);
        assert!(matches!(m.exprs[ev.interpolants()[0].1], Expr::TexCoord { .. }));
        assert_eq!(ev.value(ev.interpolants()[0].1), None);
    }

    fn kilgard() -> Module {
        let src = include_str!("../../examples/kilgard_bump_mapping.shd");
        let (program, d) = crate::parser::check(src);
        assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
        let (m, d) = crate::ir::lower(&program);
        assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
        m
    }

    fn normalize(v: [f64; 3]) -> [f64; 3] {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / n, v[1] / n, v[2] / n]
    }

    /// One fragment of Kilgard's passes: L and H interpolated, the
    /// normalization cube map, a normal-map texel, the framebuffer.
    struct Fragment<'m> {
        m: &'m Module,
        l: [f64; 3],
        h: [f64; 3],
        normal_texel: Value,
        c: Value,
        /// Round every input to f32 (so both precisions see the same inputs).
        f32_inputs: bool,
    }

    impl Fragment<'_> {
        fn input(&self, v: Value) -> Value {
            if self.f32_inputs {
                v.map(|x| x as f32 as f64)
            } else {
                v
            }
        }
    }

    impl Env for Fragment<'_> {
        fn interpolate(&mut self, _node: Handle<Expr>, value: Handle<Expr>, _to: Frequency) -> Value {
            let v = match &self.m.exprs[value] {
                Expr::Vector { vector, .. } => match self.m.vectors[*vector as usize].name.as_str() {
                    "L" => [self.l[0], self.l[1], self.l[2], 0.0],
                    "H" => [self.h[0], self.h[1], self.h[2], 0.0],
                    _ => NAN,
                },
                Expr::TexCoord { .. } => [0.25, 0.75, 0.0, 0.0],
                Expr::Project { .. } => [10.0, 20.0, 0.5, 1.0],
                _ => NAN,
            };
            self.input(v)
        }

        fn lookup(&mut self, texture: TextureId, coords: Value, _: Ty) -> Value {
            let v = match self.m.textures[texture as usize].name.as_str() {
                // A normalization cube map: the range-compressed direction (seeds/003 App. D).
                "Ncube" => {
                    let n = normalize([coords[0], coords[1], coords[2]]);
                    [(n[0] + 1.0) / 2.0, (n[1] + 1.0) / 2.0, (n[2] + 1.0) / 2.0, 0.0]
                }
                "Tn" => self.normal_texel,
                "Tdecal" => [0.2, 0.4, 0.6, 1.0],
                _ => NAN,
            };
            self.input(v)
        }

        fn framebuffer(&mut self, _: FramebufferId, channel: FbChannel, position: Value) -> Value {
            assert_eq!(position, [10.0, 20.0, 0.5, 1.0]);
            match channel {
                FbChannel::Color => self.input(self.c),
                FbChannel::Alpha => [self.input(self.c)[3]; 4],
                _ => NAN,
            }
        }
    }

    fn roots(m: &Module) -> Vec<Handle<Expr>> {
        m.statements.iter().map(|s: &Statement| s.value).collect()
    }

    #[test]
    fn kilgard_diffuse_and_specular_by_hand() {
        let m = kilgard();
        let roots = roots(&m);
        // Pass 2's value is C ⊕ rgba(diffuse, s_self): find the diffuse term.
        let Expr::Combine { rhs, .. } = m.exprs[roots[1]] else { panic!("pass 2 is a combine") };
        let Expr::Compose { components, .. } = &m.exprs[rhs] else { panic!("rgba(diffuse, s_self)") };
        let diffuse = components[0];
        let mut ev = Evaluator::new(&m, &roots, Precision::Exact);
        let mut env = Fragment {
            m: &m,
            l: [0.99f64.sqrt(), 0.0, 0.1],
            h: [0.0, 0.6, 0.8],
            // N′ = (0.6, 0, 0.8), range-compressed; denormalization factor ½.
            normal_texel: [0.8, 0.5, 0.9, 0.5],
            c: [0.5, 0.5, 0.5, 1.0],
            f32_inputs: false,
        };
        let r = ev.eval(&mut env);
        assert_eq!(r.discard, &[false; 3]);
        close(&r.values[0], &[0.2, 0.4, 0.6, 1.0]);
        // s_self = saturate(8 Lz) = 0.8; L·N′ = 0.6 √0.99 + 0.08;
        // diffuse = Iambient + Kdiffuse · s_self · max(0, L·N′) · N′.a.
        let s_self = 0.8;
        let ln = 0.6 * 0.99f64.sqrt() + 0.8 * 0.1;
        let want: Vec<f64> = [0.9, 1.0, 1.0].iter().map(|kd| 0.1 + kd * s_self * ln * 0.5).collect();
        let values = r.values.to_vec();
        close(&ev.value(diffuse).unwrap()[..3], &want);
        // Modulated into the framebuffer (0.5, 0.5, 0.5, 1), s_self into alpha.
        close(&values[1], &[0.5 * want[0], 0.5 * want[1], 0.5 * want[2], s_self]);
        // Pass 3: Hz ≥ 0, so C + (α C) · max(0, H·N′)^8 with H·N′ = 0.64.
        let spec = 0.64f64.powi(8);
        close(&values[2], &[0.5 + spec, 0.5 + spec, 0.5 + spec, 1.0 + spec]);
        // Hz < 0: the specular term is forced to zero (Appendix H's mux).
        env.h = [0.0, 0.6, -0.8];
        let r = ev.eval(&mut env);
        close(&r.values[2], &[0.5, 0.5, 0.5, 1.0]);
    }

    fn unit() -> impl Strategy<Value = f64> {
        (-1.0f32..=1.0).prop_map(f64::from)
    }
    fn unsigned() -> impl Strategy<Value = f64> {
        (0.0f32..=1.0).prop_map(f64::from)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// F32 differs from Exact by accumulated f32 rounding only.
        #[test]
        fn f32_is_exact_up_to_rounding(
            l in [unit(), unit(), unit()],
            h in [unit(), unit(), unit()],
            n in [unsigned(), unsigned(), unsigned(), unsigned()],
            c in [unsigned(), unsigned(), unsigned(), unsigned()],
        ) {
            prop_assume!(l.iter().any(|x| x.abs() > 1e-3) && h.iter().any(|x| x.abs() > 1e-3));
            let m = kilgard();
            let roots = roots(&m);
            let mut env = Fragment { m: &m, l, h, normal_texel: n, c, f32_inputs: true };
            let mut exact = Evaluator::new(&m, &roots, Precision::Exact);
            let mut f32 = Evaluator::new(&m, &roots, Precision::F32);
            let e = exact.eval(&mut env).values.to_vec();
            let f = f32.eval(&mut env).values.to_vec();
            for (a, b) in e.iter().flatten().zip(f.iter().flatten()) {
                prop_assert!((a - b).abs() <= 1e-5 * (1.0 + a.abs()), "{e:?} vs {f:?}");
            }
        }

        /// One operation on f32 inputs: F32 is the exact result rounded once.
        #[test]
        fn one_operation_rounds_once(a in -1e3f32..1e3, b in -1e3f32..1e3) {
            prop_assume!(b != 0.0);
            let mut m = Module::default();
            let (ua, ub) = (uniform(&mut m, "a", Ty::Scalar), uniform(&mut m, "b", Ty::Scalar));
            let ops: Vec<Handle<Expr>> = [BinaryOp::Add, BinaryOp::Sub, BinaryOp::Mul, BinaryOp::Div]
                .into_iter()
                .map(|op| node(&mut m, Expr::Binary { op, lhs: ua, rhs: ub }))
                .collect();
            struct Ab(f64, f64);
            impl Env for Ab {
                fn uniform(&mut self, id: UniformId) -> Option<Value> {
                    Some([if id == 0 { self.0 } else { self.1 }; 4])
                }
            }
            let mut env = Ab(a.into(), b.into());
            let e = Evaluator::new(&m, &ops, Precision::Exact).eval(&mut env).values.to_vec();
            let f = Evaluator::new(&m, &ops, Precision::F32).eval(&mut env).values.to_vec();
            let native = [a + b, a - b, a * b, a / b];
            for k in 0..4 {
                prop_assert_eq!(f[k][0], e[k][0] as f32 as f64);
                prop_assert_eq!(f[k][0], f64::from(native[k]));
            }
        }
    }
}
