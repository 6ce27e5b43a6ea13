//! The syntax tree of a `.shd` program: owned, every node with its byte span.
//!
//! It mirrors the notation of Pipeline Grammar, Section 2 (Figure 2): application is
//! right to left (`T δ u x` is `T(δ(u(x)))`), δ marks rasterization
//! (interpolate, then sample), π the projection, ⊕ a colour combination, and
//! the left side of `←` a table (framebuffer C, texture T, or a vertex
//! attribute such as `u`) indexed by pixel, texel or vertex.

use crate::span::Span;

/// A whole program: declarations and statements in source order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    pub items: Vec<Item>,
    /// Comments after the last item.
    pub trailing_comments: Vec<String>,
    /// The names of declarations left out for an error: still declared
    /// (poisoned), so their uses are not "unknown" too.
    pub poisoned: Vec<Poisoned>,
}

/// A name a failed declaration declares, with the keyword that declares it
/// (`vector`, `shader`, …).
#[derive(Clone, Debug, PartialEq)]
pub struct Poisoned {
    pub keyword: String,
    pub name: Name,
}

/// One top-level item: a declaration or a statement, with its comments.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    pub kind: ItemKind,
    pub span: Span,
    /// Comments are kept so `fmt` can rewrite a file in place and lose
    /// nothing: between items, on the lines of a `{ … }` shader block, and
    /// (moved above the item) anywhere else inside it.
    pub comments: Comments,
}

/// The comments around one item, as written (`// …`, `# …`, `/* … */`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Comments {
    /// Whole-line comments above the item; `""` stands for an empty line.
    pub leading: Vec<String>,
    /// A comment on the line where the item ends.
    pub trailing: Option<String>,
    /// Whether an empty line separates the item (and its leading comments)
    /// from the item before.
    pub blank_line_before: bool,
    /// Comments inside a `{ … }` shader block, one entry per line of the
    /// block: `lets[i]` for `i < lets.len()`, then the result, then the
    /// closing brace (`leading` only). Empty when the block has none.
    pub block: Vec<LineComments>,
}

/// The comments of one line inside a shader block.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LineComments {
    /// Whole-line comments above the line.
    pub leading: Vec<String>,
    /// A comment at the end of the line.
    pub trailing: Option<String>,
}

/// What a top-level item declares or states.
#[derive(Clone, Debug, PartialEq)]
pub enum ItemKind {
    Target(TargetDecl),
    Texture(TextureDecl),
    Framebuffer(FramebufferDecl),
    Vector(VectorDecl),
    Params(ParamsDecl),
    Const(ConstDecl),
    Uniform(UniformDecl),
    Let(LetDecl),
    Shader(ShaderDecl),
    Statement(Statement),
}

/// A name as the paper writes it: a base, primes (`T'''`, `u′`) and an
/// optional star mark for per-pass operators (`s*`, `T*`, Pipeline Grammar, eq. (9)).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Name {
    pub base: String,
    pub primes: u8,
    pub star: bool,
    pub span: Span,
}

impl Name {
    /// The name as written in ASCII (`T'''`, `s*`): the key names are resolved by.
    pub fn key(&self) -> String {
        let mut s = self.base.clone();
        s.extend(std::iter::repeat_n('\'', self.primes as usize));
        if self.star {
            s.push('*');
        }
        s
    }
}

/// A word with its span, already classified into `T` (a kind, format, mode…).
#[derive(Clone, Debug, PartialEq)]
pub struct Word<T> {
    pub value: T,
    pub span: Span,
}

/// `target geforce256;` — the profile whose limits the program must fit.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetDecl {
    pub profile: Word<String>,
}

/// `texture T, T' : 2d rgba8 mipmap = image("brick.png");`
#[derive(Clone, Debug, PartialEq)]
pub struct TextureDecl {
    pub names: Vec<Name>,
    pub kind: Word<TextureKind>,
    pub format: Option<Word<TextureFormat>>,
    pub attrs: Vec<Word<TextureAttr>>,
    /// An image file, a generator (`normalize_cube(32)`), or nothing when
    /// statements render into it (texture shading, Pipeline Grammar, eq. (13)).
    pub source: Option<Expr>,
}

