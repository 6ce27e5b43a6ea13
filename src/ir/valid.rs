//! Typing, frequency and range rules: what each [`Expr`] node is, given its
//! operands (see the module doc of `ir` for the semantics), and constant
//! folding. `infer` runs on every node as lowering appends it, so a node in a
//! [`Module`] always has an [`ExprInfo`].

use super::{
    eval, BinaryOp, Constant, Expr, ExprInfo, FbChannel, FramebufferId, Frequency, Handle, Interval,
    MathFunction, Module, Site, TextureId, Ty, UnaryOp, VectorId,
};
use crate::parser::ast::{CombineMode, TextureFormat, TextureKind, VectorKind};

/// Why a node is ill-typed; the caller adds the span.
#[derive(Clone, Debug, PartialEq)]
pub struct TypeError {
    /// A stable code: `type-mismatch`, `frequency`, `bad-index`.
    pub code: &'static str,
    pub message: String,
    pub label: String,
    pub help: Option<String>,
}

fn err(code: &'static str, message: impl Into<String>, label: impl Into<String>) -> TypeError {
    TypeError { code, message: message.into(), label: label.into(), help: None }
}

impl TypeError {
    fn help(mut self, help: impl Into<String>) -> TypeError {
        self.help = Some(help.into());
        self
    }
}

/// The texel type of a texture: unsigned formats hold colours; signed
/// formats hold vectors with as many components as the texture has
/// coordinates (a 2-D offset map for EMBM, Pipeline Grammar, eq. (8): "returns a 2-D
/// vector"; a normalization cube map holds directions).
pub fn texel_type(kind: TextureKind, format: TextureFormat) -> (Ty, Interval) {
    use TextureFormat::*;
    match format {
        Signed8 | Signed16 => {
            let ty = match kind {
                TextureKind::Tex1d => Ty::Scalar,
                TextureKind::Tex2d => Ty::Vec2,
                TextureKind::Tex3d | TextureKind::Cube => Ty::Vec3,
            };
            (ty, Interval::SIGNED)
        }
        Rgba8 | Rgba16 => (Ty::Rgba, Interval::UNSIGNED),
        Rgb8 => (Ty::Rgb, Interval::UNSIGNED),
        R8 => (Ty::Scalar, Interval::UNSIGNED),
        Rgba16f | Rgba32f => (Ty::Rgba, Interval::ALL),
    }
}

/// The coordinate type a texture kind is indexed by.
pub fn coord_type(kind: TextureKind) -> Ty {
    match kind {
        TextureKind::Tex1d => Ty::Scalar,
        TextureKind::Tex2d => Ty::Vec2,
        TextureKind::Tex3d | TextureKind::Cube => Ty::Vec3,
    }
}

fn join(a: Frequency, b: Frequency) -> Result<Frequency, TypeError> {
    a.join(b).ok_or_else(|| {
        if a.min(b) == Frequency::Vertex {
            let hi = a.max(b);
            return err("frequency", format!("a per-vertex value is used in a {} computation without δ", hi.name()), "per-vertex operand here")
                .help("right of δ is per vertex, left of δ per sample: interpolate the per-vertex part with δ");
        }
        err("frequency", format!("a {} value meets a {} value", a.name(), b.name()), "computed at two sample frequencies")
            .help("a value is computed per fragment, per texel or per screen pixel, never two at once; split the statement")
    })
}

fn join_all(m: &Module, hs: &[super::Handle<Expr>]) -> Result<Frequency, TypeError> {
    let mut f = Frequency::Constant;
    for h in hs {
        f = join(f, m.info(*h).freq)?;
    }
    Ok(f)
}

/// Whether `a` and `b` may meet componentwise; the result type.
pub fn unify(a: Ty, b: Ty) -> Option<Ty> {
    match (a, b) {
        _ if a == b => Some(a),
        (Ty::Scalar, t) | (t, Ty::Scalar) if t.is_numeric() => Some(t),
        (Ty::Vec3, Ty::Rgb) | (Ty::Rgb, Ty::Vec3) => Some(Ty::Rgb),
        _ => None,
    }
}

fn mismatch(what: &str, a: Ty, b: Ty) -> TypeError {
    err(
        "type-mismatch",
        format!("{what} of {} and {}", a.a_name(), b.a_name()),
        format!("{} and {} do not match", a.name(), b.name()),
    )
    .help(mismatch_help(a, b))
}

/// What makes two types meet, with the likely fix for the pair: a vec3
/// (a tuple is one) does not widen to rgba, an rgb does.
fn mismatch_help(a: Ty, b: Ty) -> &'static str {
    match (a, b) {
        (Ty::Rgba, Ty::Vec3) | (Ty::Vec3, Ty::Rgba) => "operands must have the same type, or one must be a scalar; a vec3 meets an rgba only as a colour: write the tuple as a colour, `rgb(r, g, b)` (rgb widens to rgba, alpha 1), or take the rgba's `.rgb`",
        _ => "operands must have the same type, or one must be a scalar; rgb and vec3 mix, rgb widens to rgba",
    }
}

fn numeric(t: Ty, what: &str) -> Result<(), TypeError> {
    if t.is_numeric() {
        Ok(())
    } else {
        Err(err(
            "type-mismatch",
            format!("{what} of {}", t.a_name()),
            format!("{} is not a number", t.a_name()),
        )
        .help("positions (x, π x, xs) only index tables, and shading-parameter vectors only feed shaders; for a vertex's coordinates as numbers, declare `vector P : position;` and read it in a shader: `shader g : s → vec2 = vec2(P.x, P.z);`, then `u x ← g s x;` (texgen)"))
    }
}

