//! The shading IR: a typed, hash-consed DAG of expressions with computation
//! frequencies and value ranges, lowered from the checked AST.
//!
//! # What a module holds
//!
//! A [`Module`] is the program after name resolution, inlining and constant
//! folding. Its resources (textures, framebuffers, shading vectors, uniforms,
//! vertex streams, texture-coordinate sets) are plain lists indexed by small
//! ids; its [`Statement`]s are the `←` assignments of Pipeline Grammar in source
//! order, each one pass until the planner splits it; every value is an
//! [`Expr`] in one [`UniqueArena`], so identical subexpressions are one node
//! (hash-consing: `Ncube δ L s x` used by two `let`s is one lookup, hence one
//! texture unit). Handles point backwards only: a node's operands were
//! appended before it, so walking the arena in order is a topological order.
//!
//! # Types, frequencies, ranges: a side table
//!
//! Every node has an [`ExprInfo`] in `Module::info` (same index as the
//! handle), computed by [`valid::infer`] when the node is appended — naga
//! keeps types in a side table too; ours is filled eagerly because lowering
//! needs the type of an operand to lower its user (shader inlining, texture
//! coordinates). The info says:
//!
//! - **type** ([`Ty`]): `scalar`, `vec2` (texture coordinates), `vec3`
//!   (direction), `rgb`, `rgba`, plus `position` (a point from `x`, `π x`,
//!   `xs`) and `bundle(n)` (a whole shading-parameter vector `s`, stored into a
//!   fat texture, Pipeline Grammar, eq. (5), (15)). `vec3` and `rgb` are both
//!   three-component and mix freely in arithmetic (a normal-map texel *is* a
//!   vector, Kilgard 2000, Section 5.3); a dot product needs two three-component
//!   operands; an `rgb` widens to `rgba` (alpha 1) where an `rgba` is needed,
//!   through an explicit [`Expr::Convert`].
//! - **frequency** ([`Frequency`]): where the value is computed, read from
//!   where δ stands (Pipeline Grammar, Section 3.1-3.2). Constants and uniforms (per
//!   object) join anything; right of δ is per vertex; `δ e` is
//!   [`Expr::Interpolate`], which takes a per-vertex value to the statement's
//!   *sample* frequency: per fragment (`C δπx ←`, `T δπx ←`), or per texel
//!   when the statement renders into a texture in its own coordinates
//!   (`T δu ←`, `T δu x ←`, texture shading, Pipeline Grammar, eq. (13), (15)). A screen
//!   pass `C xs ←` (Pipeline Grammar, eq. (6)) reads framebuffers per pixel and has no δ.
//!   The three sample frequencies do not mix: a value is per fragment, per
//!   texel or per screen pixel, never two of them.
//! - **range** ([`Range`], from a conservative interval): unsigned \[0,1\]
//!   (8-bit textures, colours, the final combiner), signed [−1,1] (unit
//!   vectors, the general combiners, signed textures) or unbounded. Dot
//!   products of two signed operands are taken as dot products of unit
//!   vectors, hence signed: the register combiners clamp them to [−1,1]
//!   anyway (Kilgard 2000, Section 4.2).
//!
//! # The semantics of lowering (Pipeline Grammar, Sections 2-3)
//!
//! - `x` is a vertex ([`Expr::VertexPosition`], per vertex); `u x` its
//!   texture coordinates ([`Expr::TexCoord`]); `s x` its shading parameters,
//!   a bundle that exists only during lowering: a vector `N` of the bundle at
//!   vertex `x` is [`Expr::Vector`]; a declared vector with a value
//!   (`vector H = normalize(L + V)`) is computed at the vertex from the other
//!   members. `δ s x` interpolates each member; `s δu` is the bundle as a
//!   function of the texel coordinate (texture shading); a fat-texture lookup
//!   `T δu x` used as a bundle gives [`Expr::FatMember`]s.
//! - `δ e`: `e` per vertex → [`Expr::Interpolate`]; `e` with per-vertex and
//!   per-sample parts (EMBM, Pipeline Grammar, eq. (8): `T δ((u x) + (T′ δu′ x))`) → δ
//!   distributes over the operators and interpolates only the per-vertex
//!   operands; `e` already per sample (`δ δ u x`) → error "δ applied twice";
//!   `e` constant or uniform → `e` (interpolating a constant is the constant).
//! - `T e` with `T` a texture is [`Expr::Lookup`]: one texture unit, at the
//!   frequency of `e`; the coordinates must match the texture's kind (1d:
//!   scalar, 2d: vec2 or a screen position, 3d and cube: vec3); indexing a
//!   texture by a colour is an error. A lookup whose coordinates depend on
//!   another per-sample lookup is a *dependent* lookup (texture shaders).
//! - `p a` with `p` a shader inlines the body with its parameter vector bound
//!   to the bundle `a` and its parameters bound to their defaults. `p s x` is
//!   per-vertex shading, `δ p s x` Gouraud (1), `p δ s x` fragment lighting (4).
//! - `π x` is [`Expr::Project`] of the vertex position (per vertex, a
//!   position); `δπx` the fragment's position; `πR v` of a direction is a
//!   vec2 (sphere-map texgen, Pipeline Grammar, eq. (7)); `π⁻¹ xs` goes back to model
//!   space.
//! - `C p` reads framebuffer `C` at position `p` ([`Expr::FramebufferRead`]);
//!   `α`, `z`, `σ` select its alpha, depth or stencil channel; `z` of a
//!   position is its depth.
//! - `⊕[mode]` is [`Expr::Combine`] (no mode: modulate); `c ? a : b` is
//!   [`Expr::Select`] (no `b`: keep the destination — shadow volumes).
//! - Constants fold: every operation whose operands are all constants is
//!   evaluated at compile time (f64, by [`eval::apply`], the one semantics
//!   the per-sample [`eval::Evaluator`] shares) and becomes one
//!   [`Expr::Constant`].
//!
//! Lowering never panics on a program `parser::check` accepts; what it cannot
//! lower yet is an error diagnostic saying "not yet supported". Shaders and
//! `let`s are inlined where they are used; one that no statement uses is
//! still type-checked (a shader on a per-texel bundle, a `let` per fragment)
//! and then dropped.
//!
//! # For the pass planner
//!
//! A [`Statement`] is one pass as written. [`Usage::of`] lists what it needs
//! (texture units = distinct per-sample lookups, interpolants, constant
//! registers, dependent lookups, …) with the nodes that need it, and
//! `crate::profile::fit` compares that with a target. To split a statement,
//! cut its DAG at a node: the node's value goes to the framebuffer (blend it
//! back with ⊕, `C δπx ← (C δπx) ⊕ …`) or to a texture rendered per texel;
//! frequencies say where each cut may go (per-vertex nodes move to the
//! vertex stage or to interpolants for free), ranges say whether an 8-bit
//! target can hold the cut value (unsigned) or must range-compress it
//! (signed, Kilgard 2000 `expand`), or cannot (unbounded). Hash-consing means
//! a node shared by two statements (Kilgard's `Tn δu x`) is the same handle.

