//! Name resolution: every name a program uses is declared, built in, or a
//! member of the paper's families (Figure 2 of Pipeline Grammar: `x` vertices, `xs`
//! pixels, `u` texture coordinates, `s` shading parameters, `C` framebuffers,
//! each with primes and stars); no name is declared twice; the left of `←` is
//! a table. Unknown names get a "did you mean" from what is in scope.

use std::collections::HashMap;

use super::ast::*;
use crate::diag::{did_you_mean, Diagnostic, Suggester};
use crate::span::Span;

/// Built-in functions, usable in any expression.
pub const FUNCTIONS: &[&str] = &[
    "normalize",
    "length",
    "dot",
    "cross",
    "reflect",
    "max",
    "min",
    "clamp",
    "saturate",
    "abs",
    "sign",
    "sqrt",
    "rsqrt",
    "pow",
    "exp",
    "log",
    "sin",
    "cos",
    "floor",
    "fract",
    "step",
    "smoothstep",
    "lerp",
    "mix",
    // Range mappings of the register combiners (seeds/003 Table 3): 2x−1 and x−½, and back.
    "expand",
    "half_bias",
    "compress",
    "rgb",
    "rgba",
    "vec2",
    "vec3",
    "vec4",
];

/// An undeclared `d` or `p` is most likely text pasted from Pipeline Grammar as
/// printed, whose Symbol font shows δ as `d` and π as `p`: the
/// help names the symbol, not the nearest one-letter name.
fn symbol_font_help(key: &str) -> Option<String> {
    let (symbol, ascii) = match key {
        "d" => ("δ", "delta"),
        "p" => ("π", "pi"),
        _ => return None,
    };
    Some(format!(
        "did you mean `{symbol}` (ASCII `{ascii}`)? Text pasted from a PDF set in the Symbol font shows {symbol} as `{key}`"
    ))
}

/// The keywords of the language (`grammar/shade.pest`, rule `keyword`): never names.
pub const KEYWORDS: &[&str] = &[
    "target",
    "texture",
    "framebuffer",
    "vector",
    "params",
    "const",
    "uniform",
    "shader",
    "let",
    "in",
    "delta",
    "pi",
    "alpha",
    "depth",
    "stencil",
    "OR",
    "AND",
];

/// The declaration an unknown name needs, by how it is used: applied to
/// texture coordinates (`T δu x`) a texture, applied to the shading
/// parameters (`p δ s x`) a shader or a shading vector, else a value.
fn declaration_help(key: &str, applied_to: Option<&Expr>) -> String {
    if applied_to.is_some_and(projects) {
        return format!(
            "declare it first as a framebuffer: `framebuffer {key} : rgba8, depth;` (a light's depth map: `framebuffer {key} : depth;`), or use a built-in one, `C` or `C′`"
        );
    }
    let mut families = Vec::new();
    if let Some(arg) = applied_to {
        arg.walk(&mut |e| {
            if let Some(f) = e.head_name().and_then(family) {
                families.push(f);
            }
        });
    }
    if families.contains(&Entity::TexCoords) {
        format!("declare it first as a texture: `texture {key} : 2d rgba8 = image(\"file.png\");`")
    } else if families.contains(&Entity::Params) {
        format!(
            "declare it first: a shader, `shader {key} : s → c = …;`, or a shading vector, `vector {key} : normal;`"
        )
    } else {
        format!("declare it first, e.g. `vector {key} : normal;`, `const {key} = 1;` or `texture {key} : 2d rgba8 = image(\"file.png\");`")
    }
}

/// Whether `e` is read at a projected position (`δπx`, `δπl x`,
/// `πl π⁻¹ xs`): what a framebuffer is applied to.
fn projects(e: &Expr) -> bool {
    let mut found = false;
    e.walk(&mut |e| {
        found |=
            matches!(&e.kind, ExprKind::Apply { func, .. } if matches!(func.kind, FuncKind::Projection(_)))
    });
    found
}

