//! A statement's blend form — what framebuffer blending does with what it
//! reads of its own target (Pipeline Grammar, eq. (9)) — and the pieces it
//! is split into, exact through the target's clamps.

use super::*;

/// The framebuffer read of `st`'s own target at its own position.
pub(super) fn self_read(m: &Module, st: &Statement, channel: FbChannel) -> Option<Handle<Expr>> {
    match st.table {
        Table::Framebuffer { id, .. } => {
            m.exprs.find(&Expr::FramebufferRead { framebuffer: id, channel, position: st.index })
        }
        _ => None,
    }
}

/// Whether `b` can be fused after `a`: same framebuffer, colour writes,
/// same geometry, no stencil or discard.
pub(super) fn fusable(m: &Module, a: &Statement, b: &Statement) -> bool {
    matches!((&a.table, &b.table), (Table::Framebuffer { id: x, channel: FbChannel::Color }, Table::Framebuffer { id: y, channel: FbChannel::Color }) if x == y)
        && a.index == b.index
        && a.freq == Frequency::Fragment
        && ![a.value, b.value].iter().any(|v| matches!(m.exprs[*v], Expr::Select { reject: None, .. }))
}

/// The value of the statements `stmts` run one after another, as one value:
/// each later statement's reads of the framebuffer replaced by the earlier
/// value.
pub(super) fn fuse(m: &mut Module, stmts: &[usize]) -> Option<Handle<Expr>> {
    let first = m.statements[stmts[0]].clone();
    let mut value = blended_as_gl(m, &first, first.value);
    for &s in &stmts[1..] {
        value = fuse_next(m, value, s)?;
    }
    Some(value)
}

/// The value of statement `s` run after `value` (the fused value of the
/// statements before it): one step of [`fuse`].
pub(super) fn fuse_next(m: &mut Module, value: Handle<Expr>, s: usize) -> Option<Handle<Expr>> {
    let st = m.statements[s].clone();
    let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::default();
    let reads = [FbChannel::Color, FbChannel::Alpha].iter().any(|&c| self_read(m, &st, c).is_some());
    let value = if reads { stored(m, &st, value)? } else { value };
    if let Some(r) = self_read(m, &st, FbChannel::Color) {
        let v = widen_rgba(m, value)?;
        map.insert(r, v);
    }
    if let Some(r) = self_read(m, &st, FbChannel::Alpha) {
        let a = Builder { module: m }.alpha(value)?;
        map.insert(r, a);
    }
    let written = blended_as_gl(m, &st, st.value);
    substitute(m, written, &map)
}

/// The source of the framebuffer blend statement `st` writes, where GL
/// clamps it and the clamp changes it: `v` of `(T) ⊕ v` and of `(T) ⊕[add]
/// v`, `s` of `(T) ⊕[add] ((α T)·s)` (Pipeline Grammar, eq. (9); Kilgard
/// 2000, Sections 5.4-5.5), into a fixed-point (`rgba8`) framebuffer, whose
/// blend clamps its source to [0, 1] (OpenGL 1.2.1 §2.13.9, §4.1.8; Vulkan
/// clamps a UNORM attachment's alike). `None` where the source's range is
/// in [0, 1], or only above 1 in an add (`min(1, C + min(1, v))` is
/// `min(1, C + v)` for `C ≥ 0`). Arithmetic (`C + v`, `C·v`) is not a
/// blend the program writes: it means what it computes, and the planner
/// blends it exactly ([`split::exact_through_clamps`]).
pub fn clamped_blend_source(m: &Module, st: &Statement, value: Handle<Expr>) -> Option<Handle<Expr>> {
    if !matches!(st.table, Table::Framebuffer { channel: FbChannel::Color, .. }) || float_framebuffer(m, st) {
        return None;
    }
    let r = self_read(m, st, FbChannel::Color)?;
    let Expr::Combine { mode, lhs, rhs } = m.exprs[value] else { return None };
    let v = other_operand(lhs, rhs, r)?;
    let ra = self_read(m, st, FbChannel::Alpha);
    let outside = |h: Handle<Expr>| {
        let i = m.info(h).interval;
        i.lo < 0.0 || i.hi > 1.0
    };
    if split::depends_on(m, v, r) {
        return None;
    }
    match mode {
        CombineMode::Modulate if ra.is_none_or(|ra| !split::depends_on(m, v, ra)) => outside(v).then_some(v),
        CombineMode::Add => match ra.and_then(|ra| alpha_factor(m, v, ra)) {
            Some(s) => outside(s).then_some(s),
            None if ra.is_some_and(|ra| split::depends_on(m, v, ra)) => None,
            None => (m.info(v).interval.lo < 0.0).then_some(v),
        },
        _ => None,
    }
}

