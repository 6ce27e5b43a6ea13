//! Passes assembled from the chosen pieces: targets, texture units, state,
//! reasons and the plan's values.

use super::*;

/// What assembling passes needs besides the chosen groups.
pub(super) struct AssembleCtx<'a> {
    pub(super) profile: &'a Profile,
    pub(super) realizer: Option<&'a dyn Realizer>,
    /// Texgen statements by the coordinate set they write.
    pub(super) texgen: &'a HashMap<u32, String>,
    pub(super) at: &'a dyn Fn(Span) -> String,
}

/// A pass's span and its fragment stage as the target realized it (a
/// refusal, located, when the generator makes no setup for it).
pub(super) type Stage = (Span, StageSetup);

/// A fragment stage as the target realized it, or its located refusal.
pub(super) type StageSetup = Result<crate::pipeline::FragmentSetup, Box<Diagnostic>>;

pub(super) fn assemble(
    m: &Module,
    ctx: &AssembleCtx,
    chosen: &[Chosen],
    prepared: Prepared,
) -> (PassPlan, Vec<Stage>) {
    let Prepared { removed, per_light, names, .. } = prepared;
    let mut passes = Vec::new();
    let mut stages = Vec::new();
    let mut drawn = Drawn::default();
    let mut roots = Vec::new();
    for (gi, (stmts, form, pieces, reason)) in chosen.iter().enumerate() {
        let group = Group { stmts, form, reason, n: pieces.len() };
        // The passes of a statement split in texture space are drawn object
        // by object (`Pass::object_major`): no depth test orders their
        // texels, and a later object's first pass must replace what an
        // earlier one left where their parameterizations overlap, before
        // the rest of its passes blend onto it.
        let object_major =
            (pieces.len() > 1 && in_texture_space(m, &m.statements[stmts[0]])).then_some(gi as u32);
        for (pi, piece) in pieces.iter().enumerate() {
            let (mut pass, drawn_at, stage) =
                assemble_pass(m, ctx, &group, piece, pi, &mut drawn, &names, &per_light);
            pass.object_major = object_major;
            stages.push(stage);
            roots.extend([piece.value, m.statements[stmts[0]].index, drawn_at]);
            roots.extend(form.condition);
            passes.push(pass);
        }
    }
    let plan = PassPlan {
        target: ctx.profile.name.clone(),
        passes,
        removed,
        values: plan_values(m, &roots, ctx.at),
        approximations: Vec::new(),
        predicted: None,
        measured: None,
    };
    (plan, stages)
}

/// A planned group of statements as [`assemble`] walks it.
pub(super) struct Group<'a> {
    pub(super) stmts: &'a [usize],
    pub(super) form: &'a Form,
    pub(super) reason: &'a str,
    /// Its number of passes.
    pub(super) n: usize,
}

/// What earlier passes drew, for the depth test of the next: a
/// framebuffer's geometry (its table and index) and the temporaries drawn.
#[derive(Default)]
pub(super) struct Drawn {
    /// In the order drawn (the last into a framebuffer is reused).
    pub(super) main: Vec<(Table, Handle<Expr>)>,
    /// The same, as a set: a plan of many passes asks once per pass.
    main_set: rustc_hash::FxHashSet<(Table, Handle<Expr>)>,
    temps: rustc_hash::FxHashSet<u32>,
}