// Interval arithmetic, conservative; NaN bounds widen to everything.
fn iv(lo: f64, hi: f64) -> Interval {
    if lo.is_nan() || hi.is_nan() {
        Interval::ALL
    } else {
        Interval { lo, hi }
    }
}
/// The range of `⊕[dot3_*]`: 4((Ct − ½)·(Cf − ½)) summed over r, g, b (one
/// term for scalars), unclamped like `eval::combine` — GL's clamp to [0, 1]
/// belongs to the hardware model, not to the value (two unsigned colours
/// give [−3, 3]).
fn dot3(t: Interval, f: Interval, scalar: bool) -> Interval {
    let term = mul(add(t, Interval::point(-0.5)), add(f, Interval::point(-0.5)));
    let terms = if scalar { 1.0 } else { 3.0 };
    mul(term, Interval::point(4.0 * terms))
}

fn hull(a: Interval, b: Interval) -> Interval {
    iv(a.lo.min(b.lo), a.hi.max(b.hi))
}
/// Interval sum (also the planner's clamp check between passes).
pub fn add(a: Interval, b: Interval) -> Interval {
    iv(a.lo + b.lo, a.hi + b.hi)
}
fn neg(a: Interval) -> Interval {
    iv(-a.hi, -a.lo)
}
/// Interval product (also the planner's clamp check between passes). An
/// infinite bound means "no bound", every value finite: a factor bounded
/// at 0 times it is 0 there (`[0, 1]·[0, ∞)` is `[0, ∞)`, an intensity
/// times a cosine), not everything.
pub fn mul(a: Interval, b: Interval) -> Interval {
    let p = |x: f64, y: f64| if x == 0.0 || y == 0.0 { 0.0 } else { x * y };
    let c = [p(a.lo, b.lo), p(a.lo, b.hi), p(a.hi, b.lo), p(a.hi, b.hi)];
    if c.iter().any(|v| v.is_nan()) {
        return Interval::ALL;
    }
    iv(c.iter().copied().fold(f64::INFINITY, f64::min), c.iter().copied().fold(f64::NEG_INFINITY, f64::max))
}
fn div(a: Interval, b: Interval) -> Interval {
    if b.lo <= 0.0 && b.hi >= 0.0 {
        Interval::ALL
    } else {
        mul(a, iv(1.0 / b.hi, 1.0 / b.lo))
    }
}
fn map_monotone(a: Interval, f: impl Fn(f64) -> f64) -> Interval {
    iv(f(a.lo), f(a.hi))
}

/// Infers a node's type, frequency, interval and channel ranges from its
/// operands.
pub fn infer(m: &Module, e: &Expr) -> Result<ExprInfo, TypeError> {
    let mut info = infer_node(m, e)?;
    info.channels = node_channels(m, e, &info);
    Ok(info)
}

/// [`infer`] but for the channel ranges (the node's interval in each).
fn infer_node(m: &Module, e: &Expr) -> Result<ExprInfo, TypeError> {
    let info = |h: &super::Handle<Expr>| *m.info(*h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    match e {
        Expr::Constant(c) => {
            let v = c.values();
            let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            out(c.ty, Frequency::Constant, iv(lo, hi))
        }
        Expr::Uniform(id) => {
            let ty = m.uniforms[*id as usize].ty;
            // Colours set by the scene are colours: [0, 1] (the fixed pipeline clamps them).
            let interval = if ty.is_color() { Interval::UNSIGNED } else { Interval::ALL };
            out(ty, Frequency::Uniform, interval)
        }
        Expr::VertexPosition(_) => out(Ty::Position, Frequency::Vertex, Interval::ALL),
        Expr::TexCoord { set, .. } => {
            out(m.texcoord_sets[*set as usize].ty, Frequency::Vertex, Interval::ALL)
        }
        Expr::Vector { vector, site } => shading_vector(m, *vector, *site),
        Expr::TexelCoord => out(Ty::Vec2, Frequency::Texel, Interval::UNSIGNED),
        Expr::Pixel { freq } => out(Ty::Position, *freq, Interval::ALL),
        Expr::Project { value, .. } => {
            let v = info(value);
            match v.ty {
                Ty::Position => out(Ty::Position, v.freq, Interval::ALL),
                Ty::Vec3 => out(Ty::Vec2, v.freq, Interval::UNSIGNED),
                t => Err(err(
                    "type-mismatch",
                    format!("π projects a point or a direction, not {}", t.a_name()),
                    "projected here",
                )
                .help("write `π x` for a vertex, or `πR R s x` for a direction (Pipeline Grammar, eq. (7))")),
            }
        }
        Expr::Interpolate { value, to } => interpolate(m, *value, *to),
        Expr::Lookup { texture, coords } => lookup(m, *texture, *coords),
        Expr::FramebufferRead { framebuffer, channel, position } => {
            framebuffer_read(m, *framebuffer, *channel, *position)
        }
        Expr::Depth(p) => {
            let p = info(p);
            if p.ty != Ty::Position {
                return Err(err(
                    "type-mismatch",
                    format!("z of {}", p.ty.a_name()),
                    "not a position or framebuffer",
                )
                .help("z selects the depth of a framebuffer (`z C xs`) or of a fragment (`z δπx`)"));
            }
            out(Ty::Scalar, p.freq, Interval::UNSIGNED)
        }
        Expr::FatMember { texel, .. } => {
            let t = info(texel);
            out(Ty::Vec3, t.freq, Interval::ALL)
        }
        Expr::Bundle(members) => {
            out(Ty::Bundle(members.len().min(255) as u8), join_all(m, members)?, Interval::ALL)
        }
        Expr::Unary { op, value } => unary(m, *op, *value),
        Expr::Binary { op, lhs, rhs } => {
            binary(m, *op, info(lhs), info(rhs)).map(|i| refine(m, *op, *lhs, *rhs, i))
        }
        Expr::Combine { mode, lhs, rhs } => combine(m, *mode, *lhs, *rhs),
        Expr::Math { fun, args } => math(m, *fun, args),
        Expr::Swizzle { value, pattern, len, ty } => swizzle(m, *value, pattern, *len, *ty),
        Expr::Compose { ty, components } => compose(m, *ty, components),
        Expr::Convert { value, to } => convert(m, *value, *to),
        Expr::Select { cond, accept, reject } => select(m, *cond, *accept, *reject),
    }
}

/// `δ`: a per-vertex value, interpolated once.
fn interpolate(m: &Module, value: Handle<Expr>, to: Frequency) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let v = info(value);
    if v.freq.is_sample() {
        return Err(err(
            "delta-twice",
            format!("δ applied to a value that is already {}", v.freq.name()),
            "δ applied twice",
        )
        .help("δ interpolates per-vertex values; remove one δ"));
    }
    if matches!(v.ty, Ty::Bundle(_)) {
        return Err(err("not-supported", "not yet supported: interpolating a bundle value", "here").help(
            "interpolate each member the shader reads (`δ N s x`, `δ L s x`) instead of the whole bundle",
        ));
    }
    out(v.ty, to, v.interval)
}

