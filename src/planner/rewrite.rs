//! A statement that does not plan as written, planned in its equivalent
//! forms ([`super::algebra`]), and the refusal that says what was tried.

use super::*;

/// A statement's equivalent forms: the value, the value added after a
/// modulation (`C ← C·m + s`), and what made them.
pub(super) type Candidate = (Handle<Expr>, Option<Handle<Expr>>, &'static str);
/// A statement planned in an equivalent form, with what the form is; or
/// each form tried and why it does not plan.
pub(super) type Rewritten = Result<(Form, Vec<Piece>, &'static str), Vec<(&'static str, Overflow)>>;

/// [`candidate`], then — for a single statement — its equivalent forms
/// ([`rewritten`]): when it does not plan as written, or when it was
/// rewritten already so that the target could run it (`Fits::canonical`)
/// and another form may be cheaper. `rewrites` records the statements
/// planned in another form, with the reason. `Err(Err(d))`: refused for
/// resources in every form, `d` saying what was tried.
#[allow(clippy::too_many_arguments)]
pub(super) fn planned_or_rewritten(
    m: &mut Module,
    profile: &Profile,
    search: Search,
    fits: &mut Fits,
    baked: bool,
    stmts: &[usize],
    value: Handle<Expr>,
    rewrites: &mut HashMap<usize, String>,
    fused_forms: bool,
) -> Result<(Form, Vec<Piece>), Result<Unplanned, Diagnostic>> {
    // The statement's forms and splits share one search budget.
    for cache in [&mut fits.cache, &mut fits.compiler_cache] {
        cache.statement_began = cache.checked.get();
    }
    let single = stmts.len() == 1;
    let as_written = candidate(m, search, fits, baked, stmts, value, storage_of(profile));
    if !single && as_written.is_err() && fused_forms {
        if let Some(planned) = fused_rewritten(m, search, fits, baked, stmts, value, storage_of(profile)) {
            return Ok(planned);
        }
    }
    let canonical = fits.canonical.contains(&value);
    let (written_cost, why) = match &as_written {
        Ok((_, pieces)) if single && canonical => (
            Some(split::cost(m, fits.fit(baked), pieces)),
            format!("as written {} cannot run it", profile.name),
        ),
        // Render-to-texture is the last resort of a split: a form may
        // plan without it (a sum of lights merged back into one δ).
        Ok((_, pieces)) if single && pieces.iter().any(|p| p.dest != Dest::Main) => (
            Some(split::cost(m, fits.fit(baked), pieces)),
            format!("as written it takes {} passes through a temporary", pieces.len()),
        ),
        // A sum repeating a term (`a + a` doubled) as written takes a
        // pass per pair of terms, counted (`2ⁿ·a`) one per doubling.
        Ok((_, pieces)) if single && pieces.len() > 1 && algebra::repeats_a_term(m, value) => (
            Some(split::cost(m, fits.fit(baked), pieces)),
            format!("as written it takes {} passes", pieces.len()),
        ),
        Err(Unplanned::Overflow(o)) if single => (None, format!("as written it {o}")),
        _ => return as_written.map_err(Ok),
    };
    let tried = match rewritten(m, search, fits, baked, stmts[0], storage_of(profile)) {
        Ok((f, mut p, what)) if written_cost.is_none_or(|c| split::cost(m, fits.fit(baked), &p) < c) => {
            let note = format!("{what} ({why})");
            note_rewrite(&mut p, &note);
            rewrites.insert(stmts[0], note);
            return Ok((f, p));
        }
        Ok(_) => Vec::new(),
        Err(tried) => tried,
    };
    match as_written {
        Ok(planned) if !canonical => Ok(planned),
        Ok((form, mut pieces)) => {
            // The canonical form the target runs is the cheapest.
            let note = format!("{} ({why})", algebra::CANONICAL);
            note_rewrite(&mut pieces, &note);
            rewrites.insert(stmts[0], note);
            Ok((form, pieces))
        }
        Err(Unplanned::Overflow(o)) => {
            let st = m.statements[stmts[0]].clone();
            Err(Err(cannot_split(m, &st, profile, &o, &tried)))
        }
        Err(why) => Err(Ok(why)),
    }
}

/// How [`fused_rewritten`]'s piece begins: the run's reason quotes it.
pub(super) const FUSED_IN: &str = "fused in a form";

/// Statements fused into one value that does not fit one pass as
/// written, fused in an equivalent form of that value that does
/// (`C ← T4; C ← C·(T0·T0 + T0·T0 + …)` is `T4·(4·T0·T0)` multiplied out
/// with like terms collected). Only one pass, as fusing is
/// ([`candidate`]); the first form that fits, its piece saying which.
fn fused_rewritten(
    m: &mut Module,
    search: Search,
    fits: &mut Fits,
    baked: bool,
    stmts: &[usize],
    value: Handle<Expr>,
    storage: Storage,
) -> Option<(Form, Vec<Piece>)> {
    for f in algebra::forms(m, value, algebra::MAX_TERMS) {
        if let Ok((form, mut pieces)) = candidate(m, search, fits, baked, stmts, f.value, storage) {
            note_rewrite(&mut pieces, &format!("{FUSED_IN} {}", f.what));
            return Some((form, pieces));
        }
    }
    None
}

/// The first pass of a statement planned in an equivalent form says which
/// (the pass reasons of a split quote their pieces).
pub(super) fn note_rewrite(pieces: &mut [Piece], note: &str) {
    if let Some(first) = pieces.first_mut() {
        let why = if first.why.is_empty() { "the part rendered first" } else { first.why.as_str() };
        first.why = format!("{note}; {why}");
    }
}

/// A single statement that does not plan as written, planned in the
/// equivalent forms of its blended value ([`algebra`]; with its clamp left
/// to the 8-bit framebuffer's, which clamps anyway): the cheapest that
/// plans by [`split::cost`] (the cost model, then passes, then fetches),
/// with what it is; else each form tried and why it does not plan.
pub(super) fn rewritten(
    m: &mut Module,
    search: Search,
    fits: &mut Fits,
    baked: bool,
    s: usize,
    storage: Storage,
) -> Rewritten {
    let st = m.statements[s].clone();
    let Ok(form) = classify(m, &st, st.value) else { return Err(Vec::new()) };
    // The exhaustive search enumerates every grouping of the terms.
    let max = if search == Search::Exhaustive { 8 } else { algebra::MAX_TERMS };
    let mut candidates: Vec<Candidate> = Vec::new();
    let adds = form.then_add.map(|a| algebra::forms(m, a, max)).unwrap_or_default();
    let add_of = |what: &str| adds.iter().find(|f| f.what == what).map(|f| f.value).or(form.then_add);
    for f in algebra::forms(m, form.value, max) {
        candidates.push((f.value, add_of(f.what), f.what));
    }
    for f in &adds {
        if candidates.iter().all(|c| c.2 != f.what) {
            candidates.push((form.value, Some(f.value), f.what));
        }
    }
    if let Some(x) = framebuffer_clamped(m, &st, &form) {
        let what = "with its clamp left to the framebuffer's";
        candidates.push((x, form.then_add, what));
        for f in algebra::forms(m, x, max) {
            candidates.push((f.value, form.then_add, what));
        }
    }
    for (value, what) in clamped_source_forms(m, form.value, max) {
        candidates.push((value, add_of(what), what));
    }
    if storage.clamps(Dest::Temp(0)) {
        candidates.extend(own_clamp_forms(m, form.value, &candidates));
    }
    let mut best: Option<(split::Cost, Form, Vec<Piece>, &'static str)> = None;
    let mut tried = Vec::new();
    for (value, then_add, what) in candidates {
        let f = Form { value, then_add, ..form.clone() };
        let (fit, cache) =
            if baked { (&fits.compiler, &mut fits.compiler_cache) } else { (&fits.target, &mut fits.cache) };
        match plan_form(m, fit, cache, &st, &f, storage, search) {
            Ok(pieces) => {
                let c = split::cost(m, fit, &pieces);
                if best.as_ref().is_none_or(|b| c < b.0) {
                    best = Some((c, f, pieces, what));
                }
            }
            Err(o) => tried.push((what, o)),
        }
    }
    best.map(|(_, f, p, what)| (f, p, what)).ok_or(tried)
}

/// The blend's source GL clamps (`C ← (C) ⊕ x` reads `saturate(x)`,
/// [`super::form::blended_as_gl`]; widened to rgba or not) with `x` in
/// each of its equivalent forms: the clamp is of the value, whatever form
/// it is written in, so `(C) ⊕ (mix(T0, δl, T3.a) + T0)` plans as its
/// expansion does.
fn clamped_source_forms(m: &mut Module, v: Handle<Expr>, max: usize) -> Vec<(Handle<Expr>, &'static str)> {
    let (x, widened) = match m.exprs[v] {
        Expr::Convert { value, to: ir::Ty::Rgba } => (value, true),
        _ => (v, false),
    };
    let Expr::Math { fun: ir::MathFunction::Saturate, ref args } = m.exprs[x] else { return Vec::new() };
    let inner = args[0];
    let mut out = Vec::new();
    for f in algebra::forms(m, inner, max) {
        let mut b = Builder { module: m };
        let clamped = b.node(Expr::Math { fun: ir::MathFunction::Saturate, args: vec![f.value] });
        let value = match (clamped, widened) {
            (Some(c), true) => b.node(Expr::Convert { value: c, to: ir::Ty::Rgba }),
            (c, _) => c,
        };
        out.extend(value.map(|value| (value, f.what)));
    }
    out
}

/// A value in [0, 1] is its own clamp, `v` = `saturate(v)`: each form of
/// it whose bound leaves [0, 1] (`mix(T0, T1, a)²` multiplied out is three
/// terms whose bounds add to 4) clamped, so that an 8-bit temporary holds
/// the form exactly, the store clamping what its bound says it may exceed
/// (`C ⊕ mix(T0, T1, a)²` on a 2-unit target: the square multiplied out
/// into a temporary, then modulated in, as its expansion written by hand
/// plans). The value is in [0, 1] where its own bound or the bound of any
/// of its `forms` says so (the square written out by hand: its form
/// factored back into `mix(T0, T1, a)·mix(T0, T1, a)` is bounded by 1).
/// The value as written, and values already clamped, give none.
fn own_clamp_forms(m: &mut Module, v: Handle<Expr>, forms: &[Candidate]) -> Vec<Candidate> {
    let unit = |i: ir::Interval| i.lo >= 0.0 && i.hi <= 1.0;
    let clamped = |m: &Module, h: Handle<Expr>| {
        let x = match m.exprs[h] {
            Expr::Convert { value, to: ir::Ty::Rgba } => value,
            _ => h,
        };
        matches!(m.exprs[x], Expr::Math { fun: ir::MathFunction::Saturate, .. })
    };
    // The value's range is the narrowest of its forms' (each equal to it):
    // `mix(T2, T1, a)²` lies in [0, 1], its four terms written out by hand
    // have hulls adding to 4, and the program may be written either way.
    let in_unit = unit(m.info(v).interval) || forms.iter().any(|c| unit(m.info(c.0).interval));
    if !in_unit || clamped(m, v) {
        return Vec::new();
    }
    let mut out = Vec::new();
    for &(value, then_add, what) in forms {
        if then_add.is_some() || unit(m.info(value).interval) || clamped(m, value) {
            continue;
        }
        let mut b = Builder { module: m };
        let Some(c) = b.node(Expr::Math { fun: ir::MathFunction::Saturate, args: vec![value] }) else {
            continue;
        };
        if b.module.info(c).ty == b.module.info(v).ty {
            out.push((c, None, what));
        }
    }
    out
}

/// `x` of a statement writing `saturate(x)` (or `rgba(saturate(x), 1)`)
/// whole into an 8-bit colour framebuffer, which stores it clamped to
/// [0, 1] anyway (Kilgard 2000, Section 5): the clamp happens there, and
/// `x` may split where `saturate(x)` cannot.
pub(super) fn framebuffer_clamped(m: &mut Module, st: &Statement, form: &Form) -> Option<Handle<Expr>> {
    let Table::Framebuffer { id, channel: FbChannel::Color } = st.table else { return None };
    let float = m.framebuffers[id as usize].channels.iter().any(|c| {
        matches!(
            c,
            crate::parser::ast::FramebufferChannel::Rgba16f | crate::parser::ast::FramebufferChannel::Rgba32f
        )
    });
    if float || form.blend != BlendMode::Replace || form.channels != "rgba" {
        return None;
    }
    let saturated = |m: &Module, h: Handle<Expr>| match &m.exprs[h] {
        Expr::Math { fun: ir::MathFunction::Saturate, args } => Some(args[0]),
        _ => None,
    };
    match m.exprs[form.value] {
        Expr::Convert { value, to: ir::Ty::Rgba } => {
            let x = saturated(m, value)?;
            Builder { module: m }.node(Expr::Convert { value: x, to: ir::Ty::Rgba })
        }
        _ => saturated(m, form.value),
    }
}

pub(super) fn cannot_split(
    m: &Module,
    st: &Statement,
    profile: &Profile,
    o: &Overflow,
    tried: &[(&str, Overflow)],
) -> Diagnostic {
    let span = o.at.map(|h| m.span(h)).filter(|s| *s != Span::DETACHED).unwrap_or(st.span);
    let clamped = |o: &Overflow| o.resource.ends_with(form::CLAMPED_BETWEEN_PASSES);
    // As written alone, only where the fragment stage gave no advice of its
    // own (the code generator's help says more than the clamps do).
    if tried.iter().all(|(_, t)| clamped(t)) && (!tried.is_empty() || (clamped(o) && o.help.is_none())) {
        // As written too: what the one pass lacks, without the clamp
        // sentence the headline says itself.
        let suffix = format!(", {}", form::CLAMPED_BETWEEN_PASSES);
        let whole = match o.resource.strip_suffix(&suffix) {
            Some(r) => Overflow { resource: r.to_string(), ..o.clone() },
            None => o.clone(),
        };
        return not_exact_through_clamps(st, profile, &whole, span, tried);
    }
    // A `max` or `min` of two computed values in the statement (not a
    // `max(0, N·L)`): the help says whether the blender could split it.
    let min_max = m.reachable(&[st.value]).into_iter().any(|h| match &m.exprs[h] {
        Expr::Math { fun: ir::MathFunction::Max | ir::MathFunction::Min, args } => {
            args.iter().all(|&a| !matches!(m.exprs[a], Expr::Constant(_)))
        }
        _ => false,
    });
    let d = cannot_split_as_written(st, profile, o, span, min_max);
    if tried.is_empty() {
        return d;
    }
    // What was tried, so that the refusal is not read as if a rewrite
    // would have planned it.
    // One line per kind of form (several forms of one kind, such as the
    // three common factors, usually fail alike): the first's reason.
    let mut forms: Vec<String> = Vec::new();
    let mut seen: Vec<&str> = Vec::new();
    for (what, o) in tried {
        if !seen.contains(what) {
            seen.push(what);
            forms.push(format!("{what}, it {o}"));
        }
    }
    let help = format!(
        "{}; the planner also tried the statement in its equivalent forms, and none plans: {}",
        d.help.clone().unwrap_or_default(),
        forms.join("; ")
    );
    d.with_help(help)
}

/// The refusal of a statement whose every equivalent form splits into
/// passes that fit, but none exactly through the 8-bit clamps (Kilgard
/// 2000, Section 5): that is what stops it, not the resource the whole
/// value overflows as one pass (`(a + b)³` of products of textures: each
/// part fits a pass, but its cross terms `3·a²·b` reach 3).
fn not_exact_through_clamps(
    st: &Statement,
    profile: &Profile,
    o: &Overflow,
    span: Span,
    tried: &[(&str, Overflow)],
) -> Diagnostic {
    let mut forms: Vec<&str> = Vec::new();
    for (what, _) in tried {
        if !forms.contains(what) {
            forms.push(what);
        }
    }
    let wider = if storage_of(profile).float_temps {
        "declare the framebuffer `rgba16f`"
    } else {
        "target wgsl with an `rgba16f` framebuffer"
    };
    Diagnostic::error(
        "cannot-split",
        format!(
            "no split of this statement fits {} exactly: as one pass it {o}, and the splits into passes that fit would blend or store a value outside [0, 1], where the 8-bit framebuffer's clamp changes it",
            profile.name
        ),
        st.span,
        "every split that fits is changed by the clamps between passes".to_string(),
    )
    .with_label(span, format!("as one pass, this part {o}"))
    .with_help(if forms.is_empty() {
        format!("keep each blended term and each partial product in [0, 1] (a `saturate(…)` where a clamp is meant), or {wider}")
    } else {
        format!(
            "keep each blended term and each partial product in [0, 1] (a `saturate(…)` where a clamp is meant), or {wider}; the planner also tried the statement in its equivalent forms ({}), and in each the splits that fit are changed by a clamp",
            forms.join("; ")
        )
    })
}

pub(super) fn cannot_split_as_written(
    st: &Statement,
    profile: &Profile,
    o: &Overflow,
    span: Span,
    min_max: bool,
) -> Diagnostic {
    let splits = blending_splits(profile, min_max);
    Diagnostic::error(
        "cannot-split",
        format!("no split of this statement fits {}: a part that cannot be divided further {o}", profile.name),
        st.span,
        format!("{o}"),
    )
    .with_label(span, "this part".to_string())
    .with_help(if let Some(help) = o.help.as_deref().filter(|h| !h.is_empty()) {
        // The code generator's own advice for the part, then the splits'.
        format!("{help}; {splits} of parts that fit")
    } else if o.have == 0 {
        // Nothing the target has (`length` per fragment), not too little.
        format!("{splits}; compute the part per vertex, bake it into a lookup texture (`= bake(f)`), or target `wgsl`")
    } else {
        format!("{splits}; compute the part per vertex, bake it into a lookup texture, or target a profile with more {}", o.resource)
    })
}

/// What framebuffer blending splits on `profile`: sums and products, and
/// `max`/`min` chains where its blender has GL's MIN and MAX equations
/// (EXT_blend_minmax). Where the statement has a `max` or `min`
/// (`min_max`) and the blender lacks them, it says so.
fn blending_splits(profile: &Profile, min_max: bool) -> String {
    if storage_of(profile).min_max {
        "framebuffer blending can only split sums, products, `max` and `min` (and affine ⊕ chains)"
            .to_string()
    } else if min_max {
        format!(
            "framebuffer blending can only split sums and products (and affine ⊕ chains): a `max` or `min` splits only with the MIN/MAX blend equations (EXT_blend_minmax), which {} does not have",
            profile.name
        )
    } else {
        "framebuffer blending can only split sums and products (and affine ⊕ chains)".to_string()
    }
}
