//! Texture declarations as written, read once from the syntax tree: each
//! declaration's names, kind, format and sampling, and its source — a
//! generator call with its arguments typed (numbers with the program's
//! value of a named `const` or `uniform`, file names, nested calls), or a
//! texture that statements render into (texture shading, Pipeline
//! Grammar, eq. (13)).
//!
//! The lowering stores them in [`super::Module::declared`]; the scene
//! binder (`scene::bind::texture_decls`) turns them into textures to load
//! or generate, with the scene's constants in place of a uniform's
//! default, and never reads the syntax tree again. The front end's checks
//! of image files read the same form ([`read`]).

use std::collections::BTreeMap;

use crate::parser::ast::{self, ExprKind, FuncKind, ItemKind};
use crate::span::Span;

pub use crate::parser::ast::{Space, TextureAttr, TextureFormat, TextureKind, VectorKind};

/// One `texture` declaration (`texture A, B : 2d rgba8 = image("f.png");`).
#[derive(Clone, Debug, PartialEq)]
pub struct DeclaredTexture {
    /// The names it declares, each with its span; every one binds the same source.
    pub names: Vec<(String, Span)>,
    /// 1-D, 2-D, 3-D or cube.
    pub kind: TextureKind,
    /// Where the kind is written (the label of a cube map's errors).
    pub kind_span: Span,
    /// The declared format; `None` when the declaration names none.
    pub format: Option<TextureFormat>,
    /// Its attributes read by the IR's one rule ([`super::Sampling::of`]).
    pub sampling: super::Sampling,
    /// `None` for a texture that statements render into.
    pub source: Option<DeclaredSource>,
}

/// What a declaration's `= …` says.
#[derive(Clone, Debug, PartialEq)]
pub enum DeclaredSource {
    /// `f(args…)`: a generator (or `image`, `bake`) called by name.
    Generator {
        /// The generator's name (`normalize_cube`).
        name: String,
        /// Its arguments: the items of a tuple, else the one argument.
        args: Vec<GeneratorArg>,
        /// The whole argument, parentheses aside (an arity error's place).
        args_span: Span,
        /// The whole source expression.
        span: Span,
    },
    /// Anything else, as the binder names it when it refuses it (no generator).
    Other {
        /// The source as the binder names it.
        text: String,
        /// Where it is written.
        span: Span,
    },
}

impl DeclaredSource {
    /// Where the source is written.
    pub fn span(&self) -> Span {
        match self {
            DeclaredSource::Generator { span, .. } | DeclaredSource::Other { span, .. } => *span,
        }
    }
}

/// An argument of a generator call.
#[derive(Clone, Debug, PartialEq)]
pub struct GeneratorArg {
    /// What the argument is.
    pub kind: ArgKind,
    /// Where it is written (a cube map's argument errors are shown there).
    pub span: Span,
}

/// The kinds of generator argument the binder reads; the rest is `Other`.
#[derive(Clone, Debug, PartialEq)]
pub enum ArgKind {
    /// A number written as such.
    Number(f64),
    /// A named `const` or `uniform`, with the program's value of it when
    /// it is a number (a literal, an earlier such name, a negation of
    /// one): a scene constant of the name takes its place when bound.
    Name {
        /// The name as written.
        name: String,
        /// The program's number for it, if it has one.
        value: Option<f32>,
    },
    /// `-a`.
    Neg(Box<GeneratorArg>),
    /// A file name in quotes.
    Text(String),
    /// A nested call (`height("f.png")` in `normal_map(…)`): its name and
    /// its argument as written.
    Call {
        /// The function's name (`None` for an applied expression).
        name: Option<String>,
        /// Its argument as written (an [`ArgKind::Tuple`] for several).
        arg: Box<GeneratorArg>,
    },
    /// `(a, b, …)`: a nested call's several arguments.
    Tuple(Vec<GeneratorArg>),
    /// Anything else (an expression the binder reads no value from).
    Other,
}