/// Pass `pi` of a group: where it draws, what it binds, its state and why;
/// and the geometry it is drawn at.
#[allow(clippy::too_many_arguments)]
pub(super) fn assemble_pass(
    m: &Module,
    ctx: &AssembleCtx,
    group: &Group,
    piece: &Piece,
    pi: usize,
    drawn: &mut Drawn,
    names: &[String],
    per_light: &PerLight,
) -> (Pass, Handle<Expr>, Stage) {
    let Group { stmts, form, .. } = *group;
    let st = &m.statements[stmts[0]];
    let in_texture_space = in_texture_space(m, st);
    let mesh = st.freq == Frequency::Fragment || in_texture_space;
    // seeds/001 (10), `C δxs ← (C δxs) ⊕ (δ p s x …)`: a static viewpoint —
    // the pass reuses the vertices the last mesh pass into the same
    // framebuffer projected (`reused_projection` checked there is one),
    // with its depth (equal, no write).
    let reused = (mesh && form.drawn_at.is_none() && matches!(m.exprs[st.index], Expr::Pixel { .. }))
        .then(|| drawn.main.iter().rev().find(|(t, _)| same_framebuffer(t, &st.table)).cloned())
        .flatten();
    let drawn_at = reused.as_ref().map_or(form.drawn_at.unwrap_or(st.index), |(_, h)| *h);
    let geometry = if st.freq == Frequency::Screen {
        Geometry::Screen
    } else if mesh {
        Geometry::Mesh { projection: projection_name(m, drawn_at) }
    } else {
        Geometry::Texels
    };
    // The discard's condition is computed by the pass too: its lookups are
    // bound and its operations counted with the value's.
    let reached = m.reachable(&[piece.value].into_iter().chain(form.condition).collect::<Vec<_>>());
    let u = Usage::of_reached(m, &reached);
    let textures = texture_bindings(m, st, &u);
    let key = reused.unwrap_or_else(|| (st.table.depth_target(), depth_key(m, st.index)));
    let state = pass_state(form, piece, &geometry, in_texture_space, drawn, key);
    // A `bake` table is the compiler's: no combiner setup to judge.
    let baked = m.is_baked(st);
    let stage = if baked {
        Ok(crate::pipeline::FragmentSetup::Baked)
    } else {
        combiner_setup(m, ctx.realizer, piece.value, &textures)
    };
    let reason = pass_reason(group, piece, pi, names, ctx.profile);
    let one = |v: &[Option<u32>]| match stmts {
        [s] => v.get(*s).copied().flatten(),
        _ => None,
    };
    let pass = Pass {
        statements: {
            let mut v: Vec<usize> =
                stmts.iter().map(|s| per_light.source.get(*s).copied().unwrap_or(*s)).collect();
            v.dedup();
            v
        },
        light: one(&per_light.light),
        objects: match stmts {
            [s] => per_light.objects.get(*s).cloned().flatten(),
            _ => None,
        },
        object_major: None,
        at: (ctx.at)(st.span),
        reason: if baked {
            format!("{reason}: a `bake` table, computed by the compiler on the CPU, which the target samples")
        } else {
            reason
        },
        target: pass_target(m, st, piece, form),
        geometry,
        vertex: VertexWork {
            position: mesh.then_some(drawn_at.index() as u32),
            interpolants: u.interpolants.iter().map(|h| h.index() as u32).collect(),
            texgen: texgen_of(m, &reached, ctx.texgen),
        },
        textures,
        fragment: FragmentWork {
            output: piece.value.index() as u32,
            operations: fragment_operations(m, &reached),
            condition: form.condition.map(|c| c.index() as u32),
            general_combiners: stage.as_ref().ok().and_then(|s| match s {
                crate::pipeline::FragmentSetup::Combiners(p) => Some(p.stages()),
                _ => None,
            }),
            depth: None,
        },
        blend: piece.blend,
        state,
        baked,
        predicted: None,
    };
    (pass, drawn_at, (st.span, stage))
}

/// Whether a statement rasterizes the mesh in texture space: a texel
/// statement indexed through a vertex (`T δu x`, Pipeline Grammar, eq. (15)).
fn in_texture_space(m: &Module, st: &Statement) -> bool {
    st.freq == Frequency::Texel
        && m.reachable(&[st.index]).iter().any(|h| m.info(*h).freq == Frequency::Vertex)
}

/// Where a pass draws: a temporary, the statement's framebuffer (with the
/// channels it writes), or its texture.
pub(super) fn pass_target(m: &Module, st: &Statement, piece: &Piece, form: &Form) -> RenderTarget {
    match (piece.dest, &st.table) {
        (Dest::Temp(id), _) => RenderTarget::Temporary { name: format!("temp{id}") },
        (Dest::Main, Table::Framebuffer { id, .. }) => RenderTarget::Framebuffer {
            name: m.framebuffers[*id as usize].name.clone(),
            channels: form.channels.to_string(),
        },
        (Dest::Main, Table::Texture(id)) => {
            RenderTarget::Texture { name: m.textures[*id as usize].name.clone() }
        }
        (Dest::Main, Table::TexCoords(_)) => unreachable!("texgen statements are vertex work"),
    }
}