/// Negation of a number, or `not` of a condition.
fn unary(m: &Module, op: UnaryOp, value: Handle<Expr>) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let v = info(value);
    numeric(v.ty, "negation")?;
    match op {
        UnaryOp::Neg => out(v.ty, v.freq, neg(v.interval)),
        UnaryOp::Not => {
            if v.ty != Ty::Scalar {
                return Err(err(
                    "type-mismatch",
                    format!("`not` of {}", v.ty.a_name()),
                    "a condition is a scalar",
                )
                .help("negate a comparison or a channel (`¬((T δu x).a > 0.5)`, `¬σ C δπx`)"));
            }
            out(Ty::Scalar, v.freq, Interval::UNSIGNED)
        }
    }
}

/// A component selection: each selected component must exist.
fn swizzle(
    m: &Module,
    value: Handle<Expr>,
    pattern: &[u8; 4],
    len: u8,
    ty: Ty,
) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let v = info(value);
    numeric(v.ty, "a component selection")?;
    if let Some(&i) = pattern[..len as usize].iter().find(|&&i| i as usize >= v.ty.width()) {
        let missing = component_missing(v.ty, i as usize);
        return Err(match signed_2d(m, value) {
            Some(name) => missing.help(format!(
                "`{name}` is a signed 2-D texture: two components a texel (an offset texture's ds, dt, or a HILO normal's x, y, as NV_texture_shader stores them); for a normal, rebuild its z, `vec3(n.x, n.y, sqrt(max(0, 1 - n·n)))`, or store the normal as a colour (`texture Tn : 2d rgb8 … = normal_map(height(\"bumps.png\"), 4);`) read by `expand(Tn δu x)`"
            )),
            None => missing,
        });
    }
    // The channels read, not the hull of all (`(0.8·d, 0.6·d′, 0).g` is
    // in [0, 0.6]).
    let c = m.info(value).channels;
    let read = pattern[..len as usize].iter().map(|&i| c[(i as usize).min(3)]).reduce(hull);
    out(ty, v.freq, read.unwrap_or(v.interval))
}

/// The name of the signed 2-D texture `value` looks up, if it is one.
fn signed_2d(m: &Module, value: Handle<Expr>) -> Option<&str> {
    let Expr::Lookup { texture, .. } = m.exprs[value] else { return None };
    let t = &m.textures[texture as usize];
    let signed = matches!(t.format, TextureFormat::Signed8 | TextureFormat::Signed16);
    (signed && t.kind == TextureKind::Tex2d).then_some(t.name.as_str())
}

/// A swizzle asks for component `i` (0-based) of `ty`, which has fewer:
/// a scalar has none to select; a vector names the ones it has.
fn component_missing(ty: Ty, i: usize) -> TypeError {
    if ty == Ty::Scalar {
        return err("bad-swizzle", "a scalar has no components to swizzle", "a scalar, swizzled")
            .help("a scalar is one number: use it as it is, without the swizzle (it spreads to every channel where a colour is needed), or write `vec3(…)` to make a vector of it");
    }
    let (n, name) = (ty.width(), ty.name());
    let have = |set: &str| set[..n].chars().map(String::from).collect::<Vec<_>>().join(" ");
    err(
        "bad-swizzle",
        format!(
            "a {name} has {n} components, and the swizzle asks for a {} (`{}` or `{}`)",
            match i + 1 {
                2 => "2nd".to_string(),
                3 => "3rd".to_string(),
                k => format!("{k}th"),
            },
            "xyzw".get(i..=i).unwrap_or("?"),
            "rgba".get(i..=i).unwrap_or("?")
        ),
        "no such component",
    )
    .help(format!("a {name}'s components are {} (or {})", have("xyzw"), have("rgba")))
}