/// `deltapi`, `ux`, `sx`: the ASCII words of δ and π and the paper's
/// families (`u`, `s`, `x`, `xs`) glued into one name; the parts with
/// spaces, when the whole name splits into two or more of them.
fn run_together(key: &str) -> Option<String> {
    const PARTS: &[&str] = &["delta", "pi", "alpha", "stencil", "depth", "xs", "x", "u", "s"];
    // The parts are prefix-free but for `x`/`xs`: a search with
    // backtracking over them.
    fn split<'k>(rest: &'k str, out: &mut Vec<&'k str>) -> bool {
        if rest.is_empty() {
            return true;
        }
        for p in PARTS {
            if let Some(tail) = rest.strip_prefix(p) {
                out.push(&rest[..p.len()]);
                if split(tail, out) {
                    return true;
                }
                out.pop();
            }
        }
        false
    }
    // `xsxs…` splits two ways at every `xs`: the search is exponential in
    // the worst case, and no run of glued parts is long.
    if key.len() > 24 {
        return None;
    }
    let mut parts = Vec::new();
    (split(key, &mut parts) && parts.len() >= 2).then(|| parts.join(" "))
}

/// Texture sources (generators), usable only after `texture … =`.
pub const GENERATORS: &[&str] = &[
    "image",
    "normalize_cube",
    "normal_map",
    "height",
    "bumps",
    "dual_paraboloid",
    "brdf_fd",
    "brdf_g",
    "exponent_table",
    "bake",
];

/// Target profiles the compiler knows.
pub const PROFILES: &[&str] = &["geforce256", "geforce3", "multitexture", "wgsl"];

/// What a declared or built-in name stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entity {
    Texture,
    Framebuffer,
    Vector,
    Params,
    Const,
    Uniform,
    Let,
    Shader,
    /// `x`, `x'`: model-space vertices.
    Vertex,
    /// `xs`: a pixel in viewport coordinates.
    Pixel,
    /// `u`, `u'''`, `u*`: texture-coordinate sets, a vertex attribute.
    TexCoords,
    ShaderParam,
    Function,
}

impl Entity {
    /// The kind of entity, as diagnostics name it.
    pub fn describe(self) -> &'static str {
        match self {
            Entity::Texture => "texture",
            Entity::Framebuffer => "framebuffer",
            Entity::Vector => "shading vector",
            Entity::Params => "shading-parameter vector",
            Entity::Const => "constant",
            Entity::Uniform => "uniform",
            Entity::Let => "`let` binding",
            Entity::Shader => "shader",
            Entity::Vertex => "vertex",
            Entity::Pixel => "pixel position",
            Entity::TexCoords => "texture-coordinate set",
            Entity::ShaderParam => "shader parameter",
            Entity::Function => "built-in function",
        }
    }
}

/// The entity a name belongs to by the paper's conventions, if undeclared.
pub fn family(name: &Name) -> Option<Entity> {
    match name.base.as_str() {
        "x" => Some(Entity::Vertex),
        "xs" => Some(Entity::Pixel),
        "u" => Some(Entity::TexCoords),
        "s" => Some(Entity::Params),
        "C" => Some(Entity::Framebuffer),
        _ => None,
    }
}

struct Declared {
    entity: Entity,
    span: Span,
    used: bool,
}

#[derive(Default)]
struct Resolver {
    globals: HashMap<String, Declared>,
    order: Vec<String>,
    diagnostics: Vec<Diagnostic>,
    /// The "did you mean" index over the globals, built-in functions and
    /// generators, made at the first unknown name (every declaration is
    /// known by then: they are all read before any use).
    suggester: Option<Suggester>,
}

/// Resolves every name of `program`: declarations first, then uses, then warnings for what is never used.
pub fn resolve(program: &Program) -> Vec<Diagnostic> {
    let mut r = Resolver::default();
    let mut target: Option<Span> = None;
    for item in &program.items {
        match &item.kind {
            ItemKind::Target(t) => r.choose_target(t, &mut target),
            ItemKind::Texture(t) => t.names.iter().for_each(|n| r.declare(n, Entity::Texture)),
            ItemKind::Framebuffer(f) => f.names.iter().for_each(|n| r.declare(n, Entity::Framebuffer)),
            ItemKind::Vector(v) => v.names.iter().for_each(|n| r.declare(n, Entity::Vector)),
            ItemKind::Params(p) => r.declare(&p.name, Entity::Params),
            ItemKind::Const(c) => r.declare(&c.name, Entity::Const),
            ItemKind::Uniform(u) => r.declare(&u.name, Entity::Uniform),
            ItemKind::Let(l) => r.declare(&l.name, Entity::Let),
            ItemKind::Shader(s) => r.declare(&s.name, Entity::Shader),
            ItemKind::Statement(_) => {}
        }
    }
    r.declare_poisoned(&program.poisoned);
    for item in &program.items {
        r.use_item(item);
    }
    r.warn_unused();
    r.diagnostics
}

