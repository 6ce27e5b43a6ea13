//! AST → IR: resolve names, inline shaders and `let`s, apply the δ rules,
//! fold constants, intern every node (see the `ir` module doc).
//!
//! Declarations are lowered first (resources, constants, uniforms); `let`s
//! and shaders are lowered where they are used, in the context of the
//! statement (which fixes what δ interpolates to); those no statement uses
//! are type-checked at the end and dropped (`check_unused`). Texgen
//! statements (`u x ← …`) are lowered before the others, because they give
//! their coordinate set a type.

use std::collections::HashMap;

use super::valid::{self, TypeError};
use super::{
    BinaryOp, Constant, Expr, FbChannel, Frequency, Handle, MathFunction, Module, Projection, Site,
    Statement, Table, TexCoordSet, Texture, Ty, UnaryOp, Uniform, Vector, VectorId, VertexId,
};
use crate::diag::Diagnostic;
use crate::parser::ast::{self, ExprKind, FuncKind, ItemKind};
use crate::parser::resolve::{self, Entity, FUNCTIONS};
use crate::span::Span;

/// Lowers a checked program. Never panics; what cannot be lowered is a
/// diagnostic, and the statement it belongs to is left out of the module.
pub fn lower(program: &ast::Program) -> (Module, Vec<Diagnostic>) {
    // Lowering recurses over expressions and inlined definitions; a large
    // stack keeps the recursion bounds (below) far from an overflow on any
    // thread, including test threads.
    std::thread::scope(|scope| {
        match std::thread::Builder::new()
            .name("shadec-lower".into())
            .stack_size(LOWER_STACK)
            .spawn_scoped(scope, || lower_here(program))
        {
            Ok(handle) => handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
            Err(_) => lower_here(program),
        }
    })
}

/// Stack for the lowering thread.
const LOWER_STACK: usize = 256 << 20;
/// Deepest recursion over expressions, counting inlined definitions.
const MAX_EXPR_RECURSION: usize = 20_000;
/// Deepest nesting of definitions (`let`, computed vectors, shaders): beyond
/// this, a definition uses itself.
const MAX_DEFINITION_DEPTH: usize = 64;

fn lower_here(program: &ast::Program) -> (Module, Vec<Diagnostic>) {
    let baked;
    let program = match with_bakes(program) {
        Some(p) => {
            baked = p;
            &baked
        }
        None => program,
    };
    let mut l = Lowerer {
        program,
        module: Module::default(),
        diagnostics: Vec::new(),
        globals: HashMap::new(),
        vector_decls: Vec::new(),
        params: Vec::new(),
        sample: None,
        statement_freq: None,
        let_cache: HashMap::new(),
        used: Default::default(),
        locals: Vec::new(),
        bundles: Vec::new(),
        depth: 0,
        expr_depth: 0,
        under_delta: 0,
        distributed: false,
        surface: None,
        written: Default::default(),
    };
    l.run();
    l.diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    (l.module, l.diagnostics)
}

/// `texture T … = bake(f)` is texture shading (Pipeline Grammar, eq. (13)) of the
/// function `f` over T's texels: the program with the statement
/// `T δu ← f s δu` added for every such texture (its spans those of the
/// `bake(…)` source, so it sorts, plans and reports where it was written),
/// or `None` when no texture is baked. Renderers treat a baked texture as
/// one that statements render into.
/// Whether a texture source is `bake(f)`.
/// The function a texture source's generator tabulates (an exponent
/// given as a number; a named constant is not looked up).
fn tabulated(src: &ast::Expr) -> Option<super::Tabulated> {
    let ExprKind::Apply { func, arg } = &src.kind else { return None };
    let FuncKind::Name(f) = &func.kind else { return None };
    let first = match &arg.kind {
        ExprKind::Tuple(items) => items.first()?,
        _ => arg,
    };
    match f.key().as_str() {
        "normalize_cube" => Some(super::Tabulated::Normalize),
        "exponent_table" => match first.kind {
            ExprKind::Number(n) if n >= 1.0 => Some(super::Tabulated::Power(n)),
            _ => None,
        },
        _ => None,
    }
}

fn is_bake(src: &ast::Expr) -> bool {
    matches!(&src.kind, ExprKind::Apply { func, arg } if matches!((&func.kind, &arg.kind), (FuncKind::Name(f), ExprKind::Name(_)) if f.key() == "bake"))
}

fn with_bakes(program: &ast::Program) -> Option<ast::Program> {
    let mut added = Vec::new();
    for item in &program.items {
        let ItemKind::Texture(t) = &item.kind else { continue };
        let Some(src) = t.source.as_ref().filter(|s| is_bake(s)) else { continue };
        let ExprKind::Apply { arg, .. } = &src.kind else { continue };
        let ExprKind::Name(shader) = &arg.kind else { continue };
        for name in &t.names {
            let (parsed, diagnostics) =
                crate::parser::parse(&format!("{} delta u <- {} s delta u;", name.key(), shader.key()));
            let Some(mut statement) = parsed.items.into_iter().next().filter(|_| diagnostics.is_empty())
            else {
                continue;
            };
            statement.erase_spans();
            statement.span = src.span;
            if let ItemKind::Statement(st) = &mut statement.kind {
                st.target.span = src.span;
                st.target.table.span = name.span;
                st.value.span = src.span;
            }
            added.push(statement);
        }
    }
    if added.is_empty() {
        return None;
    }
    let mut p = program.clone();
    p.items.extend(added);
    Some(p)
}

/// Where a shading-parameter bundle is evaluated.
#[derive(Clone, Copy, Debug, PartialEq)]
enum BundleSite {
    Vertex(VertexId),
    Interpolated(VertexId, Frequency),
    /// At the texel being rendered (`s δu`): in a texture-shading statement
    /// of a program with a mesh, a vector is taken at the surface point
    /// whose coordinate is the texel's (Pipeline Grammar, eq. (13)) — a role
    /// interpolated from the vertex stream in texture space, a computed
    /// vector evaluated per texel from them (see `surface_vertex`); `s.x`
    /// is the texel coordinate (a table, as `bake(f)` makes).
    Texel,
    Fat(Handle<Expr>),
}

#[derive(Clone, Debug)]
struct Bundle {
    members: Vec<VectorId>,
    site: BundleSite,
}

/// A lowering-time value: an IR node, or one of the notation's objects that
/// only exist until they are applied (a vertex, a bundle `s x`, a set `u`).
#[derive(Clone, Debug)]
enum Value {
    Expr(Handle<Expr>),
    Bundle(Bundle),
    Vertex(VertexId),
    TexCoordSet,
    /// `s`, unapplied: the members of the parameter vector.
    ParamsName(Vec<VectorId>),
}

#[derive(Clone, Copy, Debug)]
enum Global<'a> {
    Texture(u32),
    Framebuffer(u32),
    Vector(VectorId),
    Params(usize),
    Const(Handle<Expr>),
    Uniform(u32),
    Let(&'a ast::LetDecl),
    Shader(&'a ast::ShaderDecl),
}

type Res<T> = Result<T, ()>;

/// A bundle's vertex stream and the index `δu x` that replaces `δu`.
type SurfaceVertex = (VertexId, Handle<Expr>);

struct Lowerer<'a> {
    program: &'a ast::Program,
    module: Module,
    diagnostics: Vec<Diagnostic>,
    globals: HashMap<String, Global<'a>>,
    vector_decls: Vec<Option<&'a ast::Expr>>,
    params: Vec<Vec<VectorId>>,
    /// What δ interpolates to in the current statement (`None`: no δ allowed).
    sample: Option<Frequency>,
    /// The frequency of the statement being lowered.
    statement_freq: Option<Frequency>,
    /// Shaders and `let`s some statement used.
    used: std::collections::HashSet<String>,
    /// Values of global `let`s in the current statement.
    let_cache: HashMap<String, Value>,
    /// Shader locals, innermost last; a `None` name marks a scope boundary.
    locals: Vec<(String, Value)>,
    /// The bundle the shader being inlined was applied to.
    bundles: Vec<Bundle>,
    /// Nesting of definitions being inlined: guards against cycles.
    depth: usize,
    /// Recursion over expressions.
    expr_depth: usize,
    /// Inside the argument of a δ: nodes mixing per-vertex and per-sample
    /// operands interpolate the per-vertex ones (δ distributes, EMBM).
    under_delta: usize,
    /// Whether the innermost δ's argument distributed.
    distributed: bool,
    /// In a texture-shading statement `T δu ← …`: the set `u`, and once a
    /// bundle `s δu` was taken on the surface, its vertex stream and the
    /// index `δu x` that replaces `δu` (see `surface_vertex`).
    surface: Option<(u32, Option<SurfaceVertex>)>,
    /// Framebuffers some statement before the current one writes (in source
    /// order, whether or not it lowered): reading one of these is reading
    /// what was drawn, not the cleared buffer.
    written: std::collections::HashSet<u32>,
}

impl<'a> Lowerer<'a> {
    fn run(&mut self) {
        let program = self.program;
        for item in &program.items {
            self.declare(item);
        }
        // After every `const` is known, as the scene binder reads them.
        for item in &program.items {
            if let ItemKind::Texture(t) = &item.kind {
                self.check_generator(t);
            }
        }
        let statements: Vec<&ast::Statement> = program
            .items
            .iter()
            .filter_map(|i| match &i.kind {
                ItemKind::Statement(s) => Some(s),
                _ => None,
            })
            .collect();
        let (texgen, rest): (Vec<_>, Vec<_>) = statements.into_iter().partition(|s| {
            resolve::family(&s.target.table) == Some(Entity::TexCoords)
                && !self.globals.contains_key(&s.target.table.key())
        });
        for st in texgen.into_iter().chain(rest) {
            self.statement(st);
        }
        self.module.statements.sort_by_key(|s| s.span.start);
        self.check_unused();
    }