/// A widening conversion: rgb to rgba (alpha 1), a scalar splatted, or to its own type.
fn convert(m: &Module, value: Handle<Expr>, to: Ty) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let v = info(value);
    let ok = (v.ty == Ty::Rgb && to == Ty::Rgba) || (v.ty == Ty::Scalar && to.is_numeric()) || v.ty == to;
    if !ok {
        return Err(mismatch("conversion", v.ty, to));
    }
    let interval =
        if to == Ty::Rgba && v.ty == Ty::Rgb { hull(v.interval, Interval::point(1.0)) } else { v.interval };
    out(to, v.freq, interval)
}

/// A shading vector: per vertex or per texel, a unit direction unless its kind says otherwise.
fn shading_vector(m: &Module, vector: VectorId, site: Site) -> Result<ExprInfo, TypeError> {
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let freq = match site {
        Site::Vertex(_) => Frequency::Vertex,
        Site::Texel => Frequency::Texel,
    };
    let (ty, interval) = match m.vectors[vector as usize].kind {
        Some(VectorKind::Position) => (Ty::Vec3, Interval::ALL),
        // A light's colour · attenuation · spot factor: not a unit
        // vector but a colour (the I of seeds/001 (1)-(3)), written
        // into a framebuffer as it is.
        Some(VectorKind::Intensity) => (Ty::Rgb, Interval { lo: 0.0, hi: f64::INFINITY }),
        _ => (Ty::Vec3, Interval::SIGNED),
    };
    out(ty, freq, interval)
}

/// A texel: the coordinates must be the texture kind's.
/// What indexes a texture of `kind`, with an example of the right form —
/// never the expression that failed (`Env δu x` for a cube map).
fn coordinates_help(kind: TextureKind, want: Ty, name: &str, colour: bool) -> String {
    let example = match kind {
        TextureKind::Tex2d => format!("its texture coordinates, `{name} δu x`"),
        TextureKind::Cube => format!("a direction, such as a reflection vector (`vector R : reflection;`) interpolated: `{name} δ R s x`"),
        TextureKind::Tex3d => format!("a point, such as the surface position (`vector P : position;`): `{name} δ P s x`"),
        TextureKind::Tex1d => format!("a scalar, such as the result of a scalar shader `shader d : s → scalar = …`: `{name} δ d s x`"),
    };
    let colour = if colour {
        let built = match kind {
            TextureKind::Tex1d => "c.r",
            TextureKind::Tex2d => "vec2(c.r, c.g)",
            // A colour-grading table is a volume indexed by a colour.
            TextureKind::Tex3d | TextureKind::Cube => "vec3(c)",
        };
        format!("; a colour is not a coordinate (build one from its channels: `{name} {built}`)")
    } else {
        String::new()
    };
    format!("a {} texture takes {} coordinates: {example}{colour}", kind.as_str(), want.name())
}

fn lookup(m: &Module, texture: TextureId, coords: Handle<Expr>) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let t = &m.textures[texture as usize];
    let c = info(coords);
    let want = coord_type(t.kind);
    let ok = c.ty == want || (t.kind == TextureKind::Tex2d && c.ty == Ty::Position);
    if !ok {
        let message = if c.ty.is_color() {
            format!("the texture `{}` is indexed by a colour ({})", t.name, c.ty.name())
        } else {
            format!("the {} texture `{}` is indexed by a {}", t.kind.as_str(), t.name, c.ty.name())
        };
        return Err(err("bad-index", message, format!("expected {} coordinates", want.name()))
            .help(coordinates_help(t.kind, want, &t.name, c.ty.is_color())));
    }
    let (ty, interval) = texel_type(t.kind, t.format);
    out(ty, c.freq.max(Frequency::Uniform), interval)
}

/// A framebuffer channel, read at a per-fragment or per-pixel position; a float framebuffer's colour is unbounded.
fn framebuffer_read(
    m: &Module,
    framebuffer: FramebufferId,
    channel: FbChannel,
    position: Handle<Expr>,
) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let p = info(position);
    let name = &m.framebuffers[framebuffer as usize].name;
    if p.ty != Ty::Position {
        return Err(err(
            "bad-index",
            format!("the framebuffer `{name}` is indexed by {}", p.ty.a_name()),
            "expected a position",
        )
        .help(format!("read a framebuffer at a fragment (`{name} δπx`) or a pixel (`{name} xs`)")));
    }
    if !p.freq.is_sample() {
        return Err(err(
            "frequency",
            format!("the framebuffer `{name}` is read at a {} position", p.freq.name()),
            "not a fragment or pixel",
        )
        .help(format!("framebuffers hold pixels: write `{name} δπx` or `{name} xs`")));
    }
    let (ty, interval) = match channel {
        FbChannel::Color => (Ty::Rgba, Interval::UNSIGNED),
        FbChannel::Alpha | FbChannel::Depth => (Ty::Scalar, Interval::UNSIGNED),
        FbChannel::Stencil => (Ty::Scalar, Interval { lo: 0.0, hi: 255.0 }),
    };
    let float = m.framebuffers[framebuffer as usize].channels.iter().any(|c| {
        matches!(
            c,
            crate::parser::ast::FramebufferChannel::Rgba16f | crate::parser::ast::FramebufferChannel::Rgba32f
        )
    });
    let interval = if float && matches!(channel, FbChannel::Color | FbChannel::Alpha) {
        Interval::ALL
    } else {
        interval
    };
    out(ty, p.freq, interval)
}