impl Resolver {
    /// A `target` line: at most one, naming a known profile; `target` is
    /// where the first one chose.
    fn choose_target(&mut self, t: &TargetDecl, target: &mut Option<Span>) {
        if let Some(first) = *target {
            self.diagnostics.push(
                Diagnostic::error(
                    "duplicate-target",
                    "the target profile is chosen twice",
                    t.profile.span,
                    "second choice",
                )
                .with_label(first, "first chosen here")
                .with_help("keep one `target` line, or choose on the command line with `--target`"),
            );
        }
        *target = Some(t.profile.span);
        if !PROFILES.contains(&t.profile.value.as_str()) {
            let help = match did_you_mean(&t.profile.value, PROFILES.iter().copied()) {
                Some(s) => format!("did you mean `{s}`? (profiles: {})", PROFILES.join(", ")),
                None => format!("the profiles are: {}", PROFILES.join(", ")),
            };
            self.diagnostics.push(
                Diagnostic::error(
                    "unknown-profile",
                    format!("unknown target profile `{}`", t.profile.value),
                    t.profile.span,
                    "no such profile",
                )
                .with_help(help),
            );
        }
    }

    /// Resolves the names an item uses (every declaration is known by now).
    fn use_item(&mut self, item: &Item) {
        match &item.kind {
            ItemKind::Target(_) | ItemKind::Framebuffer(_) => {}
            ItemKind::Texture(t) => {
                if let Some(src) = &t.source {
                    self.expr(src, &[], true);
                }
            }
            ItemKind::Vector(v) => {
                if let Some(value) = &v.value {
                    self.expr(value, &[], false);
                }
            }
            ItemKind::Params(p) => p.members.iter().for_each(|m| self.use_name(m, &[], false)),
            ItemKind::Const(c) => self.expr(&c.value, &[], false),
            ItemKind::Uniform(u) => {
                if let Some(d) = &u.default {
                    self.expr(d, &[], false);
                }
            }
            ItemKind::Let(l) => self.expr(&l.value, &[], false),
            ItemKind::Shader(s) => self.shader(s),
            ItemKind::Statement(st) => {
                self.target(&st.target);
                self.expr(&st.value, &[], false);
            }
        }
    }

    /// Warns at each declaration nothing uses (framebuffers excepted).
    fn warn_unused(&mut self) {
        for key in &self.order {
            let d = &self.globals[key];
            if !d.used && d.entity != Entity::Framebuffer {
                self.diagnostics.push(
                    Diagnostic::warning(
                        "unused",
                        format!("{} `{key}` is never used", d.entity.describe()),
                        d.span,
                        "declared here",
                    )
                    .with_help("remove the declaration, or use it in a statement"),
                );
            }
        }
    }
}

impl Resolver {
    /// The names of declarations that failed (reported already): declared
    /// without a word, so that their uses raise nothing more. A name that
    /// is declared again, or that a family reserves, is left as it is.
    fn declare_poisoned(&mut self, poisoned: &[Poisoned]) {
        for p in poisoned {
            let entity = match p.keyword.as_str() {
                "texture" => Entity::Texture,
                "framebuffer" => Entity::Framebuffer,
                "vector" => Entity::Vector,
                "params" => Entity::Params,
                "const" => Entity::Const,
                "uniform" => Entity::Uniform,
                "shader" => Entity::Shader,
                _ => Entity::Let,
            };
            let key = p.name.key();
            if self.globals.contains_key(&key) || family(&p.name).is_some() {
                continue;
            }
            self.globals.insert(key.clone(), Declared { entity, span: p.name.span, used: true });
            self.order.push(key);
        }
    }

    fn declare(&mut self, name: &Name, entity: Entity) {
        let key = name.key();
        if let Some(prev) = self.globals.get(&key) {
            self.diagnostics.push(
                Diagnostic::error(
                    "duplicate-name",
                    format!("`{key}` is declared twice"),
                    name.span,
                    "declared again here",
                )
                .with_label(prev.span, format!("first declared here as a {}", prev.entity.describe()))
                .with_help("rename one of them (primes make new names: `T'`, `T''`)"),
            );
            return;
        }
        if let Some(fam) = family(name) {
            if fam != entity {
                self.diagnostics.push(
                    Diagnostic::error(
                        "reserved-name",
                        format!("`{key}` names a {} in the pipeline grammar", fam.describe()),
                        name.span,
                        format!("cannot be a {}", entity.describe()),
                    )
                    .with_help("x, xs, u, s and C (with primes and stars) keep their meaning from Pipeline Grammar, Figure 2; pick another name"),
                );
                return;
            }
        }
        self.globals.insert(key.clone(), Declared { entity, span: name.span, used: false });
        self.order.push(key);
    }