pub mod arena;
mod chain;
pub mod declared;
pub mod dump;
pub mod eval;
pub mod lower;
pub mod persist;
pub mod usage;
pub mod valid;

use std::hash::{Hash, Hasher};

pub use arena::{Arena, Handle, UniqueArena};
pub use lower::lower;
pub use persist::{Layered, Shared};
pub use usage::{
    address_only, fat_layers, fragment_reach, power_by_squaring, register_reads, squaring_exponent, Usage,
};

use crate::parser::ast;
use crate::span::Span;

/// A lowered program.
#[derive(Clone, Debug, Default)]
pub struct Module {
    /// The profile the program names with `target X;`, if any.
    pub target: Option<ast::Word<String>>,
    pub textures: Shared<Vec<Texture>>,
    pub framebuffers: Shared<Vec<Framebuffer>>,
    pub vectors: Shared<Vec<Vector>>,
    pub uniforms: Shared<Vec<Uniform>>,
    /// Vertex streams by name: `x`, `x'`.
    pub vertices: Shared<Vec<String>>,
    /// Texture-coordinate sets: `u`, `u'`, `u*` (vertex attributes).
    pub texcoord_sets: Shared<Vec<TexCoordSet>>,
    /// Every value. Invariant: a node's operands precede it; equal nodes are
    /// one node (the span kept is the first occurrence's).
    pub exprs: UniqueArena<Expr>,
    /// `info[h.index()]` is the type, frequency and range of `exprs[h]`.
    pub info: Layered<ExprInfo>,
    /// The assignments, in source order.
    pub statements: Shared<Vec<Statement>>,
    /// The texture declarations as written, their generators typed
    /// ([`declared`]): what the scene binder builds textures from.
    pub declared: Shared<Vec<declared::DeclaredTexture>>,
}