/// `framebuffer Cl : depth;` — a table indexed by screen position.
#[derive(Clone, Debug, PartialEq)]
pub struct FramebufferDecl {
    pub names: Vec<Name>,
    /// Empty means the default: `rgba8, depth, stencil`.
    pub channels: Vec<Word<FramebufferChannel>>,
}

/// `vector L : light(0) in tangent;` or `vector H = normalize(L + V);` —
/// the shading vectors of Pipeline Grammar, Figure 3.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorDecl {
    pub names: Vec<Name>,
    pub role: Option<VectorRole>,
    pub value: Option<Expr>,
}

/// What a vertex-attribute vector is: its kind, light index and space.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorRole {
    pub kind: Word<VectorKind>,
    /// Which light, for `light(i)`, `half(i)`, `reflection(i)`.
    pub index: Option<Word<u32>>,
    pub space: Option<Word<Space>>,
}

/// `params s : N, L, H;` — which shading vectors the parameter vector s bundles.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamsDecl {
    pub name: Name,
    pub members: Vec<Name>,
}

/// `const kd : rgb = (0.8, 0.6, 0.4);` — folded at compile time.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstDecl {
    pub name: Name,
    pub ty: Option<Word<Type>>,
    pub value: Expr,
}

/// `uniform ks : rgb = (1, 1, 1);` — set per object by the scene (a material).
#[derive(Clone, Debug, PartialEq)]
pub struct UniformDecl {
    pub name: Name,
    pub ty: Option<Word<Type>>,
    pub default: Option<Expr>,
}

/// `let s_self = …;` — a named subexpression.
#[derive(Clone, Debug, PartialEq)]
pub struct LetDecl {
    pub name: Name,
    pub value: Expr,
}

/// `shader p(n: scalar = 32) : s → c = …;` — the map p: s → c of Pipeline Grammar, Section 2.
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderDecl {
    pub name: Name,
    pub params: Vec<ShaderParam>,
    /// The shading-parameter vector the shader takes (`s`).
    pub input: Name,
    pub output: Word<Type>,
    /// `{ let a = …; … }` bindings before the result; empty for `= expr`.
    pub lets: Vec<LetDecl>,
    pub body: Expr,
    /// Whether it was written as a `{ … }` block.
    pub block: bool,
}

/// A shader parameter: its name, type and default.
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderParam {
    pub name: Name,
    pub ty: Option<Word<Type>>,
    pub default: Option<Expr>,
}

/// `C δπx ← T δu x;` — an assignment into a table.
#[derive(Clone, Debug, PartialEq)]
pub struct Statement {
    pub target: Target,
    pub value: Expr,
}

/// The left side of `←`: `[channel] table index`, e.g. `α C xs`, `T δu`,
/// `u x` (texgen, Pipeline Grammar, eq. (7)), `Cl δ πl x`.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    pub channel: Option<Word<Channel>>,
    pub table: Name,
    pub index: Expr,
    pub span: Span,
}

/// An expression of the language, with its source span.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

/// The forms of an expression.
#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    Number(f64),
    String(String),
    Name(Name),
    /// `(a, b, c)`: a vector or colour literal, or the arguments of a call.
    Tuple(Vec<Expr>),
    /// `f arg`: right-to-left application, e.g. `T δu x`, `max(0, N·L)`.
    Apply {
        func: Func,
        arg: Box<Expr>,
    },
    /// `L.z`, `(T δu x).a`.
    Swizzle {
        base: Box<Expr>,
        components: String,
    },
    Unary {
        op: UnaryOp,
        operand: Box<Expr>,
    },
    Binary {
        op: BinaryOp,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
    },
    /// `a ⊕ b` or `a ⊕[add] b`; no mode means modulate (Pipeline Grammar, eq. (3)).
    Combine {
        mode: Option<Word<CombineMode>>,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
    },
    /// `c ? a : b`, or `c ? a` — write a only where c holds (shadow volumes).
    Select {
        cond: Box<Expr>,
        then: Box<Expr>,
        otherwise: Option<Box<Expr>>,
    },
}