/// `⊕`: a texture-environment or framebuffer operation on colours.
/// Whether every value of `i` lies in [0, 1].
fn unit(i: Interval) -> bool {
    i.lo >= 0.0 && i.hi <= 1.0
}

fn combine(
    m: &Module,
    mode: CombineMode,
    lhs: Handle<Expr>,
    rhs: Handle<Expr>,
) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let (a, b) = (info(lhs), info(rhs));
    for t in [a.ty, b.ty] {
        if !matches!(t, Ty::Scalar | Ty::Rgb | Ty::Rgba) {
            return Err(err("type-mismatch", format!("⊕ combines colours, not {}", t.a_name()), t.a_name())
                .help("⊕ is a texture-environment or framebuffer operation on colours (Pipeline Grammar, eq. (3)); use `*` or `+` for vectors, or read a vec3 as a colour with `rgb(v)` (a constant colour: `rgb(r, g, b)`)"));
        }
    }
    let ty = unify(a.ty, b.ty).ok_or_else(|| mismatch("⊕", a.ty, b.ty))?;
    let freq = join(a.freq, b.freq)?;
    let interval = match mode {
        CombineMode::Modulate => mul(a.interval, b.interval),
        CombineMode::Add => add(a.interval, b.interval),
        CombineMode::AddSigned => add(add(a.interval, b.interval), Interval::point(-0.5)),
        CombineMode::Subtract => add(a.interval, neg(b.interval)),
        CombineMode::Dot3Rgb | CombineMode::Dot3Rgba => dot3(a.interval, b.interval, ty == Ty::Scalar),
        // `Cf(1 − Ct)`: in the hull of its operands only where Ct ∈ [0, 1].
        // `Cf(1 − Ct)`, and `Af·At` in alpha (rgba): one range covers both.
        CombineMode::Blend if ty == Ty::Rgba => {
            hull(mul(b.interval, add(Interval::point(1.0), neg(a.interval))), mul(a.interval, b.interval))
        }
        CombineMode::Blend => mul(b.interval, add(Interval::point(1.0), neg(a.interval))),
        // `Ct·At + Cf(1 − At)`: a convex combination where At ∈ [0, 1]
        // (bounded by Ct's own range), else bounded term by term.
        CombineMode::Decal | CombineMode::Interpolate if !unit(a.interval) => {
            let at = a.interval;
            add(mul(a.interval, at), mul(b.interval, add(Interval::point(1.0), neg(at))))
        }
        _ => hull(a.interval, b.interval),
    };
    out(ty, freq, interval)
}

/// A vector from components, whose widths must add up to its own.
fn compose(m: &Module, ty: Ty, components: &[Handle<Expr>]) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let mut width = 0;
    let mut interval: Option<Interval> = None;
    for c in components {
        let ci = info(*c);
        numeric(ci.ty, "a vector component")?;
        width += ci.ty.width();
        interval = Some(interval.map_or(ci.interval, |i| hull(i, ci.interval)));
    }
    if width != ty.width() {
        return Err(err(
            "type-mismatch",
            format!("{} needs {} components, got {width}", ty.a_name(), ty.width()),
            "wrong number of components",
        )
        .help(format!("give {} scalars in all: `{}`", ty.width(), components_example(ty))));
    }
    out(ty, join_all(m, components)?, interval.unwrap_or(Interval::ALL))
}

/// `c ? a : b`, or `c ? a` (no reject: the fragment is discarded where c is 0).
fn select(
    m: &Module,
    cond: Handle<Expr>,
    accept: Handle<Expr>,
    reject: Option<Handle<Expr>>,
) -> Result<ExprInfo, TypeError> {
    let info = |h: Handle<Expr>| *m.info(h);
    let out = |ty, freq, interval| Ok(ExprInfo::new(ty, freq, interval));
    let c = info(cond);
    if c.ty != Ty::Scalar {
        return Err(err(
            "type-mismatch",
            format!("a condition must be a scalar, not {}", c.ty.a_name()),
            "condition",
        )
        .help("compare something: `Hn.z ≥ 0 ? … : …`"));
    }
    let a = info(accept);
    let (ty, interval, freq) = match reject {
        Some(r) => {
            let r = info(r);
            let ty = unify(a.ty, r.ty).ok_or_else(|| mismatch("selection", a.ty, r.ty))?;
            (ty, hull(a.interval, r.interval), join(join(c.freq, a.freq)?, r.freq)?)
        }
        None => (a.ty, a.interval, join(c.freq, a.freq)?),
    };
    out(ty, freq, interval)
}