/// `value` as statement `st` means it: its framebuffer blend's source
/// clamped where GL clamps it ([`clamped_blend_source`]), so the
/// program's meaning, a fused value and a split all compute what the
/// passes the program writes compute on the hardware.
pub fn blended_as_gl(m: &mut Module, st: &Statement, value: Handle<Expr>) -> Handle<Expr> {
    let Some(source) = clamped_blend_source(m, st, value) else { return value };
    let Some(clamped) =
        Builder { module: m }.node(Expr::Math { fun: ir::MathFunction::Saturate, args: vec![source] })
    else {
        return value;
    };
    let map = HashMap::from_iter([(source, clamped)]);
    substitute(m, value, &map).unwrap_or(value)
}

/// What statement `st` reads of `value` stored into its framebuffer: a
/// fixed-point (`rgba8`) framebuffer clamps to [0, 1] (GL §2.13.9,
/// §4.1.8), so a fused value whose range leaves [0, 1] is saturated where
/// the earlier statement would have stored it (`2T³` is not `T·2T·T` on an
/// rgba8 target: `2T²` was clamped in between). Not needed where `st` only
/// adds a non-negative term to a non-negative value: `min(v, 1) + s` and
/// `v + s` are stored alike. A float framebuffer keeps the value.
pub(super) fn stored(m: &mut Module, st: &Statement, value: Handle<Expr>) -> Option<Handle<Expr>> {
    use crate::parser::ast::FramebufferChannel as F;
    let Table::Framebuffer { id, .. } = st.table else { return Some(value) };
    let float = m.framebuffers[id as usize].channels.iter().any(|c| matches!(c, F::Rgba16f | F::Rgba32f));
    let range = m.info(value).interval;
    if float || range.class() == ir::Range::Unsigned || (range.lo >= 0.0 && adds_non_negative(m, st)) {
        return Some(value);
    }
    Builder { module: m }.node(Expr::Math { fun: ir::MathFunction::Saturate, args: vec![value] })
}

/// Whether `st`'s value is `C + s` with `s ≥ 0` by its range, reading no
/// destination alpha.
pub(super) fn adds_non_negative(m: &mut Module, st: &Statement) -> bool {
    let Some(r) = self_read(m, st, FbChannel::Color) else { return false };
    if self_read(m, st, FbChannel::Alpha).is_some_and(|ra| split::depends_on(m, st.value, ra)) {
        return false;
    }
    match affine::affine(&mut Builder { module: m }, st.value, r) {
        Some((coef, offset)) => m.is_constant(coef, 1.0) && m.info(offset).interval.lo >= 0.0,
        None => false,
    }
}

/// An rgb value as the framebuffer holds it: alpha 1.
pub(super) fn widen_rgba(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    match m.info(h).ty {
        ir::Ty::Rgb | ir::Ty::Vec3 => {
            Builder { module: m }.node(Expr::Convert { value: h, to: ir::Ty::Rgba })
        }
        _ => Some(h),
    }
}

/// `h` with the nodes of `map` replaced, rebuilt bottom-up.
pub fn substitute(
    m: &mut Module,
    h: Handle<Expr>,
    map: &HashMap<Handle<Expr>, Handle<Expr>>,
) -> Option<Handle<Expr>> {
    let mut done: HashMap<Handle<Expr>, Handle<Expr>> = map.clone();
    for n in m.reachable(&[h]) {
        if done.contains_key(&n) {
            continue;
        }
        let e = m.exprs[n].clone();
        let ops = e.operands();
        if ops.iter().all(|o| done.get(o).is_none_or(|x| x == o)) {
            done.insert(n, n);
            continue;
        }
        let new = e.map_operands(|o| *done.get(&o).unwrap_or(&o));
        let span = m.span(n);
        let nh = m.intern(new, span).ok()?;
        done.insert(n, nh);
    }
    done.get(&h).copied()
}