    /// Type-checks the shaders and `let`s no statement used (or only a
    /// texture source such as `bake(p)` uses), so their errors are reported
    /// too: shaders on a per-texel bundle (where `s.x` is the texel
    /// coordinate), `let`s in a per-fragment context. Nothing they add stays
    /// in the module.
    fn check_unused(&mut self) {
        let program = self.program;
        let saved = self.module.clone();
        for item in &program.items {
            match &item.kind {
                ItemKind::Shader(s) if !self.used.contains(&s.name.key()) => {
                    self.let_cache.clear();
                    self.sample = Some(Frequency::Texel);
                    self.statement_freq = Some(Frequency::Texel);
                    let members = match self.globals.get(&s.input.key()) {
                        Some(Global::Params(i)) => self.params[*i].clone(),
                        _ => self.all_vectors(),
                    };
                    let bundle = Value::Bundle(Bundle { members, site: BundleSite::Texel });
                    let _ = self.inline(s, bundle, s.name.span, s.name.span);
                }
                ItemKind::Let(l) if !self.used.contains(&l.name.key()) => {
                    self.let_cache.clear();
                    self.sample = Some(Frequency::Fragment);
                    self.statement_freq = Some(Frequency::Fragment);
                    let _ = self.let_value(l);
                }
                _ => {}
            }
        }
        self.module = saved;
        self.sample = None;
        self.statement_freq = None;
    }

    fn error(
        &mut self,
        code: &'static str,
        message: impl Into<String>,
        span: Span,
        label: impl Into<String>,
        help: impl Into<String>,
    ) {
        self.diagnostics.push(Diagnostic::error(code, message, span, label).with_help(help));
    }

    fn unsupported(&mut self, what: impl Into<String>, span: Span) {
        let what = what.into();
        self.diagnostics.push(
            Diagnostic::error(
                "not-supported",
                format!("not yet supported: {what}"),
                span,
                "the IR cannot express this yet",
            )
            .with_help("rewrite it with the forms of Pipeline Grammar, Sections 2-3, or report it as a gap"),
        );
    }

    fn declare(&mut self, item: &'a ast::Item) {
        match &item.kind {
            ItemKind::Target(t) => self.module.target = Some(t.profile.clone()),
            ItemKind::Texture(t) => {
                for n in &t.names {
                    let id = self.module.textures.len() as u32;
                    self.module.textures.push(Texture {
                        name: n.key(),
                        kind: t.kind.value,
                        format: t.format.as_ref().map_or(ast::TextureFormat::Rgba8, |f| f.value),
                        rendered: t.source.is_none(),
                        baked: t.source.as_ref().is_some_and(is_bake),
                        declaration: None,
                        copy_of: None,
                        tabulates: t.source.as_ref().and_then(tabulated),
                        sampling: super::Sampling::of(
                            t.kind.value,
                            &t.attrs.iter().map(|a| a.value).collect::<Vec<_>>(),
                        ),
                        span: n.span,
                    });
                    self.globals.insert(n.key(), Global::Texture(id));
                }
            }
            ItemKind::Framebuffer(f) => {
                for n in &f.names {
                    self.framebuffer_id(n, f.channels.iter().map(|c| c.value).collect());
                }
            }
            ItemKind::Vector(v) => {
                for n in &v.names {
                    let id = self.module.vectors.len() as u32;
                    self.module.vectors.push(Vector {
                        name: n.key(),
                        kind: v.role.as_ref().map(|r| r.kind.value),
                        index: v.role.as_ref().and_then(|r| r.index.as_ref().map(|i| i.value)),
                        space: v.role.as_ref().and_then(|r| r.space.as_ref().map(|s| s.value)),
                        span: n.span,
                    });
                    self.vector_decls.push(v.value.as_ref());
                    self.globals.insert(n.key(), Global::Vector(id));
                }
            }
            ItemKind::Params(p) => {
                let mut members = Vec::new();
                for m in &p.members {
                    match self.globals.get(&m.key()) {
                        Some(Global::Vector(id)) => members.push(*id),
                        _ => self.error(
                            "bad-params",
                            format!("`{}` is not a shading vector", m.key()),
                            m.span,
                            "not a vector",
                            "list vectors declared with `vector`",
                        ),
                    }
                }
                self.params.push(members);
                self.globals.insert(p.name.key(), Global::Params(self.params.len() - 1));
            }
            ItemKind::Const(c) => {
                self.sample = None;
                let Ok(h) = self.lower_expr(&c.value).and_then(|v| self.expect_expr(v, c.value.span)) else {
                    return;
                };
                let Ok(h) = self.annotate(h, c.ty.as_ref(), c.value.span) else { return };
                if !matches!(self.module.exprs[h], Expr::Constant(_)) {
                    self.error(
                        "not-constant",
                        format!("the constant `{}` is not computable at compile time", c.name.key()),
                        c.value.span,
                        "not a constant",
                        "use `uniform` for a value the scene sets",
                    );
                    return;
                }
                self.globals.insert(c.name.key(), Global::Const(h));
            }
            ItemKind::Uniform(u) => {
                self.sample = None;
                let mut default = None;
                let mut ty = u.ty.as_ref().map(|t| Ty::from_ast(t.value));
                if let Some(d) = &u.default {
                    if let Ok(h) = self
                        .lower_expr(d)
                        .and_then(|v| self.expect_expr(v, d.span))
                        .and_then(|h| self.annotate(h, u.ty.as_ref(), d.span))
                    {
                        if let Expr::Constant(c) = self.module.exprs[h] {
                            ty = Some(c.ty);
                            default = Some(c);
                        } else {
                            self.error(
                                "not-constant",
                                "a uniform's default must be a constant",
                                d.span,
                                "not a constant",
                                "write numbers or constants here",
                            );
                        }
                    }
                }
                let id = self.module.uniforms.len() as u32;
                self.module.uniforms.push(Uniform {
                    name: u.name.key(),
                    ty: ty.unwrap_or(Ty::Scalar),
                    default,
                    span: u.name.span,
                });
                self.globals.insert(u.name.key(), Global::Uniform(id));
            }
            ItemKind::Let(l) => {
                self.globals.insert(l.name.key(), Global::Let(l));
            }
            ItemKind::Shader(s) => {
                self.globals.insert(s.name.key(), Global::Shader(s));
            }
            ItemKind::Statement(_) => {}
        }
    }