impl Module {
    /// Whether `st` is the texel statement of a `bake(f)` table, which the
    /// compiler computes, not the target (`Texture::baked`).
    pub fn is_baked(&self, st: &Statement) -> bool {
        matches!(st.table, Table::Texture(id) if self.textures[id as usize].baked)
            && st.freq == Frequency::Texel
    }

    /// What `valid::infer` found for node `h`: type, frequency, interval.
    pub fn info(&self, h: Handle<Expr>) -> &ExprInfo {
        &self.info[h.index()]
    }

    /// The source span of node `h` (the first one, for a node shared by equal expressions).
    pub fn span(&self, h: Handle<Expr>) -> Span {
        self.exprs.arena().span(h)
    }

    /// The operands of a node, in order.
    pub fn operands(&self, h: Handle<Expr>) -> Vec<Handle<Expr>> {
        self.exprs[h].operands()
    }

    /// Appends (or finds) a node built after lowering — by the pass planner
    /// when it splits or fuses statements: infers its info and folds
    /// constants, as lowering does.
    pub fn intern(&mut self, e: Expr, span: Span) -> Result<Handle<Expr>, valid::TypeError> {
        if let Some(h) = self.exprs.find(&e) {
            return Ok(h);
        }
        let info = valid::infer(self, &e)?;
        if let Some(c) = valid::fold(self, &e, info.ty) {
            return self.intern(Expr::Constant(c), span);
        }
        let (h, new) = self.exprs.insert(e, span);
        if new {
            self.info.push(info);
        }
        Ok(h)
    }

    /// Whether `h` is the constant `v` in every component.
    pub fn is_constant(&self, h: Handle<Expr>, v: f64) -> bool {
        matches!(&self.exprs[h], Expr::Constant(c) if c.values().iter().all(|x| *x == v))
    }

    /// Every node reachable from `roots`, in arena (topological) order.
    ///
    /// The visited set is a bitset over the arena kept per thread and
    /// cleared after each call, and the result is sorted at the end (this runs for every value the planner measures; a `BTreeSet` per
    /// call was 6 % of a 100 000-operation plan).
    pub fn reachable(&self, roots: &[Handle<Expr>]) -> Vec<Handle<Expr>> {
        thread_local! {
            static SEEN: std::cell::RefCell<Vec<u64>> = const { std::cell::RefCell::new(Vec::new()) };
        }
        /// The marks of one call: cleared when it ends, also by a panic
        /// (the LSP server catches them and goes on using the thread).
        struct Marks<'a> {
            seen: std::cell::RefMut<'a, Vec<u64>>,
            out: Vec<Handle<Expr>>,
        }
        impl Marks<'_> {
            fn mark(&mut self, h: Handle<Expr>) {
                let (w, b) = (h.index() / 64, 1u64 << (h.index() % 64));
                if self.seen[w] & b == 0 {
                    self.seen[w] |= b;
                    self.out.push(h);
                }
            }
        }
        impl Drop for Marks<'_> {
            fn drop(&mut self) {
                for h in &self.out {
                    self.seen[h.index() / 64] = 0;
                }
            }
        }
        SEEN.with(|seen| {
            let mut marks = Marks { seen: seen.borrow_mut(), out: Vec::with_capacity(roots.len() * 16) };
            let words = self.exprs.len().div_ceil(64);
            if marks.seen.len() < words {
                marks.seen.resize(words, 0);
            }
            for &r in roots {
                marks.mark(r);
            }
            // `out` doubles as the work list: everything before `next` has
            // had its operands marked.
            let mut next = 0;
            while next < marks.out.len() {
                let h = marks.out[next];
                next += 1;
                self.exprs[h].visit_operands(|o| marks.mark(o));
            }
            let mut out = std::mem::take(&mut marks.out);
            for h in &out {
                marks.seen[h.index() / 64] = 0;
            }
            out.sort_unstable();
            out
        })
    }
}

/// A declared texture: a source image, a generated table, or a target statements render into.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub name: String,
    pub kind: ast::TextureKind,
    pub format: ast::TextureFormat,
    /// Written by a statement (texture shading, deferred shading) rather than
    /// loaded or generated.
    pub rendered: bool,
    /// Filled by `bake(f)`: a table the compiler computes on the CPU at
    /// compile time, which the target only samples — its texel
    /// pass is never the target's to run.
    pub baked: bool,
    /// For a texture the lowering added (a normalization cube map): what
    /// it is generated from, typed, so that executors bind it as they bind
    /// a declared one (`scene::bind::lowered_decls`).
    pub declaration: Option<AddedSource>,
    /// For a texture the lowering re-stores (rule
    /// `signed_texture_compression`): the declared texture whose
    /// source it loads or generates again, in this texture's format.
    pub copy_of: Option<String>,
    /// The function its generator tabulates, which a rule can compute
    /// instead of sampling it; `None` for images and rendered
    /// textures.
    pub tabulates: Option<Tabulated>,
    /// How it is sampled: its declaration's attributes, read once here
    /// for the binder and the cost model alike.
    pub sampling: Sampling,
    pub span: Span,
}