/// A statement's framebuffer operation as written, no blend read off its
/// value: the whole value replaces the target, its reads of the target are
/// the target's values before the statement. What the target channel, a
/// discard `c ? a`, a stencil test `σ C ? a` or a stencil update say is
/// taken out (Pipeline Grammar, Sections 3.4-3.5). The program's meaning
/// (`crate::meaning`) runs statements in this form; `classify` goes on to
/// read a blend. A framebuffer blend the statement writes has its source
/// clamped where GL clamps it ([`blended_as_gl`]).
pub fn whole_form(m: &mut Module, st: &Statement, value: Handle<Expr>) -> Result<Form, Diagnostic> {
    let value = blended_as_gl(m, st, value);
    let mut form = Form {
        blend: BlendMode::Replace,
        value,
        condition: None,
        stencil: None,
        depth: None,
        channels: "rgba",
        then_add: None,
        drawn_at: None,
    };
    match st.table {
        Table::Texture(_) => return Ok(form),
        Table::TexCoords(_) => unreachable!("texgen statements are vertex work"),
        Table::Framebuffer { channel: FbChannel::Stencil, .. } => {
            return stencil_write(m, st, value)
                .or_else(|| super::stencil::stencil_form(m, st, value))
                .ok_or_else(|| super::stencil::unsupported(st))
        }
        Table::Framebuffer { channel: FbChannel::Depth, .. } => return Err(unsupported_blend(st, "a write to the depth channel")
            .with_help("the depth channel is written by drawing: `Cl δπl x ← δ x` stores the mesh's nearest depth (a shadow map's first pass, Pipeline Grammar, Section 3.5), and every colour statement on a mesh tests and writes it; a computed value cannot be stored there")),
        Table::Framebuffer { channel: FbChannel::Alpha, .. } => form.channels = "a",
        Table::Framebuffer { channel: FbChannel::Color, .. } => {}
    }
    // `σ C ? a`: a stencil test; `c ? a`: a discard (also under the
    // widening to rgba lowering puts around it).
    if let Expr::Convert { value: inner, to } = m.exprs[value].clone() {
        if let Expr::Select { cond, accept, reject: None } = m.exprs[inner].clone() {
            if let Some(widened) = (Builder { module: m }).node(Expr::Convert { value: accept, to }) {
                form.value = m
                    .intern(Expr::Select { cond, accept: widened, reject: None }, m.span(inner))
                    .unwrap_or(value);
            }
        }
    }
    if let Expr::Select { cond, accept, reject: None } = m.exprs[form.value].clone() {
        // `σ C ? a` passes where the stencil is set (0 ≠ stored), `¬σ C ? a`
        // — the shadow-volume idiom, lit where no volume counted — where it
        // is clear (0 = stored): both a stencil test, for every executor.
        let stencil = self_read(m, st, FbChannel::Stencil);
        let negated = match m.exprs[cond] {
            Expr::Unary { op: crate::ir::UnaryOp::Not, value } => Some(value) == stencil,
            _ => false,
        };
        if stencil.is_some() && (Some(cond) == stencil || negated) {
            let func = if negated {
                crate::pipeline::CompareFunc::Equal
            } else {
                crate::pipeline::CompareFunc::NotEqual
            };
            form.stencil = Some(StencilState { enabled: true, func, reference: 0, ..StencilState::DISABLED });
        } else {
            form.condition = Some(cond);
        }
        form.value = accept;
    }
    Ok(form)
}

/// `T ⊕[decal] C` of an rgba `T` reading neither the colour `r` nor the
/// alpha `ra` of the framebuffer: alpha blending of `T`.
fn decal_over(
    m: &Module,
    v: Handle<Expr>,
    r: Handle<Expr>,
    ra: Option<Handle<Expr>>,
) -> Option<Handle<Expr>> {
    let Expr::Combine { mode: CombineMode::Decal, lhs, rhs } = m.exprs[v] else { return None };
    let reads = |x: Handle<Expr>| split::depends_on(m, lhs, x);
    (rhs == r && m.info(lhs).ty == ir::Ty::Rgba && !reads(r) && !ra.is_some_and(reads)).then_some(lhs)
}

/// `v` without a `saturate` at its top (under a widening to rgba).
fn without_saturate(m: &mut Module, v: Handle<Expr>) -> Handle<Expr> {
    match m.exprs[v] {
        Expr::Math { fun: ir::MathFunction::Saturate, ref args } => args[0],
        Expr::Convert { value, to } => match m.exprs[value] {
            Expr::Math { fun: ir::MathFunction::Saturate, ref args } => {
                let inner = args[0];
                Builder { module: m }.node(Expr::Convert { value: inner, to }).unwrap_or(v)
            }
            _ => v,
        },
        _ => v,
    }
}

/// How the framebuffer's alpha may weigh its own colour.
const MIX_HELP: &str = "blending reads the framebuffer's alpha only to choose between its colour and another, \
                 `(α C)·(C) + (1 − α C)·f` or `(α C)·f + (1 − α C)·(C)`, with `f` not reading `C`: render the \
                 other image into a framebuffer of its own (`C′ δπx ← …`) and write \
                 `C xs ← (α C xs)*(C′ xs) + (1 − α C xs)*(C xs)` (the shadow mask, Pipeline Grammar, Section 3.5)";

/// How to blend an alpha that an alpha write cannot.
const ALPHA_HELP: &str = "write the alpha without reading the framebuffer (`α C δπx ← (T δu x).a`), or blend colour and alpha together in one rgba statement: `C δπx ← (C δπx) ⊕ rgba((1, 1, 1), a)` modulates the alpha by `a` and keeps the colour";

/// A statement that reads its target's colour other than as one blend.
fn non_linear(st: &Statement) -> Diagnostic {
    unsupported_blend(st, "the framebuffer's colour is used non-linearly").with_help(
        "blending computes `C·m + s` of the framebuffer's colour `C`, with `m` and `s` not reading it (Pipeline Grammar, eq. (9)): write the statement so (`C ← (C) ⊕ m`, `C ← (C) ⊕[add] s`), or compute the value in the statement that wrote `C`",
    )
}