    fn shader(&mut self, s: &ShaderDecl) {
        let mut locals: Vec<(String, Entity)> = vec![(s.input.key(), Entity::Params)];
        for p in &s.params {
            if let Some(d) = &p.default {
                self.expr(d, &locals, false);
            }
            locals.push((p.name.key(), Entity::ShaderParam));
        }
        for l in &s.lets {
            self.expr(&l.value, &locals, false);
            locals.push((l.name.key(), Entity::Let));
        }
        self.expr(&s.body, &locals, false);
    }

    fn target(&mut self, t: &Target) {
        let key = t.table.key();
        let entity = self.lookup(&t.table, &[]);
        match entity {
            Some(Entity::Framebuffer | Entity::Texture | Entity::TexCoords | Entity::Params) => {}
            Some(other) => self.diagnostics.push(
                Diagnostic::error(
                    "bad-target",
                    format!("cannot assign into the {} `{key}`", other.describe()),
                    t.table.span,
                    "not a table",
                )
                .with_help(
                    "assign into a framebuffer (`C δπx`), a texture (`T δu`) or a vertex attribute (`u x`)",
                ),
            ),
            None => self.unknown(&t.table, &[], false, Some(&t.index)),
        }
        if let Some(c) = &t.channel {
            if entity.is_some_and(|e| e != Entity::Framebuffer) {
                self.diagnostics.push(
                    Diagnostic::error(
                        "bad-channel",
                        "channel selectors apply to framebuffers",
                        c.span,
                        "selects a framebuffer channel",
                    )
                    .with_help(format!("`{key}` is not a framebuffer; declare it with `framebuffer {key};`")),
                );
            }
        }
        self.expr(&t.index, &[], false);
    }

    fn lookup(&mut self, name: &Name, locals: &[(String, Entity)]) -> Option<Entity> {
        let key = name.key();
        if let Some((_, e)) = locals.iter().rev().find(|(k, _)| *k == key) {
            return Some(*e);
        }
        if let Some(d) = self.globals.get_mut(&key) {
            d.used = true;
            return Some(d.entity);
        }
        family(name)
    }

    fn use_name(&mut self, name: &Name, locals: &[(String, Entity)], in_source: bool) {
        if self.lookup(name, locals).is_none() {
            self.unknown(name, locals, in_source, None);
        }
    }

    /// `applied_to`: what the name is applied to, when it stands in
    /// function position — its declaration's example follows the use.
    fn unknown(
        &mut self,
        name: &Name,
        locals: &[(String, Entity)],
        in_source: bool,
        applied_to: Option<&Expr>,
    ) {
        let key = name.key();
        let globals = &self.globals;
        let suggester = self.suggester.get_or_insert_with(|| {
            Suggester::new(
                globals
                    .keys()
                    .map(String::as_str)
                    .chain(FUNCTIONS.iter().copied())
                    .chain(GENERATORS.iter().copied()),
            )
        });
        // At a projected position only a framebuffer (or a fat one read as
        // a texture) is meant: `Cl δπl x` is not a misspelt vector `L`.
        let framebuffer_use = applied_to.is_some_and(projects);
        let table = |c: &str| {
            globals.get(c).is_some_and(|d| matches!(d.entity, Entity::Framebuffer | Entity::Texture))
        };
        let accept = |c: &str| {
            (in_source || globals.contains_key(c) || !GENERATORS.contains(&c))
                && (!framebuffer_use || table(c))
        };
        let local_names: Vec<&str> = locals.iter().map(|(k, _)| k.as_str()).collect();
        // The name meant is used, by the mistyped use: no "never used" too.
        let mut meant = None;
        let help = match suggester.suggest(&key, accept, &local_names) {
            _ if let Some(help) = symbol_font_help(&key) => help,
            _ if let Some(parts) = run_together(&key) => format!(
                "`{key}` reads as one name; write its parts with spaces, `{parts}` (only the Greek δ and π may be glued to what follows, as in `δu x` and `δπx`)"
            ),
            Some(s) => {
                meant = Some(s.to_string());
                format!("did you mean `{s}`?")
            }
            None if GENERATORS.contains(&key.as_str()) => format!("`{key}` is a texture generator: use it after `texture … =`"),
            // A shading vector's role used as a value (`intensity(0) * …`).
            None if super::ast::VectorKind::from_word(&key).is_some() => {
                let light = matches!(key.as_str(), "light" | "half" | "intensity");
                format!(
                    "`{key}` is a shading vector's role: declare a vector with it, e.g. `vector V : {key}{} in eye;`, and use `V`",
                    if light { "(0)" } else { "" }
                )
            }
            None => declaration_help(&key, applied_to),
        };
        if let Some(d) = meant.and_then(|m| self.globals.get_mut(&m)) {
            d.used = true;
        }
        self.diagnostics.push(
            Diagnostic::error("unknown-name", format!("unknown name `{key}`"), name.span, "not declared")
                .with_help(help),
        );
    }