/// What a texture the lowering added is generated from: the generator a
/// declaration would name, with its arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AddedSource {
    /// `normalize_cube(size, bits)` (Kilgard 2000, Appendix D).
    NormalizeCube { size: u32, bits: u32 },
}

/// The function a generated table holds (its declaration's generator).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tabulated {
    /// `normalize_cube(…)`: the unit vector of the direction (GeForce3 Phong
    /// Section 4.2.2), range-compressed unless the format is signed — a
    /// lookup at `δ v` is `normalize(v)` up to a texel, which is what a
    /// per-vertex rule computes at the vertices.
    Normalize,
    /// `exponent_table(n)`: x ↦ xⁿ on [0, 1] (GeForce3 Phong, Figure 10),
    /// [`crate::textures::generators::EXPONENT_TABLE_SIZE`] texels,
    /// clamped at the edges.
    Power(f64),
}

/// A texture's filter, wrap and mipmaps, from its declaration's attributes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampling {
    pub filter: crate::textures::Filter,
    pub wrap: crate::textures::Wrap,
    pub mipmap: bool,
}

impl Sampling {
    /// The rules of the language (docs/language.md): `nearest` wins; a
    /// mipmapped texture is trilinear unless `bilinear` is said; cube maps
    /// and `clamp` clamp to the edge, everything else repeats.
    pub fn of(kind: ast::TextureKind, attrs: &[ast::TextureAttr]) -> Sampling {
        use crate::textures::{Filter, Wrap};
        let has = |a: ast::TextureAttr| attrs.contains(&a);
        let mipmap = has(ast::TextureAttr::Mipmap);
        let filter = if has(ast::TextureAttr::Nearest) {
            Filter::Nearest
        } else if has(ast::TextureAttr::Trilinear) || (mipmap && !has(ast::TextureAttr::Bilinear)) {
            Filter::Trilinear
        } else {
            Filter::Bilinear
        };
        let wrap = if has(ast::TextureAttr::Clamp) || kind == ast::TextureKind::Cube {
            Wrap::ClampToEdge
        } else {
            Wrap::Repeat
        };
        Sampling { filter, wrap, mipmap }
    }

    /// A texture the compiler adds (a temporary, a table): bilinear,
    /// clamped, one level.
    pub const ADDED: Sampling = Sampling {
        filter: crate::textures::Filter::Bilinear,
        wrap: crate::textures::Wrap::ClampToEdge,
        mipmap: false,
    };
}

/// A declared framebuffer and the channels it has (Pipeline Grammar's `C`).
#[derive(Clone, Debug, PartialEq)]
pub struct Framebuffer {
    pub name: String,
    pub channels: Vec<ast::FramebufferChannel>,
    pub span: Span,
}

/// A shading vector (`N`, `L`, `H`, …): a vertex attribute by its role, or computed.
#[derive(Clone, Debug, PartialEq)]
pub struct Vector {
    pub name: String,
    /// `None` for a computed vector (`vector H = normalize(L + V)`).
    pub kind: Option<ast::VectorKind>,
    pub index: Option<u32>,
    pub space: Option<ast::Space>,
    pub span: Span,
}

/// A texture-coordinate set: a vertex attribute, or generated by a texgen
/// statement `u x ← …` (Pipeline Grammar, eq. (7)), whose value type it takes.
#[derive(Clone, Debug, PartialEq)]
pub struct TexCoordSet {
    pub name: String,
    pub ty: Ty,
    pub generated: bool,
}

/// A per-object value the scene sets, with its type and declared default.
#[derive(Clone, Debug, PartialEq)]
pub struct Uniform {
    pub name: String,
    pub ty: Ty,
    pub default: Option<Constant>,
    pub span: Span,
}

/// An index into one of the module's resource lists.
pub type TextureId = u32;
/// An index into [`Module::framebuffers`].
pub type FramebufferId = u32;
/// An index into [`Module::vectors`].
pub type VectorId = u32;
/// An index into [`Module::uniforms`].
pub type UniformId = u32;
/// An index into [`Module::vertices`].
pub type VertexId = u32;
/// An index into [`Module::texcoord_sets`].
pub type TexCoordId = u32;