/// What stands in function position of an application.
#[derive(Clone, Debug, PartialEq)]
pub struct Func {
    pub kind: FuncKind,
    pub span: Span,
}

/// What an application applies: δ, a projection, a channel or a name.
#[derive(Clone, Debug, PartialEq)]
pub enum FuncKind {
    /// δ: rasterization — interpolate across the primitive, then sample.
    Delta,
    /// π, πl, π*, π⁻¹.
    Projection(Projection),
    /// α, z, σ: a framebuffer's alpha, depth or stencil channel.
    Channel(Channel),
    Name(Name),
}

/// A projection π and its decorations.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Projection {
    /// `l` in πl (the light's projection), `R` in πR (spheremap texgen).
    pub subscript: Option<String>,
    /// π*: perturbed projection (accumulation buffer, Pipeline Grammar, eq. (11)).
    pub star: bool,
    /// π⁻¹: from screen back to model space.
    pub inverse: bool,
}

/// A framebuffer channel other than colour (α, z, σ).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    Alpha,
    Depth,
    Stencil,
}

/// A prefix operator: `-` or `not`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    Neg,
    Not,
}

/// An infix operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    Or,
    And,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
    Add,
    Sub,
    Mul,
    Div,
    /// `·`: dot product.
    Dot,
    Pow,
}

/// Declares a closed set of words: the enum, its canonical spelling, and
/// accepted aliases — one table drives parsing, printing and suggestions.
macro_rules! words {
    ($(#[$doc:meta])* $name:ident { $($variant:ident => $canon:literal $(| $alias:literal)*),+ $(,)? }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum $name { $($variant),+ }

        impl $name {
            /// Every canonical spelling, for "expected one of" and suggestions.
            pub const ALL: &'static [&'static str] = &[$($canon),+];

            /// The value a word (canonical or an alias) names.
            pub fn from_word(word: &str) -> Option<$name> {
                match word {
                    $($canon $(| $alias)* => Some($name::$variant),)+
                    _ => None,
                }
            }

            /// The canonical spelling.
            pub fn as_str(self) -> &'static str {
                match self { $($name::$variant => $canon),+ }
            }
        }
    };
}

words! {
    /// The ⊕ modes: OpenGL 1.2.1 texture environment and its combine extension.
    CombineMode {
        Modulate => "modulate",
        Add => "add",
        AddSigned => "add_signed" | "signed_add",
        Subtract => "subtract",
        Decal => "decal",
        Blend => "blend",
        Replace => "replace",
        Interpolate => "interpolate",
        Dot3Rgb => "dot3" | "dot3_rgb",
        Dot3Rgba => "dot3_rgba",
    }
}

words! {
    /// A texture's dimensionality: 1-D, 2-D and 3-D images, and cube maps
    /// (looked up by a direction, Pipeline Grammar's `T δ v`).
    TextureKind { Tex1d => "1d", Tex2d => "2d", Tex3d => "3d", Cube => "cube" }
}

words! {
    /// Texel formats: 8-bit unsigned, signed (HILO/DSDT-style), 16-bit, float.
    TextureFormat {
        Rgba8 => "rgba8",
        Rgb8 => "rgb8",
        R8 => "r8",
        Signed8 => "signed8" | "signed",
        Rgba16 => "rgba16",
        Signed16 => "signed16",
        Rgba16f => "rgba16f",
        Rgba32f => "rgba32f",
    }
}

impl TextureFormat {
    /// 16-bit and float formats: a texture rendered into stores more than
    /// 8 bits (and keeps signs), on the CPU as on wgpu.
    pub fn is_wide(self) -> bool {
        matches!(
            self,
            TextureFormat::Rgba16 | TextureFormat::Signed16 | TextureFormat::Rgba16f | TextureFormat::Rgba32f
        )
    }
}