pub(super) fn unsupported_blend(st: &Statement, what: &str) -> Diagnostic {
    Diagnostic::error("unsupported-blend", format!("framebuffer blending cannot express this: {what}"), st.span, "this statement")
        .with_help("write the statement as `C ← (C) ⊕ e`, `C ← (C) ⊕[add] e`, `C ← (C) ⊕[add] ((α C) * e)`, or compute the value without reading the framebuffer")
}

/// Reads the framebuffer operation off a statement's (possibly fused) value.
pub fn classify(m: &mut Module, st: &Statement, value: Handle<Expr>) -> Result<Form, Diagnostic> {
    let mut form = whole_form(m, st, value)?;
    if matches!(st.table, Table::Texture(_)) || form.channels == "stencil" {
        return Ok(form);
    }
    let unsupported = |what: &str| unsupported_blend(st, what);
    let r = self_read(m, st, FbChannel::Color);
    let ra = self_read(m, st, FbChannel::Alpha);
    let uses =
        |m: &Module, h: Handle<Expr>, x: Option<Handle<Expr>>| x.is_some_and(|x| split::depends_on(m, h, x));
    let v = form.value;
    if !uses(m, v, r) && !uses(m, v, ra) {
        return Ok(form);
    }
    // `saturate(C·m + s)` into a fixed-point framebuffer is the clamp GL
    // applies to what it blends there anyway (OpenGL 1.2.1 §4.1.8).
    let v = if float_framebuffer(m, st) { v } else { without_saturate(m, v) };
    form.value = v;
    if form.channels == "a" {
        return Err(unsupported("an alpha write that reads the framebuffer").with_help(ALPHA_HELP));
    }
    if let Some(r) = r.filter(|r| split::depends_on(m, v, *r)) {
        let decal = decal_over(m, v, r, ra).map(|lhs| (BlendMode::AlphaBlend, lhs));
        if let Some((blend, x)) = decal.or_else(|| min_max_blend(m, v, r, ra)) {
            form.blend = blend;
            form.value = x;
            return Ok(form);
        }
        let (coef, offset) =
            affine::affine(&mut Builder { module: m }, v, r).ok_or_else(|| non_linear(st))?;
        let choice = ra
            .and_then(|ra| dst_alpha_choice(m, coef, offset, ra))
            .or_else(|| src_alpha_choice(m, coef, offset).map(|x| (BlendMode::AlphaBlend, x)));
        if let Some((blend, x)) = choice {
            form.blend = blend;
            form.value = x;
            return Ok(form);
        }
        if uses(m, coef, ra) {
            return Err(unsupported("the framebuffer's alpha scales its own colour").with_help(MIX_HELP));
        }
        let one = m.is_constant(coef, 1.0);
        let zero = m.is_constant(offset, 0.0);
        if one && zero {
            form.value = offset; // C ← C: nothing to do (specialization removes it)
            form.blend = BlendMode::Add;
            return Ok(form);
        }
        if !one && uses(m, offset, ra) {
            return Err(unsupported("both a colour scale and a destination-alpha term"));
        }
        if one {
            // C + s, or C + Cα·s (GL_DST_ALPHA, GL_ONE).
            if let Some(x) = ra.and_then(|ra| alpha_factor(m, offset, ra)) {
                form.blend = BlendMode::DstAlphaAdd;
                form.value = x;
            } else if uses(m, offset, ra) {
                return Err(unsupported(
                    "the destination alpha appears other than as a factor of the added term",
                ));
            } else {
                form.blend = BlendMode::Add;
                form.value = offset;
            }
        } else if zero {
            form.blend = BlendMode::Modulate;
            form.value = coef;
        } else {
            // C·m + s: modulate, then add (two passes).
            form.blend = BlendMode::Modulate;
            form.value = coef;
            form.then_add = Some(offset);
        }
        return Ok(form);
    }
    // Only the alpha is read: `C ← (α C) · x` (GL_DST_ALPHA, GL_ZERO),
    // `rgba((α C)·x, α C)` = (α C) · rgba(x, 1) included.
    match ra.and_then(|ra| alpha_factor(m, v, ra).or_else(|| composed_alpha_factor(m, v, ra))) {
        Some(x) => {
            form.blend = BlendMode::DstAlphaModulate;
            form.value = x;
            Ok(form)
        }
        None if ra.is_some_and(|ra| widened_alpha_product(m, v, ra)) => Err(unsupported_blend(st, "the value is rgb, so the statement writes alpha 1, while a blend by the destination alpha would scale the alpha too")
            .with_help("give the alpha you mean: `rgba((α C δπx) * c, α C δπx)` keeps the alpha (one blend by destination alpha), or write the colour and the alpha in two statements")),
        None => Err(unsupported("the framebuffer's alpha is used other than as a factor")),
    }
}