/// Value types (Pipeline Grammar, Figure 2's c is `rgb`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Ty {
    Scalar,
    /// Texture coordinates.
    Vec2,
    /// A direction.
    Vec3,
    Rgb,
    Rgba,
    /// A point: a vertex `x`, a projected vertex `π x`, a pixel `xs`.
    Position,
    /// A whole shading-parameter vector of `n` three-component members.
    Bundle(u8),
}

impl Ty {
    /// Components of a value (a position counts as 4, homogeneous).
    pub fn width(self) -> usize {
        match self {
            Ty::Scalar => 1,
            Ty::Vec2 => 2,
            Ty::Vec3 | Ty::Rgb => 3,
            Ty::Rgba | Ty::Position => 4,
            Ty::Bundle(n) => 3 * n as usize,
        }
    }

    /// Whether the type is a colour (`rgb` or `rgba`), whose components read as `r g b a`.
    pub fn is_color(self) -> bool {
        matches!(self, Ty::Rgb | Ty::Rgba)
    }

    /// Types that arithmetic and the built-in functions accept.
    pub fn is_numeric(self) -> bool {
        !matches!(self, Ty::Position | Ty::Bundle(_))
    }

    /// The type as the language writes it.
    pub fn name(self) -> String {
        match self {
            Ty::Scalar => "scalar".into(),
            Ty::Vec2 => "vec2".into(),
            Ty::Vec3 => "vec3".into(),
            Ty::Rgb => "rgb".into(),
            Ty::Rgba => "rgba".into(),
            Ty::Position => "position".into(),
            Ty::Bundle(n) => format!("bundle({n})"),
        }
    }

    /// The name with its article, for messages: "an rgb", "a vec3".
    pub fn a_name(self) -> String {
        let name = self.name();
        let article = if name.starts_with('r') { "an" } else { "a" };
        format!("{article} {name}")
    }

    /// The IR type of a type the source names.
    pub fn from_ast(ty: ast::Type) -> Ty {
        match ty {
            ast::Type::Scalar => Ty::Scalar,
            ast::Type::Vec2 => Ty::Vec2,
            ast::Type::Vec3 => Ty::Vec3,
            // A four-vector has no other use in the notation than a colour with alpha.
            ast::Type::Vec4 | ast::Type::Rgba => Ty::Rgba,
            ast::Type::Rgb | ast::Type::Color => Ty::Rgb,
        }
    }
}

/// Where a value is computed (Pipeline Grammar, Section 3: read from where δ stands).
/// Ordered: `Constant < Uniform < Vertex < {Fragment, Texel, Screen}`; the
/// last three are sample frequencies that never mix.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Frequency {
    /// Folded at compile time.
    Constant,
    /// Per object: a uniform, set by the scene.
    Uniform,
    /// Per vertex: right of δ.
    Vertex,
    /// Per fragment: left of δ in `C δπx ←`.
    Fragment,
    /// Per texel of a texture rendered in its own coordinates (`T δu ←`).
    Texel,
    /// Per pixel of a screen pass (`C xs ←`).
    Screen,
}

impl Frequency {
    /// Whether a value of this frequency is computed per sample (fragment, texel or pixel).
    pub fn is_sample(self) -> bool {
        self >= Frequency::Fragment
    }

    /// The frequency of a value computed from operands of `self` and
    /// `other`, or `None` when two different sample frequencies meet, or a
    /// per-vertex value meets a per-sample one without δ between them.
    pub fn join(self, other: Frequency) -> Option<Frequency> {
        let (lo, hi) = if self <= other { (self, other) } else { (other, self) };
        if hi.is_sample() && (lo == Frequency::Vertex || (lo.is_sample() && lo != hi)) {
            None
        } else {
            Some(self.max(other))
        }
    }

    /// The frequency as diagnostics and `--emit ir` name it.
    pub fn name(self) -> &'static str {
        match self {
            Frequency::Constant => "constant",
            Frequency::Uniform => "per-object",
            Frequency::Vertex => "per-vertex",
            Frequency::Fragment => "per-fragment",
            Frequency::Texel => "per-texel",
            Frequency::Screen => "per-pixel (screen pass)",
        }
    }
}

/// The value range class, as hardware sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Range {
    /// [0, 1]: 8-bit textures and framebuffers, colours.
    Unsigned,
    /// [−1, 1]: unit vectors, the general combiners, signed textures.
    Signed,
    Unbounded,
}