/// Ranges interval arithmetic cannot see, because an operand occurs twice.
/// With this module's convention for a vec3 whose components lie in
/// [−1, 1] (a direction of length at most 1: `Dot` reads two of them as a
/// cosine), `w·w` is a squared length in [0, 1], and Formula 6 of GeForce3 Phong
/// (Section 4.2.3), `w + ½w(1 − w·w)`, has length l(3 − l²)/2 ≤ 1 — so the
/// register combiners compute the Taylor renormalization without a clamp
/// changing it, as the paper does on a GeForce3.
fn refine(m: &Module, op: BinaryOp, lhs: Handle<Expr>, rhs: Handle<Expr>, info: ExprInfo) -> ExprInfo {
    let direction = |h: Handle<Expr>| {
        let i = m.info(h);
        i.ty.width() == 3 && i.interval.lo >= -1.0 && i.interval.hi <= 1.0
    };
    let interval = match op {
        BinaryOp::Dot if lhs == rhs && direction(lhs) => Interval::UNSIGNED,
        // A square is never negative: `n.x*n.x`, a triplanar weight, is in
        // [0, 1], where the product of two intervals says [−1, 1].
        BinaryOp::Mul if lhs == rhs => square(m.info(lhs).interval),
        BinaryOp::Add
            if (direction(lhs) && is_taylor_step(m, lhs, rhs))
                || (direction(rhs) && is_taylor_step(m, rhs, lhs)) =>
        {
            Interval::SIGNED
        }
        BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul if matches!(info.ty, Ty::Rgb | Ty::Rgba | Ty::Vec3) => {
            let c = channels(m, op, lhs, rhs);
            let hull = c[..info.ty.width()].iter().copied().reduce(hull).unwrap_or(info.interval);
            iv(hull.lo.max(info.interval.lo), hull.hi.min(info.interval.hi))
        }
        _ => return info,
    };
    ExprInfo { interval, ..info }
}

/// The range of `x·x` for `x` in `i`.
fn square(i: Interval) -> Interval {
    let (lo, hi) = (i.lo * i.lo, i.hi * i.hi);
    if i.lo >= 0.0 {
        iv(lo, hi)
    } else if i.hi <= 0.0 {
        iv(hi, lo)
    } else {
        iv(0.0, lo.max(hi))
    }
}

/// The range of each channel of `lhs op rhs`: the hull over the channels
/// loses what they differ in — `(0.9, 0.4, 0.3)·d + (0.3, 0.9, 0.4)·d′`
/// is at most 1.3 in each channel, where the hulls give 1.8 — and a sum
/// of lights in one shader (GL's per-vertex lighting) is refused for a
/// bound it never reaches. Each operand's channels are its own
/// ([`ExprInfo::channels`], found when it was appended), so a sum of many
/// terms keeps them however deep it is.
fn channels(m: &Module, op: BinaryOp, lhs: Handle<Expr>, rhs: Handle<Expr>) -> [Interval; 4] {
    let (a, b) = (m.info(lhs).channels, m.info(rhs).channels);
    std::array::from_fn(|i| match op {
        BinaryOp::Add => add(a[i], b[i]),
        BinaryOp::Sub => add(a[i], neg(b[i])),
        _ => mul(a[i], b[i]),
    })
}

/// The range of each channel of node `e` (a scalar's in all four) from
/// its operands' channels; the node's own interval in each where the
/// operation mixes channels or is not followed.
fn node_channels(m: &Module, e: &Expr, info: &ExprInfo) -> [Interval; 4] {
    let splat = [info.interval; 4];
    // A constant's channels are known (a leaf).
    if let (Expr::Constant(c), false) = (e, info.ty.width() == 1) {
        return std::array::from_fn(|i| Interval::point(c.components[i]));
    }
    if info.ty.width() == 1 {
        return splat;
    }
    let c = match e {
        Expr::Interpolate { value, .. } => m.info(*value).channels,
        Expr::Binary { op: op @ (BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul), lhs, rhs } => {
            channels(m, *op, *lhs, *rhs)
        }
        Expr::Convert { value, to: Ty::Rgba } if m.info(*value).ty == Ty::Rgb => {
            let c = m.info(*value).channels;
            [c[0], c[1], c[2], Interval::point(1.0)]
        }
        Expr::Swizzle { value, pattern, .. } => {
            let c = m.info(*value).channels;
            std::array::from_fn(|i| c[(pattern[i] as usize).min(3)])
        }
        Expr::Compose { components, .. } => {
            let mut out = splat;
            let mut i = 0;
            for part in components {
                let w = m.info(*part).ty.width();
                let c = m.info(*part).channels;
                let n = w.min(4 - i.min(4));
                out[i.min(4)..i.min(4) + n].copy_from_slice(&c[..n]);
                i += w;
            }
            out
        }
        _ => return splat,
    };
    // Never wider than the node's own range.
    c.map(|x| iv(x.lo.max(info.interval.lo), x.hi.min(info.interval.hi)))
}

/// Whether `step` is `½w(1 − w·w)`: the three factors in any order and
/// grouping (the combiner generator floats the ½ out to an output scale).
fn is_taylor_step(m: &Module, w: Handle<Expr>, step: Handle<Expr>) -> bool {
    fn factors(m: &Module, h: Handle<Expr>, out: &mut Vec<Handle<Expr>>) {
        match m.exprs[h] {
            Expr::Binary { op: BinaryOp::Mul, lhs, rhs } if out.len() < 4 => {
                factors(m, lhs, out);
                factors(m, rhs, out);
            }
            _ => out.push(h),
        }
    }
    let defect = |h: Handle<Expr>| match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Sub, lhs, rhs } => {
            m.is_constant(lhs, 1.0)
                && matches!(m.exprs[rhs], Expr::Binary { op: BinaryOp::Dot, lhs: a, rhs: b } if a == w && b == w)
        }
        _ => false,
    };
    let mut f = Vec::new();
    factors(m, step, &mut f);
    f.len() == 3
        && f.iter().filter(|&&h| m.is_constant(h, 0.5)).count() == 1
        && f.iter().filter(|&&h| h == w).count() == 1
        && f.iter().filter(|&&h| defect(h)).count() == 1
}