/// `max(C, f)` (`min(C, f)`, `max(C, f, g)`: a chain with the
/// framebuffer's colour `r` one operand) with the others not reading the
/// framebuffer: GL's MAX (MIN) blend equation of the others' `max`
/// (EXT_blend_minmax; WebGPU's `max` operation), `C ← max(C, f)` with the
/// factors ignored — not affine in `C`, so no `C·m + s` blend computes it.
/// The blend and `f`; the planner refuses it where the target's blender
/// lacks the equation (`Storage::min_max`).
fn min_max_blend(
    m: &mut Module,
    v: Handle<Expr>,
    r: Handle<Expr>,
    ra: Option<Handle<Expr>>,
) -> Option<(BlendMode, Handle<Expr>)> {
    let (fun, blend) = match &m.exprs[v] {
        Expr::Math { fun: ir::MathFunction::Max, args } if args.len() == 2 => {
            (ir::MathFunction::Max, BlendMode::Max)
        }
        Expr::Math { fun: ir::MathFunction::Min, args } if args.len() == 2 => {
            (ir::MathFunction::Min, BlendMode::Min)
        }
        _ => return None,
    };
    let link = |e: &Expr| matches!(e, Expr::Math { fun: f, args } if *f == fun && args.len() == 2);
    let mut ops = m.chain_operands(v, link);
    let at = ops.iter().position(|&o| o == r)?;
    ops.remove(at);
    let reads = |x: Handle<Expr>| ops.iter().any(|&o| split::depends_on(m, o, x));
    if ops.is_empty() || reads(r) || ra.is_some_and(reads) {
        return None;
    }
    let mut acc = ops[0];
    for &o in &ops[1..] {
        acc = Builder { module: m }.node(Expr::Math { fun, args: vec![acc, o] })?;
    }
    (m.info(acc).ty == m.info(v).ty).then_some((blend, acc))
}

/// `rgba(α·x, α)` or `rgba(α·x, α·y)` with α the destination alpha `ra`:
/// the factor `rgba(x, 1)` or `rgba(x, y)`.
pub(super) fn composed_alpha_factor(
    m: &mut Module,
    h: Handle<Expr>,
    ra: Handle<Expr>,
) -> Option<Handle<Expr>> {
    let Expr::Compose { ty: ir::Ty::Rgba, ref components } = m.exprs[h] else { return None };
    let [c, a] = components[..] else { return None };
    let x = alpha_factor(m, c, ra)?;
    let y =
        if a == ra { Builder { module: m }.constant(ir::Ty::Scalar, 1.0)? } else { alpha_factor(m, a, ra)? };
    Builder { module: m }.node(Expr::Compose { ty: ir::Ty::Rgba, components: vec![x, y] })
}

/// `(α C)·x` of an rgb x, widened to rgba (alpha 1): not one blend.
pub(super) fn widened_alpha_product(m: &Module, h: Handle<Expr>, ra: Handle<Expr>) -> bool {
    matches!(m.exprs[h], Expr::Convert { value, to: ir::Ty::Rgba } if alpha_factor(m, value, ra).is_some())
}

/// `coef·C + offset` as a choice by the framebuffer's alpha `ra` between
/// its colour and another value `f`: `Cα·C + (1 − Cα)·f`
/// ([`BlendMode::DstAlphaMix`], the shadow mask's compositing) or
/// `(1 − Cα)·C + Cα·f` ([`BlendMode::DstAlphaLerp`]); the mode and `f`.
fn dst_alpha_choice(
    m: &mut Module,
    coef: Handle<Expr>,
    offset: Handle<Expr>,
    ra: Handle<Expr>,
) -> Option<(BlendMode, Handle<Expr>)> {
    let omr = Builder { module: m }.one_minus(ra)?;
    if coef == ra {
        alpha_factor(m, offset, omr).map(|x| (BlendMode::DstAlphaMix, x))
    } else if coef == omr {
        alpha_factor(m, offset, ra).map(|x| (BlendMode::DstAlphaLerp, x))
    } else {
        None
    }
}
/// `coef·C + offset` as alpha blending, `(1 − a)·C + a·c` with `a` a
/// scalar and `c` a colour not reading `C` (GL_SRC_ALPHA,
/// GL_ONE_MINUS_SRC_ALPHA): the source `rgba(c, a)`. This is the
/// PlayStation 2's `(Cs − Cd)·As + Cd` and Direct3D's `lerp(Cd, Cs, As)`
/// multiplied out. The statement's alpha must be the destination's kept
/// (`coef`'s alpha 1, `offset`'s 0): the blend writes colour only.
fn src_alpha_choice(m: &mut Module, coef: Handle<Expr>, offset: Handle<Expr>) -> Option<Handle<Expr>> {
    let Expr::Compose { ty: ir::Ty::Rgba, components: ref o } = m.exprs[offset] else { return None };
    let [c_a, zero] = o[..] else { return None };
    let Expr::Binary { op: BinaryOp::Mul, lhs, rhs } = m.exprs[c_a] else { return None };
    let scalar = |h: Handle<Expr>| m.info(h).ty == ir::Ty::Scalar;
    let (c, a) = if scalar(rhs) {
        (lhs, rhs)
    } else if scalar(lhs) {
        (rhs, lhs)
    } else {
        return None;
    };
    // The colour's coefficient `1 − a`, its alpha's 1: as built, or folded
    // into a constant where `a` is one (`(Cs − Cd)·½ + Cd`).
    let one_minus_a = match &m.exprs[coef] {
        Expr::Compose { ty: ir::Ty::Rgba, components: k } if k.len() == 2 => {
            m.is_constant(k[1], 1.0) && affine_in(m, k[0], a) == Some((-1.0, 1.0))
        }
        Expr::Constant(k) => {
            let q = affine_in(m, a, coef).map(|(_, q)| 1.0 - q);
            k.ty == ir::Ty::Rgba && k.values()[3] == 1.0 && k.values()[..3].iter().all(|x| Some(*x) == q)
        }
        _ => false,
    };
    if !one_minus_a || !m.is_constant(zero, 0.0) || m.info(c).ty != ir::Ty::Rgb {
        return None;
    }
    Builder { module: m }.node(Expr::Compose { ty: ir::Ty::Rgba, components: vec![c, a] })
}