/// A conservative interval of every component of a value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    /// [0, 1]: what an unsigned 8-bit register holds.
    pub const UNSIGNED: Interval = Interval { lo: 0.0, hi: 1.0 };
    /// [−1, 1]: what a signed register holds.
    pub const SIGNED: Interval = Interval { lo: -1.0, hi: 1.0 };
    /// Every value: nothing known.
    pub const ALL: Interval = Interval { lo: f64::NEG_INFINITY, hi: f64::INFINITY };

    /// The interval holding `v` only.
    pub fn point(v: f64) -> Interval {
        Interval { lo: v, hi: v }
    }

    /// The narrowest register range the interval fits.
    pub fn class(self) -> Range {
        if self.lo >= 0.0 && self.hi <= 1.0 {
            Range::Unsigned
        } else if self.lo >= -1.0 && self.hi <= 1.0 {
            Range::Signed
        } else {
            Range::Unbounded
        }
    }
}

/// What `valid::infer` knows about a node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExprInfo {
    pub ty: Ty,
    pub freq: Frequency,
    pub interval: Interval,
    /// The range of each channel (a scalar's interval in all four), each
    /// within `interval`: where a colour's channels differ (a constant
    /// colour times a cosine), a sum of such terms is bounded channel by
    /// channel, however many terms it has (`valid::infer`).
    pub channels: [Interval; 4],
}

impl ExprInfo {
    /// A node's info with its interval in every channel.
    pub fn new(ty: Ty, freq: Frequency, interval: Interval) -> ExprInfo {
        ExprInfo { ty, freq, interval, channels: [interval; 4] }
    }

    /// The register range the node's values fit.
    pub fn range(&self) -> Range {
        self.interval.class()
    }
}

/// A compile-time value: up to four f64 components. Hashes and compares by
/// bits (−0 is stored as +0), so equal constants intern to one node.
#[derive(Clone, Copy, Debug)]
pub struct Constant {
    pub ty: Ty,
    pub components: [f64; 4],
}

impl Constant {
    /// A scalar constant.
    pub fn scalar(v: f64) -> Constant {
        Constant::new(Ty::Scalar, &[v])
    }

    /// A constant of type `ty` from its components (−0 stored as +0).
    pub fn new(ty: Ty, values: &[f64]) -> Constant {
        let mut components = [0.0; 4];
        for (c, v) in components.iter_mut().zip(values) {
            *c = if *v == 0.0 { 0.0 } else { *v };
        }
        Constant { ty, components }
    }

    /// The components the type has.
    pub fn values(&self) -> &[f64] {
        &self.components[..self.ty.width().min(4)]
    }
}

impl PartialEq for Constant {
    fn eq(&self, other: &Self) -> bool {
        self.ty == other.ty
            && self.components.iter().zip(&other.components).all(|(a, b)| a.to_bits() == b.to_bits())
    }
}
impl Eq for Constant {}
impl Hash for Constant {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.ty.hash(state);
        for c in &self.components {
            c.to_bits().hash(state);
        }
    }
}

/// Projections π (Pipeline Grammar, Figure 2): the camera's, a light's (`πl`), a
/// per-pass perturbed one (`π*`, (11)), or the inverse (`π⁻¹`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Projection {
    pub subscript: Option<String>,
    pub star: bool,
    pub inverse: bool,
}

/// Framebuffer channels a read or a write selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FbChannel {
    Color,
    Alpha,
    Depth,
    Stencil,
}

/// A unary operator of the IR.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    Neg,
    Not,
}

/// A binary operator of the IR (`Dot` is `·`, comparisons give 0 or 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Dot,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
    And,
    Or,
}

/// The built-in functions of `parser::resolve::FUNCTIONS`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MathFunction {
    Normalize,
    Length,
    Cross,
    Reflect,
    Max,
    Min,
    Clamp,
    Saturate,
    Abs,
    Sign,
    Sqrt,
    Rsqrt,
    Exp,
    Log,
    Sin,
    Cos,
    Floor,
    Fract,
    Step,
    Smoothstep,
    Mix,
    /// 2x − 1 (Kilgard 2000, Table 3, GL_EXPAND_NORMAL).
    Expand,
    /// x − ½.
    HalfBias,
    /// (x + 1)/2, the inverse of `expand`.
    Compress,
}