    /// Bounds a generated texture where it is declared, before anything
    /// builds it: `normalize_cube(size[, bits])` (Kilgard 2000, Appendix D)
    /// needs a `cube` texture, a whole face size from 1 to
    /// [`generators::MAX_CUBE_FACE`] known at compile time (a literal or a
    /// `const`), and 8 or 16 bits. The other generators' sizes are fixed
    /// (`bumps`, `exponent_table`, `brdf_*`: 256 or 64 per side, or the
    /// height image's own size).
    fn check_generator(&mut self, t: &'a ast::TextureDecl) {
        use crate::textures::generators::MAX_CUBE_FACE;
        let Some(source) = &t.source else { return };
        let ExprKind::Apply { func, arg } = &source.kind else { return };
        let FuncKind::Name(f) = &func.kind else { return };
        if f.key() != "normalize_cube" {
            return;
        }
        if t.kind.value != ast::TextureKind::Cube {
            self.diagnostics.push(
                Diagnostic::error(
                    "bad-generator",
                    format!(
                        "`normalize_cube` makes a cube map, but the texture is declared `{}`",
                        t.kind.value.as_str()
                    ),
                    f.span,
                    "a cube map generator",
                )
                .with_label(t.kind.span, "declared here")
                .with_help(format!(
                    "declare the texture `cube`: `texture {} : cube … = normalize_cube(…);`",
                    t.names.iter().map(ast::Name::key).collect::<Vec<_>>().join(", ")
                )),
            );
            // One mistake, one error: its lookups are read as the cube
            // map the generator makes, not reported again as 2-D lookups.
            for n in &t.names {
                if let Some(Global::Texture(id)) = self.globals.get(&n.key()) {
                    self.module.textures[*id as usize].kind = ast::TextureKind::Cube;
                }
            }
            return;
        }
        let items: Vec<&'a ast::Expr> = match &arg.kind {
            ExprKind::Tuple(items) => items.iter().collect(),
            _ => vec![arg],
        };
        if items.is_empty() || items.len() > 2 {
            self.error("arity", format!("`normalize_cube` takes a face size and optionally the bits (8 or 16), got {} argument(s)", items.len()), arg.span, "normalize_cube(size[, bits])", "write `normalize_cube(32)` or `normalize_cube(256, 16)`");
            return;
        }
        let values: Vec<Option<f64>> = items.iter().map(|e| self.compile_time_number(e)).collect();
        let size = values[0];
        match size {
            None => self.error("bad-generator", "the face size of `normalize_cube` is not a number known at compile time", items[0].span, "not a constant", "write a number or a `const`, such as `normalize_cube(32)`"),
            Some(n) if !(n >= 1.0 && n <= MAX_CUBE_FACE as f64 && n.fract() == 0.0) => self.error(
                if n > MAX_CUBE_FACE as f64 { "too-large" } else { "bad-generator" },
                if n > MAX_CUBE_FACE as f64 {
                    format!("a cube face of {n}×{n} texels is larger than the limit of {MAX_CUBE_FACE}×{MAX_CUBE_FACE}")
                } else {
                    format!("a cube face of {n} texels per side is not a whole number from 1 to {MAX_CUBE_FACE}")
                },
                items[0].span,
                format!("{n} texels per side"),
                format!("write a whole face size from 1 to {MAX_CUBE_FACE}: `normalize_cube(32)` is Kilgard 2000's normalization cube, 256 is smooth under magnification"),
            ),
            Some(_) => {}
        }
        if let Some(bits) = items.get(1) {
            if !matches!(values[1], Some(b) if b == 8.0 || b == 16.0) {
                self.error("bad-generator", "the bits of `normalize_cube` are 8 or 16", bits.span, "not 8 or 16", "write `normalize_cube(size, 8)` (Kilgard's 8-bit encoding) or `normalize_cube(size, 16)` (16 bits per component)");
            }
        }
    }

    /// A generator argument as the scene binder reads it (`scene::bind`): a
    /// number, a `const`, or a negation of one.
    fn compile_time_number(&self, e: &ast::Expr) -> Option<f64> {
        match &e.kind {
            ExprKind::Number(v) => Some(*v),
            ExprKind::Unary { op: ast::UnaryOp::Neg, operand } => {
                self.compile_time_number(operand).map(|v| -v)
            }
            ExprKind::Name(n) => match self.globals.get(&n.key()) {
                Some(Global::Const(h)) => match self.module.exprs[*h] {
                    Expr::Constant(c) if c.ty == Ty::Scalar => Some(c.values()[0]),
                    _ => None,
                },
                _ => None,
            },
            _ => None,
        }
    }

    fn framebuffer_id(&mut self, n: &ast::Name, channels: Vec<ast::FramebufferChannel>) -> u32 {
        if let Some(Global::Framebuffer(id)) = self.globals.get(&n.key()) {
            return *id;
        }
        let id = self.module.framebuffers.len() as u32;
        self.module.framebuffers.push(super::Framebuffer { name: n.key(), channels, span: n.span });
        self.globals.insert(n.key(), Global::Framebuffer(id));
        id
    }

    fn vertex_id(&mut self, n: &ast::Name) -> VertexId {
        let key = n.key();
        if let Some(i) = self.module.vertices.iter().position(|v| *v == key) {
            return i as u32;
        }
        self.module.vertices.push(key);
        (self.module.vertices.len() - 1) as u32
    }

    fn texcoord_id(&mut self, n: &ast::Name) -> u32 {
        let key = n.key();
        if let Some(i) = self.module.texcoord_sets.iter().position(|v| v.name == key) {
            return i as u32;
        }
        self.module.texcoord_sets.push(TexCoordSet { name: key, ty: Ty::Vec2, generated: false });
        (self.module.texcoord_sets.len() - 1) as u32
    }

    /// Appends (or finds) a node: infers its info, folds constants.
    fn append(&mut self, e: Expr, span: Span) -> Res<Handle<Expr>> {
        if let Some(h) = self.module.exprs.find(&e) {
            return Ok(h);
        }
        let e = self.distribute_delta(e, span)?;
        let info = match valid::infer(&self.module, &e) {
            Ok(i) => i,
            Err(err) => {
                self.type_error(err, span);
                return Err(());
            }
        };
        if let Some(c) = valid::fold(&self.module, &e, info.ty) {
            return self.append(Expr::Constant(c), span);
        }
        let (h, new) = self.module.exprs.insert(e, span);
        if new {
            self.module.info.push(info);
        }
        Ok(h)
    }

    /// Under δ, a node with per-vertex and per-sample operands interpolates
    /// the per-vertex ones: `δ((u x) + (T′ δu′ x))` is `δ(u x) + T′ δu′ x`.
    fn distribute_delta(&mut self, e: Expr, span: Span) -> Res<Expr> {
        let (Some(to), true) = (self.sample, self.under_delta > 0) else { return Ok(e) };
        if matches!(e, Expr::Interpolate { .. }) {
            return Ok(e);
        }
        let ops = e.operands();
        let freqs: Vec<Frequency> = ops.iter().map(|h| self.module.info(*h).freq).collect();
        if !(freqs.contains(&Frequency::Vertex) && freqs.iter().any(|f| f.is_sample())) {
            return Ok(e);
        }
        self.distributed = true;
        let mut new = Vec::new();
        for (h, f) in ops.iter().zip(freqs) {
            new.push(if f == Frequency::Vertex { self.interpolate(*h, to, span)? } else { *h });
        }
        Ok(replace_operands(e, &new))
    }

    fn type_error(&mut self, e: TypeError, span: Span) {
        let mut d = Diagnostic::error(e.code, e.message, span, e.label);
        if let Some(h) = e.help {
            d = d.with_help(h);
        }
        self.diagnostics.push(d);
    }

    fn constant(&mut self, c: Constant, span: Span) -> Handle<Expr> {
        self.append(Expr::Constant(c), span).expect("a constant always types")
    }

    /// The one rule by which a value takes a declared type — a `let`'s or
    /// parameter's annotation, a shader's `s → t`, `rgb(…)`/`vec3(…)`: the
    /// same type is kept; a constant of the same width is retagged; a scalar
    /// splats; rgb widens to rgba (alpha 1); a vec3 and an rgb are the same
    /// three numbers read as a direction or a colour (Pipeline Grammar, eq. (1)-(3)
    /// multiply light intensities, colours, by dot products of directions),
    /// so one is retagged as the other by an identity component selection.
    /// `None` when the value cannot take the type.
    fn coerce(&mut self, h: Handle<Expr>, want: Ty, span: Span) -> Res<Option<Handle<Expr>>> {
        let have = self.module.info(h).ty;
        if have == want {
            return Ok(Some(h));
        }
        if let Expr::Constant(c) = self.module.exprs[h] {
            if c.ty.width() == want.width() {
                return Ok(Some(self.constant(Constant { ty: want, ..c }, span)));
            }
        }
        Ok(Some(match (have, want) {
            (Ty::Scalar, t) if t.is_numeric() => self.append(Expr::Convert { value: h, to: t }, span)?,
            (Ty::Rgb, Ty::Rgba) => self.append(Expr::Convert { value: h, to: Ty::Rgba }, span)?,
            (Ty::Vec3, Ty::Rgb) | (Ty::Rgb, Ty::Vec3) => {
                self.append(Expr::Swizzle { value: h, pattern: [0, 1, 2, 0], len: 3, ty: want }, span)?
            }
            _ => return Ok(None),
        }))
    }

    /// Applies a declared type to a value by [`Self::coerce`].
    fn annotate(
        &mut self,
        h: Handle<Expr>,
        ty: Option<&ast::Word<ast::Type>>,
        span: Span,
    ) -> Res<Handle<Expr>> {
        let Some(want) = ty else { return Ok(h) };
        let want_ty = Ty::from_ast(want.value);
        let have = self.module.info(h).ty;
        match self.coerce(h, want_ty, span)? {
            Some(h) => Ok(h),
            None => {
                self.error(
                    "type-mismatch",
                    format!("declared {} but the value is a {}", want_ty.name(), have.name()),
                    span,
                    format!("a {}", have.name()),
                    format!("change the declared type to `{}`", have.name()),
                );
                Err(())
            }
        }
    }

    fn expect_expr(&mut self, v: Value, span: Span) -> Res<Handle<Expr>> {
        match v {
            Value::Expr(h) => Ok(h),
            Value::Bundle(_) | Value::ParamsName(_) => {
                self.error(
                    "type-mismatch",
                    "a shading-parameter vector is not a value here",
                    span,
                    "a bundle of vectors",
                    "apply a shader to it (`p δ s x`), or select a vector (`L s x`)",
                );
                Err(())
            }
            Value::Vertex(_) => {
                let v = if let Value::Vertex(id) = v { id } else { unreachable!() };
                self.append(Expr::VertexPosition(v), span)
            }
            Value::TexCoordSet => {
                self.error(
                    "type-mismatch",
                    "a texture-coordinate set needs a vertex or δ",
                    span,
                    "unapplied",
                    "write `u x` (at a vertex) or `δu` (the texel being rendered)",
                );
                Err(())
            }
        }
    }

    // ---- statements ----------------------------------------------------

    fn statement(&mut self, st: &'a ast::Statement) {
        self.let_cache.clear();
        let _ = self.statement_inner(st);
        if let Some(Global::Framebuffer(id)) = self.globals.get(&st.target.table.key()).copied() {
            self.written.insert(id);
        }
        self.surface = None;
        self.statement_freq = None;
        self.sample = None;
    }

    /// Whether a statement target's index starts with a framebuffer's name
    /// (`C δπx` in `s C δπx ← …`).
    fn index_names_framebuffer(&self, index: &ast::Expr) -> bool {
        index.head_name().is_some_and(|h| matches!(self.globals.get(&h.key()), Some(Global::Framebuffer(_))))
    }

    fn statement_inner(&mut self, st: &'a ast::Statement) -> Res<()> {
        let t = &st.target;
        let key = t.table.key();
        let span = t.span.join(st.value.span);
        let (table, sample) = self.target_table(t, &key)?;
        // Texture shading `T δu ← …`: `s δu` may be taken on the surface.
        if let (Table::Texture(_), Frequency::Texel, ExprKind::Apply { func, arg }) =
            (&table, sample, &t.index.kind)
        {
            if let (FuncKind::Delta, ExprKind::Name(u)) = (&func.kind, &arg.kind) {
                if resolve::family(u) == Some(Entity::TexCoords) && !self.globals.contains_key(&u.key()) {
                    self.surface = Some((self.texcoord_id(u), None));
                }
            }
        }
        // The index.
        self.statement_freq = Some(sample);
        self.sample = if sample.is_sample() { Some(sample) } else { None };
        let index_value = self.lower_expr(&t.index)?;
        let mut index = self.expect_expr(index_value, t.index.span)?;
        self.check_index(&key, &table, sample, index, t.index.span)?;
        // The value.
        let value = self.lower_expr(&st.value)?;
        let value = match value {
            Value::Bundle(b) if matches!(table, Table::Texture(_)) => {
                let members = self.bundle_members(&b, st.value.span)?;
                self.append(Expr::Bundle(members), st.value.span)?
            }
            v => self.expect_expr(v, st.value.span)?,
        };
        // `s δu` was taken on the surface: the statement rasterizes the mesh
        // in texture space, indexed by `δu x` (as (15) writes it).
        if let Some((_, Some((_, surface_index)))) = self.surface {
            index = surface_index;
        }
        let vi = *self.module.info(value);
        // Frequencies: the value must be computable where the statement runs.
        self.check_value_freq(vi.freq, sample, st.value.span)?;
        // Types: what the table holds.
        let value = self.fit_value(&table, index, value, vi.ty, st.value.span)?;
        self.module.statements.push(Statement {
            table,
            index,
            freq: sample,
            value,
            span,
            target_span: t.span,
        });
        Ok(())
    }

    /// The table a statement's target writes into, and the frequency the
    /// statement runs at: per fragment or per pixel for a framebuffer, per
    /// texel or fragment for a texture, per vertex for texgen.
    fn target_table(&mut self, t: &'a ast::Target, key: &str) -> Res<(Table, Frequency)> {
        let has_delta = contains(
            &t.index,
            &|e| matches!(&e.kind, ExprKind::Apply { func, .. } if func.kind == FuncKind::Delta),
        );
        let has_pi = contains(
            &t.index,
            &|e| matches!(&e.kind, ExprKind::Apply { func, .. } if matches!(func.kind, FuncKind::Projection(_))),
        );
        let channel = match t.channel.as_ref().map(|c| c.value) {
            None => FbChannel::Color,
            Some(ast::Channel::Alpha) => FbChannel::Alpha,
            Some(ast::Channel::Depth) => FbChannel::Depth,
            Some(ast::Channel::Stencil) => FbChannel::Stencil,
        };
        let (table, sample) = match (self.globals.get(key).copied(), resolve::family(&t.table)) {
            (Some(Global::Framebuffer(id)), _) => (
                Table::Framebuffer { id, channel },
                if has_delta { Frequency::Fragment } else { Frequency::Screen },
            ),
            (None, Some(Entity::Framebuffer)) => {
                let id = self.framebuffer_id(&t.table, Vec::new());
                (
                    Table::Framebuffer { id, channel },
                    if has_delta { Frequency::Fragment } else { Frequency::Screen },
                )
            }
            (Some(Global::Texture(id)), _) => {
                if !has_delta {
                    self.unsupported("rendering into a texture without δ (write `T δu` or `T δπx`)", t.span);
                    return Err(());
                }
                (Table::Texture(id), if has_pi { Frequency::Fragment } else { Frequency::Texel })
            }
            (None, Some(Entity::TexCoords)) => {
                (Table::TexCoords(self.texcoord_id(&t.table)), Frequency::Vertex)
            }
            _ if matches!(key, "a" | "s") && self.index_names_framebuffer(&t.index) => {
                // seeds/001 as printed: `s C δπx ← …` is σ, `a C xs ← …` α.
                let (sym, word) = if key == "s" { ("σ", "stencil") } else { ("α", "alpha") };
                self.diagnostics.push(
                    Diagnostic::error("unknown-name", format!("`{key}` is not a table"), t.table.span, "assigned into here").with_help(format!(
                        "did you mean `{sym}` (ASCII `{word}`), the framebuffer's {word} channel: `{sym} C δπx ← …`? Pipeline Grammar as printed (the Symbol font) shows `{sym}` as `{key}`"
                    )),
                );
                return Err(());
            }
            _ => {
                self.unsupported(format!("assigning into `{key}`"), t.table.span);
                return Err(());
            }
        };
        Ok((table, sample))
    }

    /// Refuses an index the table cannot be indexed by at `sample`.
    fn check_index(
        &mut self,
        key: &str,
        table: &Table,
        sample: Frequency,
        index: Handle<Expr>,
        span: Span,
    ) -> Res<()> {
        let ii = *self.module.info(index);
        let index_ok = match table {
            Table::Framebuffer { .. } => ii.ty == Ty::Position && ii.freq == sample,
            Table::Texture(_) if sample == Frequency::Fragment => ii.ty == Ty::Position && ii.freq == sample,
            Table::Texture(_) => ii.ty == Ty::Vec2 && ii.freq == Frequency::Texel,
            Table::TexCoords(_) => ii.ty == Ty::Position && ii.freq == Frequency::Vertex,
        };
        if !index_ok {
            self.error(
                "bad-target",
                format!("`{key}` cannot be indexed by a {} {}", ii.freq.name(), ii.ty.name()),
                span,
                "unexpected index",
                "write `C δπx` (fragments), `C xs` (a screen pass), `T δu` (texture shading), `T δπx` (render to texture) or `u x` (texgen)",
            );
            return Err(());
        }
        Ok(())
    }

    /// Refuses a value not computable where the statement runs (`sample`).
    fn check_value_freq(&mut self, freq: Frequency, sample: Frequency, span: Span) -> Res<()> {
        if freq.join(sample).is_none() || (freq == Frequency::Vertex && sample.is_sample()) {
            let help = if freq == Frequency::Vertex {
                "interpolate it: right of δ is per vertex, left of δ per fragment (e.g. `δ p s x`)"
                    .to_string()
            } else {
                format!(
                    "this target is written {}; compute the value there, or write it in another statement",
                    sample.name()
                )
            };
            self.error(
                "frequency",
                format!("a {} value is assigned to a {} target", freq.name(), sample.name()),
                span,
                format!("{} value", freq.name()),
                help,
            );
            return Err(());
        }
        Ok(())
    }

    /// The value as the table holds it (rgb widened to rgba, a position
    /// into a depth buffer as its depth); records a texgen's type.
    fn fit_value(
        &mut self,
        table: &Table,
        index: Handle<Expr>,
        mut value: Handle<Expr>,
        ty: Ty,
        span: Span,
    ) -> Res<Handle<Expr>> {
        match table {
            Table::Framebuffer { channel, .. } => {
                let want = match channel {
                    FbChannel::Color => Ty::Rgba,
                    _ => Ty::Scalar,
                };
                value = match (ty, want) {
                    (a, b) if a == b => value,
                    (Ty::Rgb, Ty::Rgba) | (Ty::Scalar, Ty::Rgba) => {
                        self.append(Expr::Convert { value, to: Ty::Rgba }, span)?
                    }
                    // `Cl δπl x ← δ x` (shadow mask): a position written into a depth
                    // buffer stores the depth of the fragment being written, in the
                    // projection of the index (πl here) — what the depth test compares.
                    (Ty::Position, _) if *channel == FbChannel::Depth || self.is_depth_only(table) => {
                        self.append(Expr::Depth(index), span)?
                    }
                    (have, want) => {
                        self.error("type-mismatch", format!("a {} is written into a {} channel", have.name(), want.name()), span, format!("a {}", have.name()), if have == Ty::Vec3 { "a vec3 is a direction: write a colour into a framebuffer (`rgb(v)` reads a vec3 as one), a scalar into α, z or σ" } else { "write a colour (rgb or rgba) into a framebuffer, a scalar into α, z or σ" });
                        return Err(());
                    }
                };
            }
            Table::Texture(id) => {
                let tex = &self.module.textures[*id as usize];
                let (texel, _) = valid::texel_type(tex.kind, tex.format);
                let name = tex.name.clone();
                value = match (ty, texel) {
                    (a, b) if a == b => value,
                    (Ty::Bundle(_), _) => value,
                    (Ty::Rgb, Ty::Rgba) | (Ty::Scalar, Ty::Rgba) => {
                        self.append(Expr::Convert { value, to: Ty::Rgba }, span)?
                    }
                    (Ty::Vec3, Ty::Rgb) | (Ty::Rgb, Ty::Vec3) => value,
                    (have, want) => {
                        self.error(
                            "type-mismatch",
                            format!(
                                "a {} is written into the texture `{name}` of {} texels",
                                have.name(),
                                want.name()
                            ),
                            span,
                            format!("a {}", have.name()),
                            "change the texture's format, or the value",
                        );
                        return Err(());
                    }
                };
            }
            Table::TexCoords(set) => {
                if !matches!(ty, Ty::Scalar | Ty::Vec2 | Ty::Vec3) {
                    self.error(
                        "type-mismatch",
                        format!("texture coordinates cannot be a {}", ty.name()),
                        span,
                        format!("a {}", ty.name()),
                        "generate a scalar, vec2 or vec3 (Pipeline Grammar, eq. (7))",
                    );
                    return Err(());
                }
                let set = &mut self.module.texcoord_sets[*set as usize];
                set.ty = ty;
                set.generated = true;
            }
        }
        Ok(value)
    }

    fn is_depth_only(&self, table: &Table) -> bool {
        match table {
            Table::Framebuffer { id, .. } => {
                let ch = &self.module.framebuffers[*id as usize].channels;
                !ch.is_empty()
                    && ch.iter().all(|c| {
                        matches!(c, ast::FramebufferChannel::Depth | ast::FramebufferChannel::Stencil)
                    })
            }
            _ => false,
        }
    }

    // ---- expressions ---------------------------------------------------

    fn lower_expr(&mut self, e: &'a ast::Expr) -> Res<Value> {
        if self.expr_depth > MAX_EXPR_RECURSION {
            self.error(
                "too-deep",
                "the expression is too deep to lower",
                e.span,
                "here",
                "split it with `let` bindings",
            );
            return Err(());
        }
        self.expr_depth += 1;
        let r = self.lower_expr_inner(e);
        self.expr_depth -= 1;
        r
    }

    /// Runs `f` one definition deeper; a cycle shows as too deep a nesting.
    fn nested<T>(&mut self, name: &str, span: Span, f: impl FnOnce(&mut Self) -> Res<T>) -> Res<T> {
        if self.depth >= MAX_DEFINITION_DEPTH {
            if self.depth == MAX_DEFINITION_DEPTH {
                self.error(
                    "cycle",
                    format!("`{name}` is defined in terms of itself"),
                    span,
                    "used here",
                    "a `let`, computed vector or shader must not use itself, directly or through others",
                );
            }
            return Err(());
        }
        self.depth += 1;
        let r = f(self);
        self.depth -= 1;
        r
    }

    fn lower_expr_inner(&mut self, e: &'a ast::Expr) -> Res<Value> {
        let span = e.span;
        match &e.kind {
            ExprKind::Number(n) => Ok(Value::Expr(self.constant(Constant::scalar(*n), span))),
            ExprKind::String(_) => {
                self.error(
                    "type-mismatch",
                    "a string is not a value",
                    span,
                    "a string",
                    "strings name files, in texture sources (`image(\"brick.png\")`)",
                );
                Err(())
            }
            ExprKind::Name(n) => self.name(n),
            ExprKind::Tuple(items) => {
                let mut hs = Vec::new();
                for i in items {
                    let v = self.lower_expr(i)?;
                    hs.push(self.expect_expr(v, i.span)?);
                }
                self.compose(hs, None, span).map(Value::Expr)
            }
            ExprKind::Apply { func, arg } => self.apply(func, arg, span),
            ExprKind::Swizzle { base, components } => {
                let v = self.lower_expr(base)?;
                if let Value::Bundle(b) = &v {
                    if b.site == BundleSite::Texel {
                        let tc = match self.surface {
                            // On the surface: the texel coordinate there, `δu x`.
                            Some((_, Some((_, index)))) => index,
                            _ => self.append(Expr::TexelCoord, base.span)?,
                        };
                        return self.swizzle(tc, components, span).map(Value::Expr);
                    }
                    self.unsupported("components of a shading-parameter vector outside texture shading; use its vectors by name", span);
                    return Err(());
                }
                let h = self.expect_expr(v, base.span)?;
                self.swizzle(h, components, span).map(Value::Expr)
            }
            ExprKind::Unary { op, operand } => {
                let v = self.lower_expr(operand)?;
                let h = self.expect_expr(v, operand.span)?;
                let op = match op {
                    ast::UnaryOp::Neg => UnaryOp::Neg,
                    ast::UnaryOp::Not => UnaryOp::Not,
                };
                self.append(Expr::Unary { op, value: h }, span).map(Value::Expr)
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let a = self.lower_expr(lhs)?;
                let a = self.expect_expr(a, lhs.span)?;
                let b = self.lower_expr(rhs)?;
                let b = self.expect_expr(b, rhs.span)?;
                let op = match op {
                    ast::BinaryOp::Or => BinaryOp::Or,
                    ast::BinaryOp::And => BinaryOp::And,
                    ast::BinaryOp::Lt => BinaryOp::Lt,
                    ast::BinaryOp::Le => BinaryOp::Le,
                    ast::BinaryOp::Gt => BinaryOp::Gt,
                    ast::BinaryOp::Ge => BinaryOp::Ge,
                    ast::BinaryOp::Eq => BinaryOp::Eq,
                    ast::BinaryOp::Ne => BinaryOp::Ne,
                    ast::BinaryOp::Add => BinaryOp::Add,
                    ast::BinaryOp::Sub => BinaryOp::Sub,
                    ast::BinaryOp::Mul => BinaryOp::Mul,
                    ast::BinaryOp::Div => BinaryOp::Div,
                    ast::BinaryOp::Dot => BinaryOp::Dot,
                    ast::BinaryOp::Pow => BinaryOp::Pow,
                };
                self.binary(op, a, b, span).map(Value::Expr)
            }
            ExprKind::Combine { mode, lhs, rhs } => {
                let a = self.lower_expr(lhs)?;
                let a = self.expect_expr(a, lhs.span)?;
                let b = self.lower_expr(rhs)?;
                let b = self.expect_expr(b, rhs.span)?;
                let (a, b) = self.widen_pair(a, b, span)?;
                if mode.is_none() {
                    self.warn_modulating_cleared(a, lhs.span, span);
                }
                let mode = mode.as_ref().map_or(ast::CombineMode::Modulate, |m| m.value);
                self.append(Expr::Combine { mode, lhs: a, rhs: b }, span).map(Value::Expr)
            }
            ExprKind::Select { cond, then, otherwise } => {
                let c = self.lower_expr(cond)?;
                let c = self.expect_expr(c, cond.span)?;
                let a = self.lower_expr(then)?;
                let mut a = self.expect_expr(a, then.span)?;
                let reject = match otherwise {
                    Some(o) => {
                        let b = self.lower_expr(o)?;
                        let b = self.expect_expr(b, o.span)?;
                        let (a2, b2) = self.widen_pair(a, b, span)?;
                        a = a2;
                        Some(b2)
                    }
                    None => None,
                };
                self.append(Expr::Select { cond: c, accept: a, reject }, span).map(Value::Expr)
            }
        }
    }

    /// A bare `⊕` is modulate: Pipeline Grammar's multipass forms (9)-(11),
    /// `C δπx ← (C δπx) ⊕ (…)`, written literally as a program's first
    /// write of `C` multiply the cleared framebuffer (0) and render black.
    /// Warns when the left operand reads the colour of a framebuffer no
    /// earlier statement writes.
    fn warn_modulating_cleared(&mut self, lhs: Handle<Expr>, lhs_span: Span, span: Span) {
        let Expr::FramebufferRead { framebuffer, channel: FbChannel::Color, .. } = self.module.exprs[lhs]
        else {
            return;
        };
        // Once per place: a `let` is lowered again in every statement using it.
        if self.written.contains(&framebuffer)
            || self.diagnostics.iter().any(|d| d.code == "modulate-cleared" && d.primary.span == lhs_span)
        {
            return;
        }
        let name = self.module.framebuffers[framebuffer as usize].name.clone();
        self.diagnostics.push(
            Diagnostic::warning(
                "modulate-cleared",
                format!("`⊕` modulates the framebuffer `{name}`, which no earlier statement writes: it is still cleared to 0, so the result is black"),
                lhs_span,
                format!("`{name}` is not written yet"),
            )
            .with_label(span, "a bare `⊕` is `⊕[modulate]`")
            .with_help(format!(
                "to accumulate into `{name}`, write `⊕[add]`; to modulate what an earlier pass drew, write `{name}` first (e.g. `{name} δπx ← …;` before this statement)"
            )),
        );
    }

    /// rgb meets rgba: the rgb side widens (alpha 1).
    fn widen_pair(
        &mut self,
        a: Handle<Expr>,
        b: Handle<Expr>,
        span: Span,
    ) -> Res<(Handle<Expr>, Handle<Expr>)> {
        let (ta, tb) = (self.module.info(a).ty, self.module.info(b).ty);
        match (ta, tb) {
            (Ty::Rgb, Ty::Rgba) => Ok((self.append(Expr::Convert { value: a, to: Ty::Rgba }, span)?, b)),
            (Ty::Rgba, Ty::Rgb) => Ok((a, self.append(Expr::Convert { value: b, to: Ty::Rgba }, span)?)),
            _ => Ok((a, b)),
        }
    }

    fn binary(&mut self, op: BinaryOp, a: Handle<Expr>, b: Handle<Expr>, span: Span) -> Res<Handle<Expr>> {
        let (a, b) = if matches!(op, BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul | BinaryOp::Div) {
            self.widen_pair(a, b, span)?
        } else {
            (a, b)
        };
        self.append(Expr::Binary { op, lhs: a, rhs: b }, span)
    }

    fn compose(&mut self, hs: Vec<Handle<Expr>>, ty: Option<Ty>, span: Span) -> Res<Handle<Expr>> {
        if hs.len() == 1 && ty.is_none() {
            return Ok(hs[0]);
        }
        let width: usize = hs.iter().map(|h| self.module.info(*h).ty.width()).sum();
        let ty = match ty {
            Some(t) => t,
            None => match width {
                2 => Ty::Vec2,
                3 => Ty::Vec3,
                4 => Ty::Rgba,
                n => {
                    self.error(
                        "type-mismatch",
                        format!("a tuple of {n} components is not a value"),
                        span,
                        "2, 3 or 4 components",
                        "write (u, v), (x, y, z) or (r, g, b, a)",
                    );
                    return Err(());
                }
            },
        };
        // `rgb(v)` of a vec3 is a colour, `vec3(c)` of a colour a vector,
        // `rgba(c)` of an rgb the colour with alpha 1, `rgb(s)` a grey.
        if hs.len() == 1 {
            if let Some(h) = self.coerce(hs[0], ty, span)? {
                return Ok(h);
            }
        }
        self.append(Expr::Compose { ty, components: hs }, span)
    }

    fn swizzle(&mut self, h: Handle<Expr>, components: &str, span: Span) -> Res<Handle<Expr>> {
        let mut pattern = [0u8; 4];
        let mut xyzw = false;
        let mut rgba = false;
        let chars: Vec<char> = components.chars().collect();
        if chars.is_empty() || chars.len() > 4 {
            self.error(
                "bad-swizzle",
                format!("`.{components}` selects {} components", chars.len()),
                span,
                "1 to 4 components",
                "write `.x`, `.xy`, `.rgb`, `.a`…",
            );
            return Err(());
        }
        for (i, c) in chars.iter().enumerate() {
            pattern[i] = match c {
                'x' | 'r' => 0,
                'y' | 'g' => 1,
                'z' | 'b' => 2,
                'w' | 'a' => 3,
                _ => {
                    self.error(
                        "bad-swizzle",
                        format!("`{c}` is not a component"),
                        span,
                        "unknown component",
                        "components are x y z w, or r g b a",
                    );
                    return Err(());
                }
            };
            if "xyzw".contains(*c) {
                xyzw = true;
            } else {
                rgba = true;
            }
        }
        if xyzw && rgba {
            self.error(
                "bad-swizzle",
                format!("`.{components}` mixes xyzw and rgba"),
                span,
                "mixed component names",
                "use one naming: `.xyz` or `.rgb`",
            );
            return Err(());
        }
        let ty = match chars.len() {
            1 => Ty::Scalar,
            2 => Ty::Vec2,
            3 if rgba => Ty::Rgb,
            3 => Ty::Vec3,
            _ => Ty::Rgba,
        };
        // `.rgb` of an rgb, `.xyz` of a vec3: nothing to do.
        let src = self.module.info(h).ty;
        if src == ty && (0..chars.len()).all(|i| pattern[i] as usize == i) {
            return Ok(h);
        }
        self.append(Expr::Swizzle { value: h, pattern, len: chars.len() as u8, ty }, span)
    }

    fn lookup_local(&self, key: &str) -> Option<Value> {
        self.locals.iter().rev().find(|(k, _)| k == key).map(|(_, v)| v.clone())
    }

    fn name(&mut self, n: &'a ast::Name) -> Res<Value> {
        let key = n.key();
        if let Some(v) = self.lookup_local(&key) {
            return Ok(v);
        }
        match self.globals.get(&key).copied() {
            Some(Global::Const(h)) => Ok(Value::Expr(h)),
            Some(Global::Uniform(id)) => self.append(Expr::Uniform(id), n.span).map(Value::Expr),
            Some(Global::Let(l)) => self.let_value(l),
            Some(Global::Vector(id)) => match self.bundles.last().cloned() {
                Some(b) => self.member(&b, id, n.span).map(Value::Expr),
                None => {
                    self.error("no-site", format!("the shading vector `{key}` needs a site"), n.span, "where is it evaluated?", format!("select it from a parameter vector: `{key} s x` (at a vertex) or `{key} δ s x` (interpolated), or use it inside a shader"));
                    Err(())
                }
            },
            Some(Global::Params(i)) => Ok(Value::ParamsName(self.params[i].clone())),
            Some(Global::Texture(_) | Global::Framebuffer(_) | Global::Shader(_)) => {
                self.error(
                    "type-mismatch",
                    format!("`{key}` is a table or shader, not a value"),
                    n.span,
                    "apply it",
                    match self.globals.get(&key) {
                        Some(Global::Framebuffer(_)) => {
                            format!("read a framebuffer at an index: `{key} δπx` (the fragment's pixel) or `{key} xs` (in a screen pass)")
                        }
                        Some(Global::Shader(_)) => format!(
                            "apply the shader to the shading parameters: `{key} δ s x` (per fragment) or `δ {key} s x` (per vertex, interpolated)"
                        ),
                        _ => format!("apply it to an index, such as `{key} δu x`"),
                    },
                );
                Err(())
            }
            None => match resolve::family(n) {
                Some(Entity::Vertex) => Ok(Value::Vertex(self.vertex_id(n))),
                Some(Entity::Pixel) => {
                    self.append(Expr::Pixel { freq: Frequency::Screen }, n.span).map(Value::Expr)
                }
                Some(Entity::TexCoords) => {
                    self.texcoord_id(n);
                    Ok(Value::TexCoordSet)
                }
                Some(Entity::Params) => Ok(Value::ParamsName(self.all_vectors())),
                Some(Entity::Framebuffer) => {
                    self.error(
                        "type-mismatch",
                        format!("the framebuffer `{key}` is not a value"),
                        n.span,
                        "apply it",
                        format!("read it at a position: `{key} δπx` or `{key} xs`"),
                    );
                    Err(())
                }
                _ => {
                    if FUNCTIONS.contains(&key.as_str()) {
                        self.error(
                            "type-mismatch",
                            format!("the function `{key}` is not a value"),
                            n.span,
                            "apply it",
                            format!("call it: `{key}(…)`"),
                        );
                    } else {
                        self.error(
                            "unknown-name",
                            format!("unknown name `{key}`"),
                            n.span,
                            "not declared",
                            "declare it first",
                        );
                    }
                    Err(())
                }
            },
        }
    }

    fn all_vectors(&self) -> Vec<VectorId> {
        (0..self.module.vectors.len() as u32).collect()
    }

    fn let_value(&mut self, l: &'a ast::LetDecl) -> Res<Value> {
        let key = l.name.key();
        self.used.insert(key.clone());
        if let Some(v) = self.let_cache.get(&key) {
            return Ok(v.clone());
        }
        // A global `let` sees no shader locals.
        let locals = std::mem::take(&mut self.locals);
        let bundles = std::mem::take(&mut self.bundles);
        let r = self.nested(&key, l.name.span, |this| this.lower_expr(&l.value));
        self.locals = locals;
        self.bundles = bundles;
        let v = r?;
        self.let_cache.insert(key, v.clone());
        Ok(v)
    }

    /// Vector `id` of bundle `b`, as an IR node.
    fn member(&mut self, b: &Bundle, id: VectorId, span: Span) -> Res<Handle<Expr>> {
        let Some(pos) = b.members.iter().position(|m| *m == id) else {
            let name = self.module.vectors[id as usize].name.clone();
            self.error(
                "not-a-member",
                format!("`{name}` is not a member of this shading-parameter vector"),
                span,
                "not in the bundle",
                format!("add `{name}` to its `params` declaration"),
            );
            return Err(());
        };
        match b.site {
            BundleSite::Vertex(x) => self.vector_at(id, Site::Vertex(x), b, span),
            BundleSite::Texel => match (self.vector_decls[id as usize], self.surface_vertex(span)?) {
                (None, Some(x)) => {
                    let h = self.vector_at(id, Site::Vertex(x), b, span)?;
                    self.interpolate(h, Frequency::Texel, span)
                }
                _ => self.vector_at(id, Site::Texel, b, span),
            },
            BundleSite::Interpolated(x, to) => {
                let at_vertex = Bundle { members: b.members.clone(), site: BundleSite::Vertex(x) };
                let h = self.vector_at(id, Site::Vertex(x), &at_vertex, span)?;
                self.interpolate(h, to, span)
            }
            BundleSite::Fat(texel) => self.append(Expr::FatMember { texel, member: pos as u8 }, span),
        }
    }

    /// A vector evaluated at a vertex or texel: a leaf for a role, or its
    /// declared expression with the other members of `b` at the same site.
    fn vector_at(&mut self, id: VectorId, site: Site, b: &Bundle, span: Span) -> Res<Handle<Expr>> {
        match self.vector_decls[id as usize] {
            None => self.append(Expr::Vector { vector: id, site }, span),
            Some(value) => {
                let locals = std::mem::take(&mut self.locals);
                self.bundles.push(Bundle { members: self.all_vectors(), site: b.site });
                let name = self.module.vectors[id as usize].name.clone();
                let r = self
                    .nested(&name, span, |l| l.lower_expr(value).and_then(|v| l.expect_expr(v, value.span)));
                self.bundles.pop();
                self.locals = locals;
                r
            }
        }
    }

    fn interpolate(&mut self, h: Handle<Expr>, to: Frequency, span: Span) -> Res<Handle<Expr>> {
        self.append(Expr::Interpolate { value: h, to }, span)
    }

    fn bundle_members(&mut self, b: &Bundle, span: Span) -> Res<Vec<Handle<Expr>>> {
        let mut v = Vec::new();
        for &m in &b.members.clone() {
            v.push(self.member(b, m, span)?);
        }
        Ok(v)
    }

    // ---- application ---------------------------------------------------

    fn apply(&mut self, func: &'a ast::Func, arg: &'a ast::Expr, span: Span) -> Res<Value> {
        match &func.kind {
            FuncKind::Delta => {
                let saved = std::mem::replace(&mut self.distributed, false);
                self.under_delta += 1;
                let v = self.lower_expr(arg);
                self.under_delta -= 1;
                let distributed = std::mem::replace(&mut self.distributed, saved);
                self.delta(v?, distributed, func.span, span)
            }
            FuncKind::Projection(p) => {
                let v = self.lower_expr(arg)?;
                let h = self.expect_expr(v, arg.span)?;
                let projection =
                    Projection { subscript: p.subscript.clone(), star: p.star, inverse: p.inverse };
                self.append(Expr::Project { projection, value: h }, span).map(Value::Expr)
            }
            FuncKind::Channel(ch) => {
                let v = self.lower_expr(arg)?;
                let h = self.expect_expr(v, arg.span)?;
                let channel = match ch {
                    ast::Channel::Alpha => FbChannel::Alpha,
                    ast::Channel::Depth => FbChannel::Depth,
                    ast::Channel::Stencil => FbChannel::Stencil,
                };
                match self.module.exprs[h].clone() {
                    Expr::FramebufferRead { framebuffer, channel: FbChannel::Color, position } => self
                        .append(Expr::FramebufferRead { framebuffer, channel, position }, span)
                        .map(Value::Expr),
                    _ if channel == FbChannel::Depth => self.append(Expr::Depth(h), span).map(Value::Expr),
                    _ if channel == FbChannel::Alpha && self.module.info(h).ty == Ty::Rgba => {
                        self.swizzle(h, "a", span).map(Value::Expr)
                    }
                    _ => {
                        self.error(
                            "type-mismatch",
                            "a channel selector needs a framebuffer",
                            func.span,
                            "selects a framebuffer channel",
                            "write `α C δπx`, `z C xs`, `σ C δπx`",
                        );
                        Err(())
                    }
                }
            }
            FuncKind::Name(n) => self.apply_name(n, arg, span),
        }
    }

    fn delta(&mut self, v: Value, distributed: bool, delta_span: Span, span: Span) -> Res<Value> {
        let Some(to) = self.sample else {
            let (message, label) = match self.statement_freq {
                Some(Frequency::Vertex) => (
                    "δ makes a per-fragment value, but this is a per-vertex target",
                    "per-fragment value in a per-vertex statement",
                ),
                Some(Frequency::Screen) => (
                    "δ in a screen pass: `C xs ←` draws no primitives to interpolate over",
                    "nothing to rasterize",
                ),
                _ => (
                    "δ outside a statement: constants and uniforms are not rasterized",
                    "δ rasterizes primitives",
                ),
            };
            self.error("frequency", message, delta_span, label, "δ belongs in statements that draw: `C δπx ← …`, `T δu ← …`; a texgen `u x ←` runs per vertex and a screen pass `C xs ←` per pixel");
            return Err(());
        };
        match v {
            Value::Bundle(Bundle { members, site: BundleSite::Vertex(x) }) => {
                Ok(Value::Bundle(Bundle { members, site: BundleSite::Interpolated(x, to) }))
            }
            Value::Bundle(_) => {
                self.error(
                    "delta-twice",
                    "δ applied to a shading-parameter vector that is not per vertex",
                    delta_span,
                    "δ applied twice",
                    "δ interpolates per-vertex values; remove one δ",
                );
                Err(())
            }
            Value::Vertex(x) => {
                let p = self.append(Expr::VertexPosition(x), span)?;
                self.interpolate(p, to, span).map(Value::Expr)
            }
            Value::TexCoordSet => {
                if to != Frequency::Texel {
                    self.error("bad-index", "`δu` without a vertex is the coordinate of the texel being rendered", span, "only in texture shading", "write `δu x` for interpolated texture coordinates; `T δu ← …` renders a texture in its own coordinates");
                    return Err(());
                }
                self.append(Expr::TexelCoord, span).map(Value::Expr)
            }
            Value::ParamsName(_) => {
                self.error(
                    "type-mismatch",
                    "δ of an unapplied parameter vector",
                    span,
                    "no vertex",
                    "write `δ s x`",
                );
                Err(())
            }
            Value::Expr(h) => {
                if let Expr::Pixel { freq: Frequency::Screen } = self.module.exprs[h] {
                    // `δ xs`: the fragment at pixel xs (seeds/001 (10)).
                    return self.append(Expr::Pixel { freq: to }, span).map(Value::Expr);
                }
                let info = *self.module.info(h);
                match info.freq {
                    Frequency::Constant | Frequency::Uniform => Ok(Value::Expr(h)),
                    Frequency::Vertex => self.interpolate(h, to, span).map(Value::Expr),
                    // EMBM (seeds/001 (8)): δ distributed over the operators while
                    // its argument was lowered, interpolating the per-vertex operands.
                    _ if distributed => Ok(Value::Expr(h)),
                    _ => {
                        self.error(
                            "delta-twice",
                            format!("δ applied to a value that is already {}", info.freq.name()),
                            delta_span,
                            "δ applied twice",
                            "δ interpolates per-vertex values; remove one δ",
                        );
                        Err(())
                    }
                }
            }
        }
    }

    fn apply_name(&mut self, n: &'a ast::Name, arg: &'a ast::Expr, span: Span) -> Res<Value> {
        let key = n.key();
        let local = self.lookup_local(&key);
        let global = self.globals.get(&key).copied();
        if local.is_none() && global.is_none() && FUNCTIONS.contains(&key.as_str()) {
            return self.builtin(&key, arg, span).map(Value::Expr);
        }
        if let Some(v) = local {
            if let Value::ParamsName(members) = v {
                let a = self.lower_expr(arg)?;
                return self.params_at(members, a, arg.span);
            }
            self.unsupported(format!("applying the local `{key}`"), n.span);
            return Err(());
        }
        match global {
            Some(Global::Texture(id)) => {
                let a = self.lower_expr(arg)?;
                let coords = self.expect_expr(a, arg.span)?;
                self.append(Expr::Lookup { texture: id, coords }, span).map(Value::Expr)
            }
            Some(Global::Framebuffer(id)) => self.framebuffer_read(id, arg, span),
            Some(Global::Shader(s)) => {
                let a = self.lower_expr(arg)?;
                self.inline(s, a, arg.span, span).map(Value::Expr)
            }
            Some(Global::Vector(id)) => {
                let a = self.lower_expr(arg)?;
                let b = match a {
                    Value::Bundle(b) => b,
                    _ => {
                        self.error(
                            "type-mismatch",
                            format!("the vector `{key}` selects from a shading-parameter vector"),
                            arg.span,
                            "not a parameter vector",
                            format!("write `{key} s x` or `{key} δ s x`"),
                        );
                        return Err(());
                    }
                };
                self.member(&b, id, n.span.join(arg.span)).map(Value::Expr)
            }
            Some(Global::Params(i)) => {
                let a = self.lower_expr(arg)?;
                let members = self.params[i].clone();
                self.params_at(members, a, arg.span)
            }
            Some(Global::Let(_) | Global::Const(_) | Global::Uniform(_)) => {
                self.unsupported(format!("applying `{key}` to a value"), n.span);
                Err(())
            }
            None => match resolve::family(n) {
                Some(Entity::Params) => {
                    let a = self.lower_expr(arg)?;
                    let members = self.all_vectors();
                    self.params_at(members, a, arg.span)
                }
                Some(Entity::TexCoords) => {
                    let set = self.texcoord_id(n);
                    match self.lower_expr(arg)? {
                        Value::Vertex(x) => {
                            self.append(Expr::TexCoord { set, vertex: x }, span).map(Value::Expr)
                        }
                        _ => {
                            self.error(
                                "type-mismatch",
                                format!("`{key}` is indexed by a vertex"),
                                arg.span,
                                "not a vertex",
                                format!("write `{key} x`"),
                            );
                            Err(())
                        }
                    }
                }
                Some(Entity::Framebuffer) => {
                    let id = self.framebuffer_id(n, Vec::new());
                    self.framebuffer_read(id, arg, span)
                }
                _ => {
                    self.unsupported(format!("applying `{key}`"), n.span);
                    Err(())
                }
            },
        }
    }

    /// A member of `s δu` in `T δu ← …`: the vertex stream of the surface
    /// it is taken on, making the statement's index `δu x` the first time
    /// (the mesh rasterized in texture space, as (15) writes it). The mesh
    /// is the program's one vertex stream; with none, `None` (the member is
    /// a function of the texel coordinate); with several, an error.
    fn surface_vertex(&mut self, span: Span) -> Res<Option<VertexId>> {
        let Some((set, made)) = self.surface else { return Ok(None) };
        if let Some((x, _)) = made {
            return Ok(Some(x));
        }
        // Every vertex stream the program names (x, x′, …).
        let mut streams: Vec<ast::Name> = Vec::new();
        for item in &self.program.items {
            if let ItemKind::Statement(st) = &item.kind {
                for e in [&st.target.index, &st.value] {
                    e.walk(&mut |x| {
                        if let ExprKind::Name(n) = &x.kind {
                            if resolve::family(n) == Some(Entity::Vertex)
                                && !streams.iter().any(|s| s.key() == n.key())
                            {
                                streams.push(n.clone());
                            }
                        }
                    });
                }
            }
        }
        let x = match streams.as_slice() {
            [] => return Ok(None),
            [x] => self.vertex_id(x),
            _ => {
                self.error(
                    "ambiguous-surface",
                    "texture shading `s δu` on a program with several vertex streams: which surface `u` parameterizes is not said",
                    span,
                    "on which mesh?",
                    "name the stream: `T δu x ← p δ s x` rasterizes the mesh `x` in texture space (Pipeline Grammar, eq. (15))",
                );
                return Err(());
            }
        };
        let tc = self.append(Expr::TexCoord { set, vertex: x }, span)?;
        let index = self.interpolate(tc, Frequency::Texel, span)?;
        self.surface = Some((set, Some((x, index))));
        Ok(Some(x))
    }

    fn framebuffer_read(&mut self, id: u32, arg: &'a ast::Expr, span: Span) -> Res<Value> {
        let a = self.lower_expr(arg)?;
        let position = self.expect_expr(a, arg.span)?;
        self.append(Expr::FramebufferRead { framebuffer: id, channel: FbChannel::Color, position }, span)
            .map(Value::Expr)
    }

    /// `s x`, `s δu`: a bundle at a vertex or at the texel being rendered.
    fn params_at(&mut self, members: Vec<VectorId>, a: Value, span: Span) -> Res<Value> {
        match a {
            Value::Vertex(x) => Ok(Value::Bundle(Bundle { members, site: BundleSite::Vertex(x) })),
            Value::Expr(h) if matches!(self.module.exprs[h], Expr::TexelCoord) => {
                Ok(Value::Bundle(Bundle { members, site: BundleSite::Texel }))
            }
            _ => {
                self.error(
                    "type-mismatch",
                    "a shading-parameter vector is indexed by a vertex or a texel",
                    span,
                    "not a vertex",
                    "write `s x` (at a vertex) or `s δu` (texture shading)",
                );
                Err(())
            }
        }
    }

    fn inline(
        &mut self,
        s: &'a ast::ShaderDecl,
        arg: Value,
        arg_span: Span,
        span: Span,
    ) -> Res<Handle<Expr>> {
        self.used.insert(s.name.key());
        let input_members = match self.globals.get(&s.input.key()) {
            Some(Global::Params(i)) => self.params[*i].clone(),
            _ => self.all_vectors(),
        };
        let bundle = match arg {
            Value::Bundle(b) => b,
            Value::Expr(h)
                if self.module.info(h).ty.is_color()
                    && matches!(self.module.exprs[h], Expr::Lookup { .. }) =>
            {
                // A fat texel holds the shader's parameters (seeds/001 (6), (14), (16)).
                Bundle { members: input_members, site: BundleSite::Fat(h) }
            }
            _ => {
                self.error(
                    "type-mismatch",
                    format!(
                        "the shader `{}` is applied to something that is not a shading-parameter vector",
                        s.name.key()
                    ),
                    arg_span,
                    "not a parameter vector",
                    "apply a shader to `s x`, `δ s x`, `s δu` or a fat-texture lookup `T δu x`",
                );
                return Err(());
            }
        };
        let saved = std::mem::take(&mut self.locals);
        self.locals.push((s.input.key(), Value::Bundle(bundle.clone())));
        self.bundles.push(bundle);
        let r = self.nested(&s.name.key(), span, |l| l.shader_body(s, span));
        self.bundles.pop();
        self.locals = saved;
        r
    }

    fn shader_body(&mut self, s: &'a ast::ShaderDecl, span: Span) -> Res<Handle<Expr>> {
        for p in &s.params {
            let Some(d) = &p.default else {
                self.unsupported(format!("the shader parameter `{}` has no default, and parameters cannot be set at the use site yet", p.name.key()), p.name.span);
                return Err(());
            };
            let v = self.lower_expr(d)?;
            let h = self.expect_expr(v, d.span)?;
            let h = self.annotate(h, p.ty.as_ref(), d.span)?;
            self.locals.push((p.name.key(), Value::Expr(h)));
        }
        for l in &s.lets {
            let v = self.lower_expr(&l.value)?;
            self.locals.push((l.name.key(), v));
        }
        let v = self.lower_expr(&s.body)?;
        let h = self.expect_expr(v, s.body.span)?;
        let have = self.module.info(h).ty;
        let want = Ty::from_ast(s.output.value);
        // The declared `s → t` is the type of every use: the declaration is
        // checked (`check_unused`) and each use inlined through this one rule,
        // so a shader that checks where it is declared types alike where it is used.
        let coerced = self.coerce(h, want, s.body.span)?;
        let Some(h) = coerced else {
            self.diagnostics.push(
                Diagnostic::error(
                    "type-mismatch",
                    format!(
                        "the shader `{}` returns a {}, not the declared {}",
                        s.name.key(),
                        have.name(),
                        want.name()
                    ),
                    s.body.span,
                    format!("a {}", have.name()),
                )
                .with_label(s.output.span, "declared here")
                .with_label(span, "inlined here")
                .with_help(format!("declare it `: s → {}`", have.name())),
            );
            return Err(());
        };
        Ok(h)
    }

    fn builtin(&mut self, key: &str, arg: &'a ast::Expr, span: Span) -> Res<Handle<Expr>> {
        let items: Vec<&'a ast::Expr> = match &arg.kind {
            ExprKind::Tuple(items) => items.iter().collect(),
            _ => vec![arg],
        };
        let mut args = Vec::new();
        for i in &items {
            let v = self.lower_expr(i)?;
            args.push(self.expect_expr(v, i.span)?);
        }
        let n_args = |l: &mut Self, n: usize| -> Res<()> {
            if args.len() != n {
                l.error(
                    "arity",
                    format!("`{key}` takes {n} argument(s), got {}", args.len()),
                    span,
                    "wrong number of arguments",
                    format!("write `{key}(…)` with {n} argument(s)"),
                );
                return Err(());
            }
            Ok(())
        };
        use MathFunction::*;
        let fun = match key {
            "dot" => {
                n_args(self, 2)?;
                return self.binary(BinaryOp::Dot, args[0], args[1], span);
            }
            "pow" => {
                n_args(self, 2)?;
                return self.binary(BinaryOp::Pow, args[0], args[1], span);
            }
            "rgb" => return self.compose(args, Some(Ty::Rgb), span),
            "rgba" | "vec4" => return self.compose(args, Some(Ty::Rgba), span),
            "vec2" => return self.compose(args, Some(Ty::Vec2), span),
            "vec3" => return self.compose(args, Some(Ty::Vec3), span),
            "normalize" => Normalize,
            "length" => Length,
            "cross" => Cross,
            "reflect" => Reflect,
            "max" => Max,
            "min" => Min,
            "clamp" => Clamp,
            "saturate" => Saturate,
            "abs" => Abs,
            "sign" => Sign,
            "sqrt" => Sqrt,
            "rsqrt" => Rsqrt,
            "exp" => Exp,
            "log" => Log,
            "sin" => Sin,
            "cos" => Cos,
            "floor" => Floor,
            "fract" => Fract,
            "step" => Step,
            "smoothstep" => Smoothstep,
            "lerp" | "mix" => Mix,
            "expand" => Expand,
            "half_bias" => HalfBias,
            "compress" => Compress,
            other => {
                self.unsupported(format!("the built-in `{other}`"), span);
                return Err(());
            }
        };
        // Componentwise functions take rgb and rgba together by widening.
        if matches!(fun, Max | Min | Clamp | Mix) && args.len() >= 2 {
            let (a, b) = self.widen_pair(args[0], args[1], span)?;
            args[0] = a;
            args[1] = b;
        }
        self.append(Expr::Math { fun, args }, span)
    }
}