/// The texture units of a pass, in order: its lookups, then the other
/// framebuffers it reads as textures (its own target it reads by blending).
pub(super) fn texture_bindings(m: &Module, st: &Statement, u: &Usage) -> Vec<TextureBinding> {
    let own = |h: Handle<Expr>| matches!(m.exprs[h], Expr::FramebufferRead { framebuffer, position, .. } if matches!(st.table, Table::Framebuffer { id, .. } if id == framebuffer) && position == st.index);
    let lookups = u.lookups.iter().map(|&h| {
        let Expr::Lookup { texture, coords } = m.exprs[h] else { unreachable!("a lookup") };
        (m.textures[texture as usize].name.clone(), h, coords)
    });
    let reads = u.framebuffer_reads.iter().filter(|h| !own(**h)).map(|&h| {
        let Expr::FramebufferRead { framebuffer, position, .. } = m.exprs[h] else { unreachable!("a read") };
        (m.framebuffers[framebuffer as usize].name.clone(), h, position)
    });
    lookups
        .chain(reads)
        .enumerate()
        .map(|(i, (texture, h, coords))| TextureBinding {
            unit: i as u32,
            texture,
            lookup: h.index() as u32,
            coords: coords.index() as u32,
        })
        .collect()
}

/// The texgen statements whose coordinates a pass reads.
pub(super) fn texgen_of(m: &Module, reached: &[Handle<Expr>], texgen: &HashMap<u32, String>) -> Vec<String> {
    let mut gen: Vec<String> = reached
        .iter()
        .filter_map(|h| match m.exprs[*h] {
            Expr::TexCoord { set, .. } => texgen.get(&set).cloned(),
            _ => None,
        })
        .collect();
    gen.dedup();
    gen
}

/// The per-sample arithmetic of a pass's fragment value.
pub(super) fn fragment_operations(m: &Module, reached: &[Handle<Expr>]) -> usize {
    reached
        .iter()
        .filter(|h| {
            m.info(**h).freq.is_sample()
                && matches!(
                    m.exprs[**h],
                    Expr::Binary { .. }
                        | Expr::Unary { .. }
                        | Expr::Math { .. }
                        | Expr::Combine { .. }
                        | Expr::Select { .. }
                )
        })
        .count()
}

/// The fixed-function state of a pass: culling, the depth test (the first
/// draw into a target tests `Less` and writes, later ones `Equal`), the
/// form's stencil, and the blend with the channels written.
pub(super) fn pass_state(
    form: &Form,
    piece: &Piece,
    geometry: &Geometry,
    in_texture_space: bool,
    drawn: &mut Drawn,
    key: (Table, Handle<Expr>),
) -> RenderState {
    // A temporary has a depth buffer of its own, fresh when its first pass
    // draws: that pass tests `Less` and writes, as the first pass into a
    // framebuffer does (an `Equal` test against the cleared depth drew
    // nothing: issue 16's lost term).
    let first_draw = match piece.dest {
        Dest::Main => !drawn.main_set.contains(&key),
        Dest::Temp(id) => !drawn.temps.contains(&id),
    };
    let on_mesh = matches!(geometry, Geometry::Mesh { .. });
    let depth = form.depth.unwrap_or(match geometry {
        // A one-to-one u covers each texel once: no depth test.
        _ if in_texture_space => DepthState::DISABLED,
        Geometry::Mesh { .. } if !first_draw => DepthState::EQUAL_NO_WRITE,
        Geometry::Mesh { .. } => DepthState::LESS_WRITE,
        _ => DepthState::DISABLED,
    });
    if on_mesh && first_draw {
        match piece.dest {
            Dest::Main => {
                drawn.main_set.insert(key.clone());
                drawn.main.push(key);
            }
            Dest::Temp(id) => _ = drawn.temps.insert(id),
        }
    }
    let mask = match form.channels {
        "a" => [false, false, false, true],
        "stencil" => [false; 4],
        _ => [true, true, true, alpha_written(form, piece)],
    };
    RenderState {
        // In texture space the winding is the parameterization's, not a facing.
        cull: if on_mesh && !in_texture_space { CullMode::Back } else { CullMode::None },
        depth,
        // The statement's stencil is its framebuffer's: a split's pass into
        // a temporary draws where that texture's own stencil says nothing
        // (it is clear), so only the passes into the framebuffer test it.
        stencil: match piece.dest {
            Dest::Main => form.stencil.unwrap_or(StencilState::DISABLED),
            Dest::Temp(_) => StencilState::DISABLED,
        },
        blend: BlendState { ..piece.blend.render_state().with_write_mask(mask) },
        alpha_test: AlphaTest::DISABLED,
    }
}