/// `h = p·a + q` with constants `p`, `q` the same in every channel:
/// `(p, q)`; `None` where `h` is built of anything but `a`, constants,
/// sums, differences, negations, constant scales and splats.
fn affine_in(m: &Module, h: Handle<Expr>, a: Handle<Expr>) -> Option<(f64, f64)> {
    if h == a {
        return Some((1.0, 0.0));
    }
    match &m.exprs[h] {
        Expr::Constant(c) => {
            let v = c.values();
            v.iter().all(|x| *x == v[0]).then_some((0.0, v[0]))
        }
        Expr::Convert { value, .. } if m.info(*value).ty == ir::Ty::Scalar => affine_in(m, *value, a),
        Expr::Unary { op: crate::ir::UnaryOp::Neg, value } => affine_in(m, *value, a).map(|(p, q)| (-p, -q)),
        Expr::Binary { op, lhs, rhs } => {
            let ((p1, q1), (p2, q2)) = (affine_in(m, *lhs, a)?, affine_in(m, *rhs, a)?);
            match op {
                BinaryOp::Add => Some((p1 + p2, q1 + q2)),
                BinaryOp::Sub => Some((p1 - p2, q1 - q2)),
                BinaryOp::Mul if p1 == 0.0 => Some((q1 * p2, q1 * q2)),
                BinaryOp::Mul if p2 == 0.0 => Some((p1 * q2, q1 * q2)),
                _ => None,
            }
        }
        _ => None,
    }
}

/// `h = ra · x` (either order): `x`.
pub(super) fn alpha_factor(m: &Module, h: Handle<Expr>, ra: Handle<Expr>) -> Option<Handle<Expr>> {
    match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs } => {
            if lhs == ra && !split::depends_on(m, rhs, ra) {
                Some(rhs)
            } else if rhs == ra && !split::depends_on(m, lhs, ra) {
                Some(lhs)
            } else {
                None
            }
        }
        _ => None,
    }
}

/// `σ C δπx ← (σ C δπx) OR (z δπx′ > z C δπx′)` (Pipeline Grammar, Section 3.5):
/// set the stencil where the fragment's depth compares with the stored one;
/// no colour, no depth write.
pub(super) fn stencil_write(m: &Module, st: &Statement, value: Handle<Expr>) -> Option<Form> {
    let Expr::Binary { op: BinaryOp::Or, lhs, rhs } = m.exprs[value] else { return None };
    let own = self_read(m, st, FbChannel::Stencil)?;
    let cmp = other_operand(lhs, rhs, own)?;
    let Expr::Binary { op, lhs: a, rhs: b } = m.exprs[cmp] else { return None };
    let stored_is_b = matches!(m.exprs[b], Expr::FramebufferRead { channel: FbChannel::Depth, .. });
    // The fragment's own depth `z δπx′`: the shadow volume x′ is what this
    // pass rasterizes (seeds/001 Section 3.5: "the shadow volume vertices
    // are x′"), not the object x of the statement's index.
    let Expr::Depth(drawn_at) = m.exprs[if stored_is_b { a } else { b }] else { return None };
    let func = match (op, stored_is_b) {
        (BinaryOp::Gt, true) | (BinaryOp::Lt, false) => crate::pipeline::CompareFunc::Greater,
        (BinaryOp::Ge, true) | (BinaryOp::Le, false) => crate::pipeline::CompareFunc::GreaterEqual,
        (BinaryOp::Lt, true) | (BinaryOp::Gt, false) => crate::pipeline::CompareFunc::Less,
        (BinaryOp::Le, true) | (BinaryOp::Ge, false) => crate::pipeline::CompareFunc::LessEqual,
        _ => return None,
    };
    Some(Form {
        blend: BlendMode::Replace,
        value,
        condition: None,
        stencil: Some(StencilState {
            enabled: true,
            func: crate::pipeline::CompareFunc::Always,
            reference: 1,
            pass: StencilOp::Replace,
            ..StencilState::DISABLED
        }),
        depth: Some(DepthState { func, write: false }),
        channels: "stencil",
        then_add: None,
        drawn_at: Some(drawn_at),
    })
}