impl MathFunction {
    /// The function as the language spells it.
    pub fn name(self) -> &'static str {
        use MathFunction::*;
        match self {
            Normalize => "normalize",
            Length => "length",
            Cross => "cross",
            Reflect => "reflect",
            Max => "max",
            Min => "min",
            Clamp => "clamp",
            Saturate => "saturate",
            Abs => "abs",
            Sign => "sign",
            Sqrt => "sqrt",
            Rsqrt => "rsqrt",
            Exp => "exp",
            Log => "log",
            Sin => "sin",
            Cos => "cos",
            Floor => "floor",
            Fract => "fract",
            Step => "step",
            Smoothstep => "smoothstep",
            Mix => "mix",
            Expand => "expand",
            HalfBias => "half_bias",
            Compress => "compress",
        }
    }
}

/// Where a shading vector is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Site {
    /// At the vertices of stream `x`.
    Vertex(VertexId),
    /// As a function of the texel coordinate (texture shading, `s δu`).
    Texel,
}

/// One node of the DAG. Operands are handles to earlier nodes.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Expr {
    Constant(Constant),
    Uniform(UniformId),
    /// The vertex `x` itself: its model-space position.
    VertexPosition(VertexId),
    /// `u x`: a texture-coordinate set of a vertex.
    TexCoord {
        set: TexCoordId,
        vertex: VertexId,
    },
    /// A role-declared shading vector (`vector N : normal`) at a site.
    Vector {
        vector: VectorId,
        site: Site,
    },
    /// `δu` in texture shading: the coordinate of the texel being computed.
    TexelCoord,
    /// `xs`: the pixel of a screen pass; with `Fragment` frequency, `δ xs`.
    Pixel {
        freq: Frequency,
    },
    Project {
        projection: Projection,
        value: Handle<Expr>,
    },
    /// δ: interpolate a per-vertex value (perspective-correct) to `to`.
    Interpolate {
        value: Handle<Expr>,
        to: Frequency,
    },
    /// `T e`: one texture unit.
    Lookup {
        texture: TextureId,
        coords: Handle<Expr>,
    },
    FramebufferRead {
        framebuffer: FramebufferId,
        channel: FbChannel,
        position: Handle<Expr>,
    },
    /// The depth of a position (`z δπx'`).
    Depth(Handle<Expr>),
    /// Member `member` of a shading-parameter vector stored in a fat texel.
    FatMember {
        texel: Handle<Expr>,
        member: u8,
    },
    /// A shading-parameter vector as one value (written into a fat texture).
    Bundle(Vec<Handle<Expr>>),
    Unary {
        op: UnaryOp,
        value: Handle<Expr>,
    },
    Binary {
        op: BinaryOp,
        lhs: Handle<Expr>,
        rhs: Handle<Expr>,
    },
    /// `a ⊕[mode] b` (Pipeline Grammar, eq. (3)).
    Combine {
        mode: ast::CombineMode,
        lhs: Handle<Expr>,
        rhs: Handle<Expr>,
    },
    Math {
        fun: MathFunction,
        args: Vec<Handle<Expr>>,
    },
    /// Component selection: `pattern[..len]` are component indices.
    Swizzle {
        value: Handle<Expr>,
        pattern: [u8; 4],
        len: u8,
        ty: Ty,
    },
    /// `(a, b, c)`, `rgb(…)`, `rgba(c, a)`: components concatenated.
    Compose {
        ty: Ty,
        components: Vec<Handle<Expr>>,
    },
    /// `rgb` → `rgba` (alpha 1), or a scalar splatted to a vector.
    Convert {
        value: Handle<Expr>,
        to: Ty,
    },
    /// `c ? a : b`; without `b`, the destination is kept where `c` fails.
    Select {
        cond: Handle<Expr>,
        accept: Handle<Expr>,
        reject: Option<Handle<Expr>>,
    },
}

impl Expr {
    /// This node with every operand `o` replaced by `f(o)`.
    pub fn map_operands(&self, mut f: impl FnMut(Handle<Expr>) -> Handle<Expr>) -> Expr {
        let mut e = self.clone();
        match &mut e {
            Expr::Constant(_)
            | Expr::Uniform(_)
            | Expr::VertexPosition(_)
            | Expr::TexCoord { .. }
            | Expr::Vector { .. }
            | Expr::TexelCoord
            | Expr::Pixel { .. } => {}
            Expr::Project { value, .. }
            | Expr::Interpolate { value, .. }
            | Expr::Unary { value, .. }
            | Expr::Swizzle { value, .. }
            | Expr::Convert { value, .. } => *value = f(*value),
            Expr::Lookup { coords, .. } => *coords = f(*coords),
            Expr::FramebufferRead { position, .. } => *position = f(*position),
            Expr::Depth(h) => *h = f(*h),
            Expr::FatMember { texel, .. } => *texel = f(*texel),
            Expr::Bundle(v) | Expr::Math { args: v, .. } | Expr::Compose { components: v, .. } => {
                for h in v.iter_mut() {
                    *h = f(*h);
                }
            }
            Expr::Binary { lhs, rhs, .. } | Expr::Combine { lhs, rhs, .. } => {
                *lhs = f(*lhs);
                *rhs = f(*rhs);
            }
            Expr::Select { cond, accept, reject } => {
                *cond = f(*cond);
                *accept = f(*accept);
                if let Some(r) = reject {
                    *r = f(*r);
                }
            }
        }
        e
    }