/// `a · b` of operands of different sizes: the help says how to match
/// them (an rgba normal map, `rgba8` being the default format, is the
/// common case).
fn dot_mismatch(a: Ty, b: Ty) -> TypeError {
    let what = |t: Ty| if t.is_color() { format!("a colour ({})", t.name()) } else { t.a_name() };
    let help = if a.width().min(b.width()) == 3 && a.width().max(b.width()) == 4 {
        "`·` of a three- and a four-component value: take `.rgb` (or `.xyz`) of the four-component one, or declare the texture it reads `rgb8` (a texture declared `rgba8`, the default, reads as rgba)"
    } else {
        "`·` is the dot product of two directions (vec3) or colours used as vectors (dot3); to scale, write `*`"
    };
    err(
        "type-mismatch",
        format!("dot product of {} with {}", what(a), what(b)),
        "· needs two vectors of the same size",
    )
    .help(help)
}

fn binary(_m: &Module, op: BinaryOp, a: ExprInfo, b: ExprInfo) -> Result<ExprInfo, TypeError> {
    use BinaryOp::*;
    numeric(a.ty, "an operation")?;
    numeric(b.ty, "an operation")?;
    let freq = join(a.freq, b.freq)?;
    let done = |ty, interval| Ok(ExprInfo::new(ty, freq, interval));
    match op {
        Dot => {
            if a.ty.width() != b.ty.width() || !a.ty.is_numeric() {
                return Err(dot_mismatch(a.ty, b.ty));
            }
            let unit = |i: Interval| i.lo >= -1.0 && i.hi <= 1.0;
            let interval = if unit(a.interval) && unit(b.interval) {
                // Unit vectors: the dot product is a cosine (seeds/003 Section 4.2 clamps it to [−1, 1]).
                if a.interval.lo >= 0.0 && b.interval.lo >= 0.0 {
                    Interval::UNSIGNED
                } else {
                    Interval::SIGNED
                }
            } else {
                // (A dot product of two scalars is their product.)
                let p = mul(a.interval, b.interval);
                iv(p.lo * a.ty.width() as f64, p.hi * a.ty.width() as f64)
            };
            done(Ty::Scalar, interval)
        }
        Pow => {
            if b.ty != Ty::Scalar {
                return Err(err(
                    "type-mismatch",
                    format!("an exponent must be a scalar, not {}", b.ty.a_name()),
                    "exponent",
                )
                .help("raise to a scalar power (`(N·H)^32`, or one channel: `x^(T δu x).r`)"));
            }
            let interval = if a.interval.lo >= 0.0 && b.interval.lo > 0.0 {
                if a.interval.hi <= 1.0 {
                    Interval::UNSIGNED
                } else {
                    iv(0.0, f64::INFINITY)
                }
            } else if a.interval.lo >= 0.0 {
                iv(0.0, f64::INFINITY)
            } else {
                Interval::ALL
            };
            done(a.ty, interval)
        }
        Lt | Le | Gt | Ge | Eq | Ne | And | Or => {
            if unify(a.ty, b.ty).is_none() {
                return Err(mismatch("comparison", a.ty, b.ty));
            }
            if a.ty != Ty::Scalar || b.ty != Ty::Scalar {
                return Err(err(
                    "type-mismatch",
                    format!("comparison of {} and {}", a.ty.a_name(), b.ty.a_name()),
                    "compare scalars",
                )
                .help("select a component first, e.g. `Hn.z ≥ 0`"));
            }
            done(Ty::Scalar, Interval::UNSIGNED)
        }
        Add | Sub | Mul | Div => {
            let ty = unify(a.ty, b.ty).ok_or_else(|| mismatch(op_word(op), a.ty, b.ty))?;
            let interval = match op {
                Add => add(a.interval, b.interval),
                Sub => add(a.interval, neg(b.interval)),
                Mul => mul(a.interval, b.interval),
                _ => div(a.interval, b.interval),
            };
            done(ty, interval)
        }
    }
}

fn op_word(op: BinaryOp) -> &'static str {
    match op {
        BinaryOp::Add => "sum",
        BinaryOp::Sub => "difference",
        BinaryOp::Mul => "product",
        BinaryOp::Div => "quotient",
        _ => "operation",
    }
}

/// A constructor call of `ty` with its components, for a help line.
fn components_example(ty: Ty) -> &'static str {
    match ty.width() {
        2 => "vec2(x, y)",
        3 if ty == Ty::Rgb => "rgb(r, g, b)",
        3 => "vec3(x, y, z)",
        _ => "rgba(r, g, b, a), or rgba(rgb, a)",
    }
}

/// A built-in function's arguments, for a help line.
fn signature(fun: MathFunction) -> String {
    use MathFunction::*;
    let args = match fun {
        Max | Min => "a, b",
        Step => "edge, x",
        Cross => "a, b",
        Reflect => "i, n",
        Clamp => "x, lo, hi",
        Smoothstep => "lo, hi, x",
        Mix => "a, b, t",
        _ => "x",
    };
    format!("{}({args})", fun.name())
}