/// Whether `e` or a subexpression satisfies `pred`.
fn contains(e: &ast::Expr, pred: &dyn Fn(&ast::Expr) -> bool) -> bool {
    let mut found = false;
    e.walk(&mut |x| found |= pred(x));
    found
}

/// `e` with its operands replaced, in `Expr::operands` order.
fn replace_operands(e: Expr, new: &[Handle<Expr>]) -> Expr {
    let mut it = new.iter().copied();
    let mut next = || it.next().expect("one handle per operand");
    match e {
        Expr::Project { projection, .. } => Expr::Project { projection, value: next() },
        Expr::Interpolate { to, .. } => Expr::Interpolate { value: next(), to },
        Expr::Unary { op, .. } => Expr::Unary { op, value: next() },
        Expr::Swizzle { pattern, len, ty, .. } => Expr::Swizzle { value: next(), pattern, len, ty },
        Expr::Convert { to, .. } => Expr::Convert { value: next(), to },
        Expr::Lookup { texture, .. } => Expr::Lookup { texture, coords: next() },
        Expr::FramebufferRead { framebuffer, channel, .. } => {
            Expr::FramebufferRead { framebuffer, channel, position: next() }
        }
        Expr::Depth(_) => Expr::Depth(next()),
        Expr::FatMember { member, .. } => Expr::FatMember { texel: next(), member },
        Expr::Bundle(_) => Expr::Bundle(new.to_vec()),
        Expr::Math { fun, .. } => Expr::Math { fun, args: new.to_vec() },
        Expr::Compose { ty, .. } => Expr::Compose { ty, components: new.to_vec() },
        Expr::Binary { op, .. } => Expr::Binary { op, lhs: next(), rhs: next() },
        Expr::Combine { mode, .. } => Expr::Combine { mode, lhs: next(), rhs: next() },
        Expr::Select { reject, .. } => {
            let cond = next();
            let accept = next();
            Expr::Select { cond, accept, reject: reject.map(|_| next()) }
        }
        leaf => leaf,
    }
}