/// Whether a pass writes the framebuffer's alpha.
pub(super) fn alpha_written(form: &Form, piece: &Piece) -> bool {
    match form.channels {
        "a" => true,
        "stencil" => false,
        // A decal keeps the incoming alpha (GL_DECAL: A = Af), so the
        // alpha-blended texture writes colour only.
        _ => piece.alpha && piece.blend != BlendMode::AlphaBlend,
    }
}

/// Why a pass exists: its group's reason, or which part of a split it is.
pub(super) fn pass_reason(
    group: &Group,
    piece: &Piece,
    pi: usize,
    names: &[String],
    profile: &Profile,
) -> String {
    let n = group.n;
    let label = match group.stmts {
        [s] => format!("statement {}", names[*s]),
        many => format!(
            "statements {} (fused)",
            many.iter().map(|s| names[*s].clone()).collect::<Vec<_>>().join(", ")
        ),
    };
    if n == 1 {
        // A split that came to one pass (a constant scale applied by the
        // pass's last stage) says why, not "as written"; a group
        // rewritten says so already (its piece repeats it).
        if piece.why.is_empty() || !group.reason.starts_with(&format!("{label} as written")) {
            return group.reason.to_string();
        }
        return format!("{label} in one pass on {}: {}", profile.name, piece.why);
    }
    let why = if piece.why.is_empty() { "the part rendered first" } else { piece.why.as_str() };
    format!("{label} split into {n} passes on {} (pass {} of {n}): {why}", profile.name, pi + 1)
}

/// Every value a plan's passes refer to, with its type, frequency and range.
pub(super) fn plan_values(m: &Module, roots: &[Handle<Expr>], at: &dyn Fn(Span) -> String) -> Vec<Value> {
    m.reachable(roots)
        .into_iter()
        .map(|h| {
            let info = m.info(h);
            Value {
                id: h.index() as u32,
                op: ir::dump::node(m, &m.exprs[h]),
                ty: info.ty.name(),
                freq: info.freq.name().to_string(),
                range: match info.range() {
                    ir::Range::Unsigned => "[0,1]".into(),
                    ir::Range::Signed => "[-1,1]".into(),
                    ir::Range::Unbounded => "unbounded".into(),
                },
                at: at(m.span(h)),
            }
        })
        .collect()
}

/// The fragment stage of a pass: on a register-combiner profile the setup
/// the combiner code generator makes for it (kept: no consumer generates it
/// again), else a refusal located at the node the error names
/// (`CodegenError::span`), or at the pass's value for an error of the whole
/// pass (too many stages); the programmable stage elsewhere.
pub(super) fn combiner_setup(
    m: &Module,
    realizer: Option<&dyn Realizer>,
    value: Handle<Expr>,
    textures: &[TextureBinding],
) -> Result<crate::pipeline::FragmentSetup, Box<Diagnostic>> {
    // Unit i holds textures[i]: a lookup, or a framebuffer read as a texture.
    let units: Vec<Handle<Expr>> = textures.iter().map(|t| Handle::new(t.lookup as usize)).collect();
    let Some(realizer) = realizer else { return Ok(crate::pipeline::FragmentSetup::Programmable) };
    realizer.setup(m, value, &units).map(crate::pipeline::FragmentSetup::Combiners).map_err(|e| {
        let span = e.span.filter(|s| *s != Span::DETACHED).unwrap_or_else(|| m.span(value));
        let message =
            format!("the register-combiner code generator makes no setup for this pass: {}", e.reason);
        Box::new(Diagnostic::error("not-generated", message, span, "in this pass").with_help(e.help))
    })
}