/// What `profile`'s storage does between passes (`Storage::float_main` is
/// the statement's, set where it is planned).
pub(super) fn storage_of(profile: &Profile) -> Storage {
    Storage {
        float_temps: profile.float_textures,
        float_main: false,
        subtract: profile.blend_modes.iter().any(|b| b == "subtract"),
        min_max: ["min", "max"].iter().all(|m| profile.blend_modes.iter().any(|b| b == m)),
        by_channel: false,
    }
}

/// Whether `st` writes a framebuffer declared `rgba16f`/`rgba32f`.
pub(super) fn float_framebuffer(m: &Module, st: &Statement) -> bool {
    use crate::parser::ast::FramebufferChannel as F;
    let Table::Framebuffer { id, .. } = st.table else { return false };
    m.framebuffers
        .get(id as usize)
        .is_some_and(|f| f.channels.iter().any(|c| matches!(c, F::Rgba16f | F::Rgba32f)))
}

/// The pieces of one (fused) statement.
pub(super) fn plan_form(
    m: &mut Module,
    fit: &dyn FitCheck,
    cache: &mut SplitCache,
    st: &Statement,
    form: &Form,
    storage: Storage,
    search: Search,
) -> Result<Vec<Piece>, Overflow> {
    if form.channels == "stencil" {
        return stencil_pieces(m, form);
    }
    if matches!(form.blend, BlendMode::Max | BlendMode::Min) && !storage.min_max {
        return Err(Overflow {
            resource: "has no MIN/MAX blend equations (EXT_blend_minmax), which `max(C, f)` and `min(C, f)` \
                       of the framebuffer's colour need"
                .into(),
            need: 0,
            have: 0,
            at: None,
            help: None,
        });
    }
    let storage = Storage { float_main: storage.float_temps && float_framebuffer(m, st), ..storage };
    if let Some(one) = gl_clamped_pass(m, fit, form, storage) {
        return Ok(one);
    }
    let refusals = cache.clamp_refusals;
    match split_form(m, fit, cache, st, form, storage, search) {
        // Every blend equation and clamp works channel by channel (OpenGL
        // 1.2.1 §4.1.6): where the hulls refused the splits at the clamps,
        // the search again with each channel's range (a sum of coloured
        // lights halved into a temporary, its red and green bounded
        // apart). A second search, not the first: the plans that the
        // first finds stay what they were, and its results are not mixed
        // with the second's (the memo is forgotten before and after).
        Err(o) if cache.clamp_refusals > refusals && !storage.by_channel => {
            cache.forget_plans();
            let again = split_form(m, fit, cache, st, form, Storage { by_channel: true, ..storage }, search);
            cache.forget_plans();
            again.map_err(|_| o)
        }
        r => r,
    }
}

/// [`plan_form`]'s search for a split of `form` with `storage`'s clamps.
fn split_form(
    m: &mut Module,
    fit: &dyn FitCheck,
    cache: &mut SplitCache,
    st: &Statement,
    form: &Form,
    storage: Storage,
    search: Search,
) -> Result<Vec<Piece>, Overflow> {
    let overflow = fit.fits(m, form.value).err();
    let clamp_refusals = cache.clamp_refusals;
    let mut splitter = Splitter::new(m, fit, cache, st.index, storage);
    if search == Search::Exhaustive {
        splitter = splitter.exhaustive();
    }
    let mut pieces: Vec<Piece> = match splitter.plan(form.blend, form.value) {
        Some(p) => p.iter().cloned().collect(),
        None => {
            let o = overflow.unwrap_or_else(no_split);
            if splitter.out_of_budget() {
                return Err(search_stopped(o));
            }
            return Err(if cache.clamp_refusals > clamp_refusals {
                Overflow { resource: format!("{o}, {CLAMPED_BETWEEN_PASSES}"), need: 0, have: 0, ..o }
            } else {
                o
            });
        }
    };
    if let Some(s) = form.then_add {
        let o = fit.fits(splitter.module, s).err();
        let Some(p) = splitter.plan(BlendMode::Add, s) else { return Err(o.unwrap_or_else(no_split)) };
        pieces.extend(
            p.iter().map(|q| Piece {
                why: "C ← C·m + s: the added term, after the modulation".into(),
                ..q.clone()
            }),
        );
    }
    through_clamps(m, fit, cache, &pieces, storage)
}

/// How a refusal ends when the splits that fit were refused for the
/// clamps between passes ([`through_clamps`]): [`super::rewrite`] reads
/// it to say so first when every form was refused so.
pub(super) const CLAMPED_BETWEEN_PASSES: &str =
    "and the splits that fit would store a value outside [0, 1] between passes, where the 8-bit framebuffer's clamp changes it";