words! {
    /// A texture's sampling attributes (`ir::Sampling::of` reads them).
    TextureAttr {
        Mipmap => "mipmap",
        Nearest => "nearest",
        Bilinear => "bilinear",
        Trilinear => "trilinear",
        Clamp => "clamp",
        Repeat => "repeat",
    }
}

words! {
    /// A framebuffer's channels: its colour format, depth and stencil.
    FramebufferChannel {
        Rgba8 => "rgba8",
        Rgb8 => "rgb8",
        Rgba16f => "rgba16f",
        Rgba32f => "rgba32f",
        Depth => "depth",
        Stencil => "stencil",
    }
}

words! {
    /// Shading vectors of Pipeline Grammar, Figure 3 (and B, the binormal of Kilgard 2000),
    /// and `intensity`: the light's colour at the point, times its distance
    /// attenuation and spot factor (the "color of each light source" that
    /// Pipeline Grammar, Section 3.2 lists among the shading parameters).
    VectorKind {
        Normal => "normal",
        Tangent => "tangent",
        Binormal => "binormal",
        Light => "light",
        View => "view",
        Half => "half",
        Reflection => "reflection",
        Position => "position",
        Intensity => "intensity",
    }
}

words! {
    /// The space a shading vector is expressed in (tangent space: Kilgard
    /// 2000, Appendix C).
    Space { Object => "object", World => "world", Eye => "eye", Tangent => "tangent" }
}

words! {
    /// Value types; `c` is the paper's colour (R, G, B).
    Type {
        Scalar => "scalar",
        Vec2 => "vec2",
        Vec3 => "vec3",
        Vec4 => "vec4",
        Rgb => "rgb",
        Rgba => "rgba",
        Color => "c",
    }
}

impl Expr {
    /// The name an expression starts with: `C` of `C`, `C δπx` or `C xs`.
    pub fn head_name(&self) -> Option<&Name> {
        match &self.kind {
            ExprKind::Name(n) => Some(n),
            ExprKind::Apply { func, .. } => match &func.kind {
                FuncKind::Name(n) => Some(n),
                _ => None,
            },
            _ => None,
        }
    }

    /// Visits every expression below and including this one (pre-order).
    pub fn walk(&self, f: &mut dyn FnMut(&Expr)) {
        f(self);
        match &self.kind {
            ExprKind::Number(_) | ExprKind::String(_) | ExprKind::Name(_) => {}
            ExprKind::Tuple(items) => items.iter().for_each(|e| e.walk(f)),
            ExprKind::Apply { arg, .. } => arg.walk(f),
            ExprKind::Swizzle { base, .. } => base.walk(f),
            ExprKind::Unary { operand, .. } => operand.walk(f),
            ExprKind::Binary { lhs, rhs, .. } | ExprKind::Combine { lhs, rhs, .. } => {
                lhs.walk(f);
                rhs.walk(f);
            }
            ExprKind::Select { cond, then, otherwise } => {
                cond.walk(f);
                then.walk(f);
                if let Some(e) = otherwise {
                    e.walk(f);
                }
            }
        }
    }
}

/// Span erasure, so two trees can be compared for structure alone (the
/// printer round trip: print, re-parse, compare).
impl Program {
    /// Every span of the program set to [`Span::DETACHED`].
    pub fn erase_spans(&mut self) {
        for item in &mut self.items {
            item.erase_spans();
        }
    }
}