/// The geometry a statement's index draws, for its depth test: `δπ* x` is
/// `δπ x`'s where the program projects the mesh by `π` too.
///
/// Pipeline Grammar, eq. (11): `C δπ* x ← (C δπ* x) ⊕ …` renders the scene
/// once more under a perturbed projection and accumulates it; each such
/// pass sees its own visible surface. The executors render `π*` as `π`
/// (they do not jitter), so that surface is the one the `π` pass left in
/// the depth buffer: the `π*` pass is a later draw of the same geometry
/// (`Equal`, no write), not a first draw of its own testing `Less` against
/// the very depths it would write (which drew nothing).
pub fn depth_key(m: &Module, index: Handle<Expr>) -> Handle<Expr> {
    let unstarred = |h: Handle<Expr>| match &m.exprs[h] {
        Expr::Project { projection, value } if projection.star => m.exprs.find(&Expr::Project {
            projection: ir::Projection { star: false, ..projection.clone() },
            value: *value,
        }),
        _ => None,
    };
    match &m.exprs[index] {
        Expr::Interpolate { value, to } => unstarred(*value)
            .and_then(|p| m.exprs.find(&Expr::Interpolate { value: p, to: *to }))
            .unwrap_or(index),
        _ => unstarred(index).unwrap_or(index),
    }
}

/// Whether a pass's blend reads the colour already in its target: its
/// destination factors or a `Dst…` source factor, or `Min`/`Max`.
fn blend_reads_destination(b: &BlendState) -> bool {
    use crate::pipeline::{BlendEquation as E, BlendFactor as F};
    let dst = |f: F| {
        matches!(
            f,
            F::DstColor | F::OneMinusDstColor | F::DstAlpha | F::OneMinusDstAlpha | F::SrcAlphaSaturate
        )
    };
    b.dst_rgb != F::Zero
        || b.dst_alpha != F::Zero
        || dst(b.src_rgb)
        || dst(b.src_alpha)
        || matches!(b.equation, E::Min | E::Max)
}

/// Whether a pass needs a depth-only pass before it: the first draw of a
/// mesh (depth `Less` with write) that blends with what its target holds.
/// Drawn in the order of the scene's triangles, such a pass blends every
/// fragment nearer than those drawn before it, also those a nearer surface
/// drawn later hides (an accumulation `C δπx ← (C δπx) ⊕[add] …` as the
/// first write into C adds them all). The program means the visible
/// surface's fragment only, as the meaning's one pass per statement (depth
/// `Less`, `replace`) and the reference take it.
fn needs_depth_prepass(pass: &Pass) -> bool {
    let s = &pass.state;
    matches!(pass.geometry, Geometry::Mesh { .. })
        && s.depth == DepthState::LESS_WRITE
        && s.blend.write_mask.iter().any(|w| *w)
        && blend_reads_destination(&s.blend)
}

/// Depth-only passes before the blended first draws
/// ([`needs_depth_prepass`]): each draws the same geometry, tests `Less`
/// and writes depth, writes no colour and no stencil, over every object
/// (an object a light's pass leaves out still hides what is behind it);
/// the blended pass then tests `Equal` without writing, as the later
/// passes of a multipass plan do (Kilgard 2000, Section 5). Its fragment
/// stage is a constant ([`depth_only_stage`]) where the blended pass
/// discards nothing, else the blended pass's own with its alpha test (a
/// discarded fragment writes no depth). A plan whose first draws replace
/// gets none. `stages` keeps one entry per pass.
pub(super) fn depth_prepasses(
    m: &mut Module,
    ctx: &AssembleCtx,
    plan: &mut PassPlan,
    stages: &mut Vec<Stage>,
) {
    let mut k = 0;
    while k < plan.passes.len() {
        if !needs_depth_prepass(&plan.passes[k]) {
            k += 1;
            continue;
        }
        let main = &mut plan.passes[k];
        let mut pre = main.clone();
        main.state.depth = DepthState::EQUAL_NO_WRITE;
        pre.state.depth = DepthState::LESS_WRITE;
        pre.state.stencil = StencilState::DISABLED;
        pre.state.blend = BlendState::REPLACE.with_write_mask([false; 4]);
        pre.blend = BlendMode::Replace;
        pre.objects = None;
        pre.reason = format!(
            "the depth of the visible surface, colour writes off, before the blended pass that follows ({}): \
             it then tests `Equal` and blends only the visible fragments",
            main.blend.name()
        );
        let mut stage = stages[k].clone();
        if let Some((value, setup)) = depth_only_stage(m, ctx, &pre) {
            pre.fragment = FragmentWork {
                output: value.index() as u32,
                operations: 0,
                condition: None,
                general_combiners: setup.as_ref().ok().and_then(|s| match s {
                    crate::pipeline::FragmentSetup::Combiners(p) => Some(p.stages()),
                    _ => None,
                }),
                depth: None,
            };
            pre.textures = Vec::new();
            pre.vertex.interpolants = Vec::new();
            pre.vertex.texgen = Vec::new();
            stage.1 = setup;
            if !plan.values.iter().any(|v| v.id == value.index() as u32) {
                plan.values.extend(plan_values(m, &[value], ctx.at));
            }
        }
        plan.passes.insert(k, pre);
        stages.insert(k, stage);
        k += 2;
    }
}