    /// The node's operands, in `visit_operands` order.
    pub fn operands(&self) -> Vec<Handle<Expr>> {
        let mut v = Vec::new();
        self.visit_operands(|o| v.push(o));
        v
    }

    /// Calls `f` on each operand in order, without allocating: the planner
    /// walks values many times per statement.
    pub fn visit_operands(&self, mut f: impl FnMut(Handle<Expr>)) {
        match self {
            Expr::Constant(_)
            | Expr::Uniform(_)
            | Expr::VertexPosition(_)
            | Expr::TexCoord { .. }
            | Expr::Vector { .. }
            | Expr::TexelCoord
            | Expr::Pixel { .. } => {}
            Expr::Project { value, .. }
            | Expr::Interpolate { value, .. }
            | Expr::Unary { value, .. }
            | Expr::Swizzle { value, .. }
            | Expr::Convert { value, .. } => f(*value),
            Expr::Lookup { coords, .. } => f(*coords),
            Expr::FramebufferRead { position, .. } => f(*position),
            Expr::Depth(h) => f(*h),
            Expr::FatMember { texel, .. } => f(*texel),
            Expr::Bundle(v) | Expr::Math { args: v, .. } | Expr::Compose { components: v, .. } => {
                v.iter().copied().for_each(f)
            }
            Expr::Binary { lhs, rhs, .. } | Expr::Combine { lhs, rhs, .. } => {
                f(*lhs);
                f(*rhs)
            }
            Expr::Select { cond, accept, reject } => {
                f(*cond);
                f(*accept);
                reject.iter().copied().for_each(f)
            }
        }
    }
}

/// The table a statement writes.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Table {
    Framebuffer {
        id: FramebufferId,
        channel: FbChannel,
    },
    Texture(TextureId),
    /// `u x ←`: texture-coordinate generation (Pipeline Grammar, eq. (7)).
    TexCoords(TexCoordId),
}

impl Table {
    /// The table whose depth buffer a write into this one tests: a
    /// framebuffer's, whichever channel is written. `α C δπx ← …` and
    /// `C δπx ← …` draw into the one depth buffer of C (Pipeline Grammar,
    /// Section 3.5: α, z and σ select channels of one framebuffer), so the
    /// second draw of the same mesh tests `Equal`, not `Less` again.
    pub fn depth_target(&self) -> Table {
        match self {
            Table::Framebuffer { id, .. } => Table::Framebuffer { id: *id, channel: FbChannel::Color },
            other => other.clone(),
        }
    }
}

/// One `←` assignment.
#[derive(Clone, Debug)]
pub struct Statement {
    pub table: Table,
    /// Where it writes: the fragment position for `C δπx`, the texel
    /// coordinate for `T δu`, the pixel for `C xs`, the vertex for `u x`.
    pub index: Handle<Expr>,
    /// The frequency the statement runs at (what its index samples).
    pub freq: Frequency,
    pub value: Handle<Expr>,
    pub span: Span,
    /// The span of the left side.
    pub target_span: Span,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_intern_by_bits_and_zero_has_one_sign() {
        let mut a: UniqueArena<Expr> = UniqueArena::default();
        let (h1, _) = a.insert(Expr::Constant(Constant::scalar(0.0)), Span::DETACHED);
        let (h2, _) = a.insert(Expr::Constant(Constant::scalar(-0.0)), Span::DETACHED);
        assert_eq!(h1, h2);
        let (h3, _) = a.insert(Expr::Constant(Constant::new(Ty::Rgb, &[0.0, 0.0, 0.0])), Span::DETACHED);
        assert_ne!(h1, h3, "the type is part of a constant");
    }

    #[test]
    fn type_widths() {
        assert_eq!(Ty::Rgb.width(), 3);
        assert_eq!(Ty::Bundle(3).width(), 9);
        assert_eq!(Ty::from_ast(ast::Type::Color), Ty::Rgb);
    }
}
