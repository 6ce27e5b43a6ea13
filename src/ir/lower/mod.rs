//! AST → IR: resolve names, inline shaders and `let`s, apply the δ rules,
//! fold constants, intern every node (see the `ir` module doc).
//!
//! Declarations are lowered first (resources, constants, uniforms); `let`s
//! and shaders are lowered where they are used, in the context of the
//! statement (which fixes what δ interpolates to); those no statement uses
//! are type-checked at the end and dropped (`check_unused`). Texgen
//! statements (`u x ← …`) are lowered before the others, because they give
//! their coordinate set a type.

use std::collections::{HashMap, HashSet};

use super::valid::{self, TypeError};
use super::{
    BinaryOp, Constant, Expr, FbChannel, Frequency, Handle, MathFunction, Module, Projection, Site,
    Statement, Table, TexCoordSet, Texture, Ty, UnaryOp, Uniform, Vector, VectorId, VertexId,
};
use crate::diag::Diagnostic;
use crate::parser::ast::{self, ExprKind, FuncKind, ItemKind};
use crate::parser::resolve::{self, Entity, FUNCTIONS};
use crate::span::Span;

mod apply;
mod bake;
mod declare;
mod expr;
mod statement;

use bake::*;

/// The module of `src`, which must check without errors: what unit tests
/// of the passes over a module start from.
#[cfg(test)]
pub fn lowered(src: &str) -> Module {
    let (program, diags) = crate::parser::check(src);
    assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
    lower(&program).0
}

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
        inlined: HashMap::new(),
        used: Default::default(),
        locals: Vec::new(),
        bundles: Vec::new(),
        defining: HashSet::new(),
        expr_depth: 0,
        under_delta: 0,
        distributed: false,
        surface: None,
        texel_volume: false,
        written: Default::default(),
        vec3_tuples: Vec::new(),
    };
    l.run();
    l.module.declared = super::declared::read(program).into();
    l.diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    (l.module, l.diagnostics)
}

/// Where a shading-parameter bundle is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
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

/// A shader's declaration (by address), the bundle it is applied to, and
/// the depth of δ it is applied under.
type InlineKey = (usize, Vec<VectorId>, BundleSite, usize);

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
    /// Shaders inlined in the current statement: a shader applied twice to
    /// one bundle is one value (`p₁ s = p₀ s · p₀ s`, and so on: twenty
    /// such shaders inlined `2²⁰` bodies before). With whether the body
    /// distributed a δ. Keyed by the declaration, the bundle and the δ depth.
    inlined: HashMap<InlineKey, (Handle<Expr>, bool)>,
    /// Shader locals, innermost last; a `None` name marks a scope boundary.
    locals: Vec<(String, Value)>,
    /// The bundle the shader being inlined was applied to.
    bundles: Vec<Bundle>,
    /// Names of the definitions being inlined: one met again is a cycle.
    defining: HashSet<String>,
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
    /// In a texture-shading statement of a `3d` texture: `s.xyz` is the
    /// 3-D texel's coordinate (`texel_coordinate`).
    texel_volume: bool,
    /// Framebuffers some statement before the current one writes (in source
    /// order, whether or not it lowered): reading one of these is reading
    /// what was drawn, not the cleared buffer.
    written: std::collections::HashSet<u32>,
    /// Constant tuples that lowered to a vec3, with their components as
    /// written: a type error naming the `rgb(…)` of one (before any
    /// folding changed its values) labels it.
    vec3_tuples: Vec<(Span, [f64; 3])>,
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
        self.warn_never_written();
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
                    self.inlined.clear();
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
                    self.inlined.clear();
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

    #[allow(clippy::expect_used)] // a constant node has its constant's type: nothing to check
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
                    format!("declared {} but the value is {}", want_ty.name(), have.a_name()),
                    span,
                    have.a_name(),
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
    #[allow(clippy::expect_used)] // callers pass `e`'s own operands, mapped one to one
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