impl GeneratorArg {
    /// Its number, `names` (the scene's constants) before the program's
    /// value of a name.
    pub fn number(&self, names: &BTreeMap<String, f32>) -> Option<f32> {
        match &self.kind {
            ArgKind::Number(v) => Some(*v as f32),
            ArgKind::Name { name, value } => names.get(name).copied().or(*value),
            ArgKind::Neg(a) => a.number(names).map(|v| -v),
            _ => None,
        }
    }

    /// The arguments it stands for: a tuple's items, else itself.
    pub fn items(&self) -> Vec<&GeneratorArg> {
        match &self.kind {
            ArgKind::Tuple(items) => items.iter().collect(),
            _ => vec![self],
        }
    }

    /// Its file name, when it is one in quotes.
    pub fn text(&self) -> Option<&str> {
        match &self.kind {
            ArgKind::Text(s) => Some(s),
            _ => None,
        }
    }
}

/// Every texture declaration of `program`, in source order.
pub fn read(program: &ast::Program) -> Vec<DeclaredTexture> {
    let values = program_numbers(program);
    program
        .items
        .iter()
        .filter_map(|item| match &item.kind {
            ItemKind::Texture(t) => Some(declaration(t, &values)),
            _ => None,
        })
        .collect()
}

fn declaration(t: &ast::TextureDecl, values: &BTreeMap<String, f32>) -> DeclaredTexture {
    let attrs: Vec<TextureAttr> = t.attrs.iter().map(|w| w.value).collect();
    DeclaredTexture {
        names: t.names.iter().map(|n| (n.key(), n.span)).collect(),
        kind: t.kind.value,
        kind_span: t.kind.span,
        format: t.format.as_ref().map(|f| f.value),
        sampling: super::Sampling::of(t.kind.value, &attrs),
        source: t.source.as_ref().map(|e| source(e, values)),
    }
}

/// The program's numbers by name, in declaration order: a `const` whose
/// value is a number, an earlier such name or a negation of one, and a
/// `uniform`'s default of that kind.
fn program_numbers(program: &ast::Program) -> BTreeMap<String, f32> {
    let mut numbers: BTreeMap<String, f32> = BTreeMap::new();
    for item in &program.items {
        let (name, value) = match &item.kind {
            ItemKind::Const(c) => (&c.name, Some(&c.value)),
            ItemKind::Uniform(u) => (&u.name, u.default.as_ref()),
            _ => continue,
        };
        if let Some(v) = value.map(|e| arg(e, &numbers)).and_then(|a| a.number(&BTreeMap::new())) {
            numbers.insert(name.key(), v);
        }
    }
    numbers
}

fn source(e: &ast::Expr, values: &BTreeMap<String, f32>) -> DeclaredSource {
    let ExprKind::Apply { func, arg: a } = &e.kind else {
        return DeclaredSource::Other { text: format!("{:?}", e.kind), span: e.span };
    };
    let FuncKind::Name(f) = &func.kind else {
        return DeclaredSource::Other { text: "?".into(), span: e.span };
    };
    let items: Vec<&ast::Expr> = match &a.kind {
        ExprKind::Tuple(items) => items.iter().collect(),
        _ => vec![a],
    };
    DeclaredSource::Generator {
        name: f.key(),
        args: items.into_iter().map(|x| arg(x, values)).collect(),
        args_span: a.span,
        span: e.span,
    }
}

fn arg(e: &ast::Expr, values: &BTreeMap<String, f32>) -> GeneratorArg {
    let kind = match &e.kind {
        ExprKind::Number(v) => ArgKind::Number(*v),
        ExprKind::Name(n) => ArgKind::Name { name: n.key(), value: values.get(&n.key()).copied() },
        ExprKind::Unary { op: ast::UnaryOp::Neg, operand } => ArgKind::Neg(Box::new(arg(operand, values))),
        ExprKind::String(s) => ArgKind::Text(s.clone()),
        ExprKind::Apply { func, arg: a } => ArgKind::Call {
            name: match &func.kind {
                FuncKind::Name(f) => Some(f.key()),
                _ => None,
            },
            arg: Box::new(arg(a, values)),
        },
        ExprKind::Tuple(items) => ArgKind::Tuple(items.iter().map(|x| arg(x, values)).collect()),
        _ => ArgKind::Other,
    };
    GeneratorArg { kind, span: e.span }
}