/// The fragment stage of a depth-only pass that discards nothing: the
/// constant 0 (its colour is not written), with the target's setup for
/// it — no lookups, no interpolants, no arithmetic. `None` where the pass
/// discards (its condition or alpha test must run), or where the target
/// makes no setup for a constant: the blended pass's own stage is kept.
fn depth_only_stage(m: &mut Module, ctx: &AssembleCtx, pre: &Pass) -> Option<(Handle<Expr>, StageSetup)> {
    if pre.fragment.condition.is_some() || !pre.state.alpha_test.is_disabled() || pre.fragment.depth.is_some()
    {
        return None;
    }
    let zero = m.intern(Expr::Constant(ir::Constant::scalar(0.0)), Span::DETACHED).ok()?;
    let setup = combiner_setup(m, ctx.realizer, zero, &[]);
    setup.is_ok().then_some((zero, setup))
}

pub(super) fn same_framebuffer(a: &Table, b: &Table) -> bool {
    matches!((a, b), (Table::Framebuffer { id: x, .. }, Table::Framebuffer { id: y, .. }) if x == y)
}

/// A statement at the pixel (`C δxs`) whose value interpolates per-vertex
/// values draws the vertices an earlier statement projected into the same
/// framebuffer (Pipeline Grammar, eq. (10): "the passes reuse the projected vertices").
/// Errors where there is none: nothing would place the mesh on the screen.
pub(super) fn reused_projection(m: &Module) -> Vec<Diagnostic> {
    let mut projected: Vec<&Table> = Vec::new();
    let mut diags = Vec::new();
    for st in &m.statements {
        if !matches!(st.table, Table::Framebuffer { .. }) || st.freq != Frequency::Fragment {
            continue;
        }
        if !matches!(m.exprs[st.index], Expr::Pixel { .. }) {
            projected.push(&st.table);
        } else if !projected.iter().any(|t| same_framebuffer(t, &st.table)) {
            let name = match st.table {
                Table::Framebuffer { id, .. } => m.framebuffers[id as usize].name.as_str(),
                _ => unreachable!(),
            };
            diags.push(
                Diagnostic::error("no-projected-vertices", format!("this statement at the pixel interpolates per-vertex values, but no earlier statement projects the mesh into `{name}`"), m.span(st.index), "the vertices of an earlier pass are reused here")
                    .with_help(format!("Pipeline Grammar, eq. (10) reuses the screen positions an earlier pass computed: write a statement `{name} δπx ← …` first, or index this one by `δπx`")),
            );
        }
    }
    diags
}

/// `π`, `πl`, `π*`, or `u` for a statement's index.
pub(super) fn projection_name(m: &Module, index: Handle<Expr>) -> String {
    for h in m.reachable(&[index]).into_iter().rev() {
        if let Expr::Project { projection, .. } = &m.exprs[h] {
            let mut s = String::from(if projection.inverse { "π⁻¹" } else { "π" });
            if let Some(sub) = &projection.subscript {
                s += sub;
            }
            if projection.star {
                s += "*";
            }
            return s;
        }
    }
    "u".to_string()
}