fn math(m: &Module, fun: MathFunction, args: &[super::Handle<Expr>]) -> Result<ExprInfo, TypeError> {
    use MathFunction::*;
    let infos: Vec<ExprInfo> = args.iter().map(|h| *m.info(*h)).collect();
    let arity = match fun {
        Max | Min | Step | Cross | Reflect => 2,
        Clamp | Smoothstep | Mix => 3,
        _ => 1,
    };
    if infos.len() != arity {
        return Err(err(
            "arity",
            format!("`{}` takes {arity} argument(s), got {}", fun.name(), infos.len()),
            "wrong number of arguments",
        )
        .help(format!("write `{}`", signature(fun))));
    }
    for i in &infos {
        numeric(i.ty, &format!("`{}`", fun.name()))?;
    }
    let freq = join_all(m, args)?;
    let a = infos[0];
    let done = |ty, interval| Ok(ExprInfo::new(ty, freq, interval));
    let vec3ish = |t: Ty| t.width() == 3;
    match fun {
        Normalize => {
            if a.ty == Ty::Scalar {
                return Err(err("type-mismatch", "normalize of a scalar", "needs a vector")
                    .help("normalize takes a vec3 (or vec2)"));
            }
            done(a.ty, Interval::SIGNED)
        }
        Length => done(Ty::Scalar, iv(0.0, f64::INFINITY)),
        Cross | Reflect => {
            if !vec3ish(a.ty) || !vec3ish(infos[1].ty) {
                return Err(mismatch(fun.name(), a.ty, infos[1].ty));
            }
            done(Ty::Vec3, Interval::ALL)
        }
        Max | Min | Clamp | Step | Smoothstep | Mix => {
            let mut ty = a.ty;
            for i in &infos[1..] {
                // mix(a, b, t) takes a scalar t; the rest unify componentwise.
                ty = unify(ty, i.ty).ok_or_else(|| mismatch(fun.name(), ty, i.ty))?;
            }
            let b = infos[1];
            let interval = match fun {
                Max => iv(a.interval.lo.max(b.interval.lo), a.interval.hi.max(b.interval.hi)),
                Min => iv(a.interval.lo.min(b.interval.lo), a.interval.hi.min(b.interval.hi)),
                Clamp => iv(
                    a.interval.lo.max(b.interval.lo).min(infos[2].interval.hi),
                    a.interval.hi.min(infos[2].interval.hi).max(b.interval.lo),
                ),
                Step | Smoothstep => Interval::UNSIGNED,
                // a·(1 − t) + b·t: between a and b for t in [0, 1] only.
                _ if infos[2].interval.lo >= 0.0 && infos[2].interval.hi <= 1.0 => {
                    hull(a.interval, b.interval)
                }
                _ => {
                    let t = infos[2].interval;
                    add(mul(a.interval, add(Interval::point(1.0), neg(t))), mul(b.interval, t))
                }
            };
            done(ty, interval)
        }
        Saturate => done(a.ty, Interval::UNSIGNED),
        Abs => done(a.ty, iv(0.0, a.interval.lo.abs().max(a.interval.hi.abs()))),
        Sign | Sin | Cos => done(a.ty, Interval::SIGNED),
        Sqrt => done(a.ty, map_monotone(iv(a.interval.lo.max(0.0), a.interval.hi.max(0.0)), f64::sqrt)),
        Rsqrt | Log => done(a.ty, Interval::ALL),
        Exp => done(a.ty, map_monotone(a.interval, f64::exp)),
        Floor => done(a.ty, map_monotone(a.interval, f64::floor)),
        Fract => done(a.ty, Interval::UNSIGNED),
        Expand => done(a.ty, map_monotone(a.interval, |x| 2.0 * x - 1.0)),
        HalfBias => done(a.ty, map_monotone(a.interval, |x| x - 0.5)),
        Compress => done(a.ty, map_monotone(a.interval, |x| (x + 1.0) / 2.0)),
    }
}

/// Evaluates a node whose operands are all constants, with the one
/// semantics of every operation, [`eval::apply`]; `None` when an operand is
/// not a constant, when the node is not a computation (a lookup, a leaf),
/// for a bundle, for `c ? a` (it keeps the destination where `c` fails: a
/// write, not a value), or when a component is not finite (`1/0` stays an
/// operation, so that the evaluator's precision decides what it gives).
pub fn fold(m: &Module, e: &Expr, ty: Ty) -> Option<Constant> {
    let width = ty.width();
    if width > 4 || !eval::is_computation(e) || matches!(e, Expr::Select { reject: None, .. }) {
        return None;
    }
    let hs = e.operands();
    let mut operands = [[0.0; 4]; 4];
    if hs.len() > operands.len() {
        return None;
    }
    for (o, h) in operands.iter_mut().zip(&hs) {
        match &m.exprs[*h] {
            Expr::Constant(c) => *o = eval::value(c),
            _ => return None,
        }
    }
    let v = eval::apply(m, e, ty, &operands[..hs.len()]);
    let v = &v[..width];
    v.iter().all(|x| x.is_finite()).then(|| Constant::new(ty, v))
}

#[cfg(test)]
mod tests;
