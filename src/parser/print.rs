//! The canonical printer: AST → text, in Unicode (`C δπx ← T δu x;`) or
//! ASCII (`C delta pi x <- T delta u x;`). Parentheses are inserted by
//! precedence, so printing and re-parsing gives the same AST.

use std::fmt::Write as _;

use super::ast::*;

/// How the printer writes the notation's symbols: `δ ← →` or their ASCII forms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    Unicode,
    Ascii,
}

/// Prints a whole program with the comments kept between items.
pub fn program(p: &Program, style: Style) -> String {
    let mut out = String::new();
    for (i, item) in p.items.iter().enumerate() {
        let c = &item.comments;
        if c.blank_line_before && i > 0 {
            out.push('\n');
        }
        for line in &c.leading {
            out.push_str(line);
            out.push('\n');
        }
        out.push_str(&self::item(item, style));
        if let Some(t) = &c.trailing {
            out.push_str("  ");
            out.push_str(t);
        }
        out.push('\n');
    }
    if !p.trailing_comments.is_empty() {
        out.push('\n');
        for line in &p.trailing_comments {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

/// Prints one top-level item canonically, in `style`.
pub fn item(item: &Item, style: Style) -> String {
    let pr = Printer { style };
    let mut s = String::new();
    match &item.kind {
        ItemKind::Target(t) => {
            let _ = write!(s, "target {};", t.profile.value);
        }
        ItemKind::Texture(t) => {
            let _ = write!(s, "texture {} : {}", pr.names(&t.names), t.kind.value.as_str());
            if let Some(f) = &t.format {
                let _ = write!(s, " {}", f.value.as_str());
            }
            for a in &t.attrs {
                let _ = write!(s, " {}", a.value.as_str());
            }
            if let Some(src) = &t.source {
                let _ = write!(s, " = {}", pr.expr(src));
            }
            s.push(';');
        }
        ItemKind::Framebuffer(f) => {
            let _ = write!(s, "framebuffer {}", pr.names(&f.names));
            if !f.channels.is_empty() {
                let channels: Vec<&str> = f.channels.iter().map(|c| c.value.as_str()).collect();
                let _ = write!(s, " : {}", channels.join(", "));
            }
            s.push(';');
        }
        ItemKind::Vector(v) => {
            let _ = write!(s, "vector {}", pr.names(&v.names));
            if let Some(role) = &v.role {
                let _ = write!(s, " : {}", role.kind.value.as_str());
                if let Some(i) = &role.index {
                    let _ = write!(s, "({})", i.value);
                }
                if let Some(space) = &role.space {
                    let _ = write!(s, " in {}", space.value.as_str());
                }
            }
            if let Some(value) = &v.value {
                let _ = write!(s, " = {}", pr.expr(value));
            }
            s.push(';');
        }
        ItemKind::Params(p) => {
            let _ = write!(s, "params {} : {};", pr.name(&p.name), pr.names(&p.members));
        }
        ItemKind::Const(c) => {
            let _ = write!(s, "const {}{} = {};", pr.name(&c.name), pr.ty(&c.ty), pr.expr(&c.value));
        }
        ItemKind::Uniform(u) => {
            let _ = write!(s, "uniform {}{}", pr.name(&u.name), pr.ty(&u.ty));
            if let Some(d) = &u.default {
                let _ = write!(s, " = {}", pr.expr(d));
            }
            s.push(';');
        }
        ItemKind::Let(l) => {
            let _ = write!(s, "let {} = {};", pr.name(&l.name), pr.expr(&l.value));
        }
        ItemKind::Shader(sh) => shader(&mut s, &pr, item, sh),
        ItemKind::Statement(st) => {
            let assign = if style == Style::Unicode { "←" } else { "<-" };
            let _ = write!(s, "{} {assign} {};", pr.target(&st.target), pr.expr(&st.value));
        }
    }
    s
}

/// A `shader` declaration: its parameters, its type, and its body, a block
/// of `let`s with the item's comments in place, or one expression.
fn shader(s: &mut String, pr: &Printer, item: &Item, sh: &ShaderDecl) {
    let style = pr.style;
    let _ = write!(s, "shader {}", pr.name(&sh.name));
    if !sh.params.is_empty() {
        let params: Vec<String> = sh
            .params
            .iter()
            .map(|p| {
                let mut t = pr.name(&p.name);
                if let Some(ty) = &p.ty {
                    let _ = write!(t, ": {}", ty.value.as_str());
                }
                if let Some(d) = &p.default {
                    let _ = write!(t, " = {}", pr.expr(d));
                }
                t
            })
            .collect();
        let _ = write!(s, "({})", params.join(", "));
    }
    let arrow = if style == Style::Unicode { "→" } else { "->" };
    let _ = write!(s, " : {} {arrow} {}", pr.name(&sh.input), sh.output.value.as_str());
    if sh.block {
        s.push_str(" {\n");
        let lines = sh.lets.iter().map(|l| format!("let {} = {};", pr.name(&l.name), pr.expr(&l.value)));
        let no_comments = LineComments::default();
        let comments = |k: usize| item.comments.block.get(k).unwrap_or(&no_comments);
        for (k, line) in lines.chain([pr.expr(&sh.body)]).enumerate() {
            let c = comments(k);
            for lead in &c.leading {
                let _ = writeln!(s, "    {lead}");
            }
            let _ = write!(s, "    {line}");
            if let Some(t) = &c.trailing {
                let _ = write!(s, "  {t}");
            }
            s.push('\n');
        }
        for lead in &comments(sh.lets.len() + 1).leading {
            let _ = writeln!(s, "    {lead}");
        }
        s.push('}');
    } else {
        let _ = write!(s, " = {};", pr.expr(&sh.body));
    }
}

/// Prints one expression canonically.
pub fn expr(e: &Expr, style: Style) -> String {
    Printer { style }.expr(e)
}

struct Printer {
    style: Style,
}

/// Binding strength, loosest first; the grammar's levels in `shade.pest`.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Prec {
    Select,
    Or,
    And,
    Cmp,
    Combine,
    Sum,
    Product,
    Dot,
    Unary,
    Power,
    Apply,
    Atom,
}

impl Printer {
    fn uni(&self) -> bool {
        self.style == Style::Unicode
    }

    fn name(&self, n: &Name) -> String {
        let mut s = n.base.clone();
        match (self.uni(), n.primes) {
            (true, 2) => s.push('″'),
            (true, 3) => s.push('‴'),
            (true, k) => s.extend(std::iter::repeat_n('′', k as usize)),
            (false, k) => s.extend(std::iter::repeat_n('\'', k as usize)),
        }
        if n.star {
            s.push('*');
        }
        s
    }

    fn names(&self, names: &[Name]) -> String {
        names.iter().map(|n| self.name(n)).collect::<Vec<_>>().join(", ")
    }

    fn ty(&self, ty: &Option<Word<Type>>) -> String {
        ty.as_ref().map(|t| format!(" : {}", t.value.as_str())).unwrap_or_default()
    }

    fn target(&self, t: &Target) -> String {
        let mut s = String::new();
        if let Some(c) = &t.channel {
            s.push_str(self.channel(c.value));
            s.push(' ');
        }
        s.push_str(&self.name(&t.table));
        s.push(' ');
        s.push_str(&self.at(&t.index, Prec::Apply));
        s
    }

    fn channel(&self, c: Channel) -> &'static str {
        match (c, self.uni()) {
            (Channel::Alpha, true) => "α",
            (Channel::Alpha, false) => "alpha",
            (Channel::Stencil, true) => "σ",
            (Channel::Stencil, false) => "stencil",
            (Channel::Depth, _) => "z",
        }
    }

    fn expr(&self, e: &Expr) -> String {
        self.at(e, Prec::Select)
    }

    /// Prints `e` where an expression of at least `min` binding strength is needed.
    fn at(&self, e: &Expr, min: Prec) -> String {
        let (prec, text) = self.bare(e);
        if prec < min {
            format!("({text})")
        } else {
            text
        }
    }

    fn bare(&self, e: &Expr) -> (Prec, String) {
        match &e.kind {
            ExprKind::Number(v) => (Prec::Atom, format!("{v}")),
            ExprKind::String(s) => (Prec::Atom, quote(s)),
            ExprKind::Name(n) => (Prec::Atom, self.name(n)),
            ExprKind::Tuple(items) => {
                let items: Vec<String> = items.iter().map(|i| self.expr(i)).collect();
                (Prec::Atom, format!("({})", items.join(", ")))
            }
            ExprKind::Swizzle { base, components } => {
                // `(2).x`: a number would swallow the dot.
                let b = if matches!(base.kind, ExprKind::Number(_)) {
                    format!("({})", self.expr(base))
                } else {
                    self.at(base, Prec::Atom)
                };
                (Prec::Atom, format!("{b}.{components}"))
            }
            ExprKind::Apply { func, arg } => {
                // A swizzle after a chain applies to the whole chain, so a
                // swizzled argument needs its parentheses: `f (v.rgb)`.
                // Built-in functions and generators print as calls: `expand(v)`.
                if let FuncKind::Name(n) = &func.kind {
                    if is_builtin_call(n) {
                        let a = match arg.kind {
                            ExprKind::Tuple(_) => self.expr(arg),
                            _ => format!("({})", self.expr(arg)),
                        };
                        return (Prec::Apply, format!("{}{a}", self.name(n)));
                    }
                }
                let a = match arg.kind {
                    ExprKind::Swizzle { .. } => format!("({})", self.expr(arg)),
                    _ => self.at(arg, Prec::Apply),
                };
                // A call glues its arguments (`max(0, x)`), but not after a star mark,
                // which would read as a product (`s* (a)` vs `s*(a)`).
                let call = matches!(&func.kind, FuncKind::Name(n) if !n.star) && a.starts_with('(');
                let sep = if self.glued(func, arg) || call { "" } else { " " };
                (Prec::Apply, format!("{}{sep}{a}", self.func(func)))
            }
            ExprKind::Unary { op, operand } => {
                let o = match op {
                    UnaryOp::Neg => "-",
                    UnaryOp::Not => "!",
                };
                (Prec::Unary, format!("{o}{}", self.at(operand, Prec::Unary)))
            }
            ExprKind::Binary { op: BinaryOp::Pow, lhs, rhs } => {
                // Right-associative; an exponent may carry a minus sign of its own.
                let r = match &rhs.kind {
                    ExprKind::Unary { op: UnaryOp::Neg, operand } if self.bare(operand).0 >= Prec::Apply => {
                        format!("-{}", self.at(operand, Prec::Apply))
                    }
                    _ => self.at(rhs, Prec::Power),
                };
                (Prec::Power, format!("{}^{r}", self.at(lhs, Prec::Apply)))
            }
            ExprKind::Binary { op, lhs, rhs } => {
                let (prec, sym) = self.binary(*op);
                // The paper writes dot products tight: `N·L`.
                let pad = if *op == BinaryOp::Dot && self.uni() { "" } else { " " };
                (prec, format!("{}{pad}{sym}{pad}{}", self.at(lhs, prec), self.at(rhs, next(prec))))
            }
            ExprKind::Combine { mode, lhs, rhs } => {
                let mut sym = if self.uni() { "⊕".to_string() } else { "(+)".to_string() };
                if let Some(m) = mode {
                    let _ = write!(sym, "[{}]", m.value.as_str());
                }
                (Prec::Combine, format!("{} {sym} {}", self.at(lhs, Prec::Combine), self.at(rhs, Prec::Sum)))
            }
            ExprKind::Select { cond, then, otherwise } => {
                let mut s = format!("{} ? {}", self.at(cond, Prec::Or), self.at(then, Prec::Or));
                if let Some(o) = otherwise {
                    let _ = write!(s, " : {}", self.at(o, Prec::Select));
                }
                // A select without `:` must stand last; parenthesize it inside another.
                (Prec::Select, s)
            }
        }
    }

    /// Unicode glues δ and π to what they apply to, as the paper writes
    /// `δπx` and `T δu x`; π glues only to a final name, since a glued name
    /// followed by more application reads as π's subscript (`πl x`).
    fn glued(&self, func: &Func, arg: &Expr) -> bool {
        if !self.uni() {
            return false;
        }
        let starts_with_op = matches!(
            &arg.kind,
            ExprKind::Apply { func: Func { kind: FuncKind::Delta | FuncKind::Projection(_), .. }, .. }
        );
        match &func.kind {
            // δ glues to projections and texture coordinates: `δπx`, `T δu x`.
            FuncKind::Delta => {
                let coords = |n: &Name| n.base == "u";
                starts_with_op
                    || matches!(&arg.kind, ExprKind::Name(_))
                    || matches!(&arg.kind, ExprKind::Apply { func: Func { kind: FuncKind::Name(n), .. }, .. } if coords(n))
            }
            FuncKind::Projection(p) if p.subscript.is_none() && !p.star && !p.inverse => {
                starts_with_op || matches!(arg.kind, ExprKind::Name(_))
            }
            _ => false,
        }
    }

    fn binary(&self, op: BinaryOp) -> (Prec, &'static str) {
        let u = self.uni();
        match op {
            BinaryOp::Or => (Prec::Or, if u { "∨" } else { "OR" }),
            BinaryOp::And => (Prec::And, if u { "∧" } else { "AND" }),
            BinaryOp::Lt => (Prec::Cmp, "<"),
            BinaryOp::Le => (Prec::Cmp, if u { "≤" } else { "<=" }),
            BinaryOp::Gt => (Prec::Cmp, ">"),
            BinaryOp::Ge => (Prec::Cmp, if u { "≥" } else { ">=" }),
            BinaryOp::Eq => (Prec::Cmp, "=="),
            BinaryOp::Ne => (Prec::Cmp, if u { "≠" } else { "!=" }),
            BinaryOp::Add => (Prec::Sum, "+"),
            BinaryOp::Sub => (Prec::Sum, "-"),
            BinaryOp::Mul => (Prec::Product, "*"),
            BinaryOp::Div => (Prec::Product, "/"),
            BinaryOp::Dot => (Prec::Dot, if u { "·" } else { "(.)" }),
            BinaryOp::Pow => (Prec::Power, "^"),
        }
    }

    fn func(&self, f: &Func) -> String {
        match &f.kind {
            FuncKind::Delta => (if self.uni() { "δ" } else { "delta" }).to_string(),
            FuncKind::Channel(c) => self.channel(*c).to_string(),
            FuncKind::Name(n) => self.name(n),
            FuncKind::Projection(p) => {
                let mut s = (if self.uni() { "π" } else { "pi" }).to_string();
                if let Some(sub) = &p.subscript {
                    // Unicode glues the subscript (`πl`); a space always follows it.
                    if !self.uni() {
                        s.push('_');
                    }
                    s.push_str(sub);
                }
                if p.star {
                    s.push('*');
                }
                if p.inverse {
                    s.push_str(if self.uni() { "⁻¹" } else { "^-1" });
                }
                s
            }
        }
    }
}

/// A string literal with the escapes the grammar reads back: `\"`, `\\`, `\n`, `\t`.
fn quote(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn is_builtin_call(n: &Name) -> bool {
    use super::resolve::{FUNCTIONS, GENERATORS};
    n.primes == 0
        && !n.star
        && (FUNCTIONS.contains(&n.base.as_str()) || GENERATORS.contains(&n.base.as_str()))
}

/// The strength needed on the right of a left-associative operator.
fn next(p: Prec) -> Prec {
    match p {
        Prec::Select => Prec::Or,
        Prec::Or => Prec::And,
        Prec::And => Prec::Cmp,
        Prec::Cmp => Prec::Combine,
        Prec::Combine => Prec::Sum,
        Prec::Sum => Prec::Product,
        Prec::Product => Prec::Dot,
        Prec::Dot => Prec::Unary,
        Prec::Unary => Prec::Power,
        Prec::Power => Prec::Apply,
        Prec::Apply | Prec::Atom => Prec::Atom,
    }
}

/// A fully parenthesized prefix form that shows the tree's shape:
/// `T δu x` → `(T (δ (u x)))`. Used by tests and `shadec fmt --tree`.
pub fn sexpr(e: &Expr) -> String {
    let p = Printer { style: Style::Unicode };
    match &e.kind {
        ExprKind::Number(_) | ExprKind::String(_) | ExprKind::Name(_) => p.expr(e),
        ExprKind::Tuple(items) => {
            format!("(tuple {})", items.iter().map(sexpr).collect::<Vec<_>>().join(" "))
        }
        ExprKind::Apply { func, arg } => format!("({} {})", p.func(func), sexpr(arg)),
        ExprKind::Swizzle { base, components } => format!("(.{components} {})", sexpr(base)),
        ExprKind::Unary { op, operand } => {
            format!("({} {})", if *op == UnaryOp::Neg { "neg" } else { "not" }, sexpr(operand))
        }
        ExprKind::Binary { op, lhs, rhs } => format!("({} {} {})", p.binary(*op).1, sexpr(lhs), sexpr(rhs)),
        ExprKind::Combine { mode, lhs, rhs } => {
            let m = mode.as_ref().map_or("⊕".to_string(), |m| format!("⊕[{}]", m.value.as_str()));
            format!("({m} {} {})", sexpr(lhs), sexpr(rhs))
        }
        ExprKind::Select { cond, then, otherwise } => match otherwise {
            Some(o) => format!("(? {} {} {})", sexpr(cond), sexpr(then), sexpr(o)),
            None => format!("(? {} {})", sexpr(cond), sexpr(then)),
        },
    }
}

/// The tree form of a whole program, one item per line.
pub fn program_tree(p: &Program) -> String {
    let mut out = String::new();
    for item in &p.items {
        match &item.kind {
            ItemKind::Statement(st) => {
                let t = &st.target;
                let channel =
                    t.channel.as_ref().map_or(String::new(), |c| format!("{:?} ", c.value).to_lowercase());
                let _ = writeln!(
                    out,
                    "(← ({channel}{} {}) {})",
                    Printer { style: Style::Unicode }.name(&t.table),
                    sexpr(&t.index),
                    sexpr(&st.value)
                );
            }
            _ => {
                let _ = writeln!(out, "{}", self::item(item, Style::Unicode));
            }
        }
    }
    out
}