/// The refusal of a value whose search for a split stopped at its budget
/// ([`super::split::SEARCH_BUDGET`]), with what the user can change.
fn search_stopped(o: Overflow) -> Overflow {
    Overflow {
        resource: format!(
            "{o}, and the search for a split stopped after checking {} candidate passes without finding one \
             (a value nested and shared this many levels deep offers more splits than that)",
            super::split::SEARCH_BUDGET
        ),
        need: 0,
        have: 0,
        help: Some(
            "write the levels as statements, each blending onto what the framebuffer holds \
             (`C δπx ← …;` then `C δπx ← lerp(C δπx, (C δπx) * T δu x, 0.5);`), or target wgsl"
                .into(),
        ),
        ..o
    }
}

/// The refusal of a value no split fits.
fn no_split() -> Overflow {
    Overflow {
        resource: "has no split into passes of this target".into(),
        need: 0,
        have: 0,
        at: None,
        help: None,
    }
}

/// A stencil update's one pass: the depth test and the stencil operation
/// of the pass state do the comparison; the fragment computes nothing and
/// reads no texture (the stored depth `z C δπx′` is the depth buffer, not
/// a unit).
fn stencil_pieces(m: &mut Module, form: &Form) -> Result<Vec<Piece>, Overflow> {
    let one =
        m.intern(Expr::Constant(crate::ir::Constant::scalar(1.0)), m.span(form.value)).map_err(|_| {
            Overflow {
                resource: "a constant stencil-pass output".into(),
                need: 1,
                have: 0,
                at: None,
                help: None,
            }
        })?;
    Ok(vec![Piece {
        blend: BlendMode::Replace,
        value: one,
        dest: Dest::Main,
        alpha: true,
        why: String::new(),
        holds: None,
    }])
}

/// The one pass of a blend the program writes, `(T) ⊕ saturate(x)` as
/// [`blended_as_gl`] reads it, where `x` fits a pass: GL clamps the
/// blend's source on the fixed-point target, so the pass blends `x` and
/// the clamp happens in the blender (Kilgard 2000's pass 2 modulates by
/// ambient + diffuse so). `None` otherwise: `saturate(x)` is then split
/// like any value, exact through the clamps.
fn gl_clamped_pass(m: &mut Module, fit: &dyn FitCheck, form: &Form, storage: Storage) -> Option<Vec<Piece>> {
    let Expr::Math { fun: ir::MathFunction::Saturate, ref args } = m.exprs[form.value] else { return None };
    let x = args[0];
    if form.blend == BlendMode::Replace || form.then_add.is_some() || !storage.clamps(Dest::Main) {
        return None;
    }
    // One pass of `x` itself, the blender clamping its source (the
    // splitter would split a factor past 1 further, to blend it exactly).
    fit.fits(m, x).ok()?;
    Some(vec![Piece::whole(form.blend, x)])
}

/// The statement's pieces as the blender runs them ([`split::signed_terms`]),
/// or a refusal when a clamp between them, or of a blend's source, would
/// change what the statement means ([`split::exact_through_clamps`]).
pub(super) fn through_clamps(
    m: &mut Module,
    fit: &dyn FitCheck,
    cache: &mut SplitCache,
    pieces: &[Piece],
    storage: Storage,
) -> Result<Vec<Piece>, Overflow> {
    let refusal = |what: &str| {
        Overflow {
        resource: format!(
            "cannot be blended exactly on this target: {what}, where the 8-bit framebuffer's clamp changes it"
        ),
        need: 0,
        have: 0,
        at: None,
        help: Some(if storage.float_temps {
            "keep each blended term in [0, 1] (a `saturate(…)` where a clamp is meant), or declare the framebuffer `rgba16f`"
        } else {
            "keep each blended term in [0, 1] (a `saturate(…)` where a clamp is meant), or target wgsl with an `rgba16f` framebuffer"
        }
        .into()),
    }
    };
    if !split::exact_through_clamps(m, pieces, storage, &cache.clamped_temps) {
        cache.clamp_refusals += 1;
        return Err(refusal(if storage.subtract {
            "its passes would blend a term outside [0, 1] or store one between passes"
        } else {
            "its passes would blend a term outside [0, 1] or store one between passes, and the target's blender cannot subtract"
        }));
    }
    split::signed_terms(m, fit, pieces, storage).ok_or_else(|| {
        refusal("the negation of a term below 0, or half of a factor above 1, does not fit a pass")
    })
}

/// The operand of a binary node that is not `own` (the statement's read of
/// its own target), where one of them is.
pub(super) fn other_operand(lhs: Handle<Expr>, rhs: Handle<Expr>, own: Handle<Expr>) -> Option<Handle<Expr>> {
    if lhs == own {
        Some(rhs)
    } else if rhs == own {
        Some(lhs)
    } else {
        None
    }
}