impl Item {
    /// The item with every span [`Span::DETACHED`]: for trees compared by
    /// their content, or made by the compiler (`bake`), with no position.
    pub fn erase_spans(&mut self) {
        self.span = Span::DETACHED;
        let names = |names: &mut Vec<Name>| names.iter_mut().for_each(|n| n.span = Span::DETACHED);
        match &mut self.kind {
            ItemKind::Target(t) => detach_word(&mut t.profile),
            ItemKind::Texture(t) => {
                names(&mut t.names);
                detach_word(&mut t.kind);
                detach_opt_word(&mut t.format);
                t.attrs.iter_mut().for_each(detach_word);
                detach_opt_expr(&mut t.source);
            }
            ItemKind::Framebuffer(f) => {
                names(&mut f.names);
                f.channels.iter_mut().for_each(detach_word);
            }
            ItemKind::Vector(v) => {
                names(&mut v.names);
                if let Some(r) = &mut v.role {
                    detach_word(&mut r.kind);
                    detach_opt_word(&mut r.index);
                    detach_opt_word(&mut r.space);
                }
                detach_opt_expr(&mut v.value);
            }
            ItemKind::Params(p) => {
                p.name.span = Span::DETACHED;
                names(&mut p.members);
            }
            ItemKind::Const(c) => {
                c.name.span = Span::DETACHED;
                detach_opt_word(&mut c.ty);
                c.value.erase_spans();
            }
            ItemKind::Uniform(u) => {
                u.name.span = Span::DETACHED;
                detach_opt_word(&mut u.ty);
                detach_opt_expr(&mut u.default);
            }
            ItemKind::Let(l) => {
                l.name.span = Span::DETACHED;
                l.value.erase_spans();
            }
            ItemKind::Shader(s) => {
                s.name.span = Span::DETACHED;
                s.input.span = Span::DETACHED;
                detach_word(&mut s.output);
                for p in &mut s.params {
                    p.name.span = Span::DETACHED;
                    detach_opt_word(&mut p.ty);
                    detach_opt_expr(&mut p.default);
                }
                for l in &mut s.lets {
                    l.name.span = Span::DETACHED;
                    l.value.erase_spans();
                }
                s.body.erase_spans();
            }
            ItemKind::Statement(st) => {
                let t = &mut st.target;
                t.span = Span::DETACHED;
                t.table.span = Span::DETACHED;
                detach_opt_word(&mut t.channel);
                t.index.erase_spans();
                st.value.erase_spans();
            }
        }
    }
}

/// `w` without its span.
fn detach_word<T>(w: &mut Word<T>) {
    w.span = Span::DETACHED;
}

/// `w`, if present, without its span.
fn detach_opt_word<T>(w: &mut Option<Word<T>>) {
    if let Some(w) = w {
        w.span = Span::DETACHED;
    }
}

/// `e`, if present, without its spans.
fn detach_opt_expr(e: &mut Option<Expr>) {
    if let Some(e) = e {
        e.erase_spans();
    }
}

impl Expr {
    /// Every span of the expression set to [`Span::DETACHED`].
    pub fn erase_spans(&mut self) {
        self.span = Span::DETACHED;
        match &mut self.kind {
            ExprKind::Number(_) | ExprKind::String(_) => {}
            ExprKind::Name(n) => n.span = Span::DETACHED,
            ExprKind::Tuple(items) => items.iter_mut().for_each(Expr::erase_spans),
            ExprKind::Apply { func, arg } => {
                func.span = Span::DETACHED;
                if let FuncKind::Name(n) = &mut func.kind {
                    n.span = Span::DETACHED;
                }
                arg.erase_spans();
            }
            ExprKind::Swizzle { base, .. } => base.erase_spans(),
            ExprKind::Unary { operand, .. } => operand.erase_spans(),
            ExprKind::Binary { lhs, rhs, .. } => {
                lhs.erase_spans();
                rhs.erase_spans();
            }
            ExprKind::Combine { mode, lhs, rhs } => {
                if let Some(m) = mode {
                    m.span = Span::DETACHED;
                }
                lhs.erase_spans();
                rhs.erase_spans();
            }
            ExprKind::Select { cond, then, otherwise } => {
                cond.erase_spans();
                then.erase_spans();
                if let Some(o) = otherwise {
                    o.erase_spans();
                }
            }
        }
    }
}