    /// Resolves every name in `e`. Names in function position may also be
    /// built-in functions (and generators inside a texture source).
    fn expr(&mut self, e: &Expr, locals: &[(String, Entity)], in_source: bool) {
        let mut stack = vec![e];
        while let Some(e) = stack.pop() {
            match &e.kind {
                ExprKind::Number(_) | ExprKind::String(_) => {}
                ExprKind::Name(n) => self.use_name(n, locals, in_source),
                ExprKind::Tuple(items) => stack.extend(items),
                ExprKind::Apply { func, arg } => {
                    if let FuncKind::Name(n) = &func.kind {
                        if !self.printed_channel(n, arg, locals) {
                            self.func_name(n, arg, locals, in_source);
                        }
                    }
                    stack.push(arg);
                }
                ExprKind::Swizzle { base, .. } => stack.push(base),
                ExprKind::Unary { operand, .. } => stack.push(operand),
                ExprKind::Binary { lhs, rhs, .. } | ExprKind::Combine { lhs, rhs, .. } => {
                    stack.push(rhs);
                    stack.push(lhs);
                }
                ExprKind::Select { cond, then, otherwise } => {
                    stack.extend(otherwise.as_deref());
                    stack.push(then);
                    stack.push(cond);
                }
            }
        }
    }

    /// Pipeline Grammar as printed writes the alpha and stencil channels as `a C xs`
    /// and `s C δπx` (the Symbol font's α and σ): an undeclared `a` or `s`
    /// applied to a framebuffer gets that suggestion, not "did
    /// you mean `N`?". Whether it reported one.
    fn printed_channel(&mut self, n: &Name, arg: &Expr, locals: &[(String, Entity)]) -> bool {
        let key = n.key();
        let symbol = match key.as_str() {
            "a" => ("α", "alpha"),
            "s" => ("σ", "stencil"),
            _ => return false,
        };
        if self.lookup(n, locals).is_some()
            || !arg.head_name().is_some_and(|h| matches!(self.lookup(h, locals), Some(Entity::Framebuffer)))
        {
            return false;
        }
        let (sym, word) = symbol;
        self.diagnostics.push(
            Diagnostic::error("unknown-name", format!("unknown name `{key}`"), n.span, "not declared").with_help(format!(
                "did you mean `{sym}` (ASCII `{word}`), the framebuffer's {word} channel? Pipeline Grammar as printed (the Symbol font) shows `{sym}` as `{key}`"
            )),
        );
        true
    }

    fn func_name(&mut self, n: &Name, arg: &Expr, locals: &[(String, Entity)], in_source: bool) {
        let key = n.key();
        let builtin = FUNCTIONS.contains(&key.as_str()) || (in_source && GENERATORS.contains(&key.as_str()));
        if builtin && !self.globals.contains_key(&key) && !locals.iter().any(|(k, _)| *k == key) {
            return;
        }
        match self.lookup(n, locals) {
            Some(e @ (Entity::Const | Entity::Uniform | Entity::ShaderParam | Entity::Pixel)) => {
                self.diagnostics.push(
                    Diagnostic::error(
                        "not-a-function",
                        format!("the {} `{key}` cannot be applied to a value", e.describe()),
                        n.span,
                        "applied here",
                    )
                    .with_help(format!("to multiply, write `{key} * …`")),
                )
            }
            Some(_) => {}
            None => self.unknown(n, locals, in_source, Some(arg)),
        }
    }
}
