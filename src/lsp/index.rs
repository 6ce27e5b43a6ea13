//! Every name of a program with what it refers to: declarations, uses,
//! shader-local names (the input `s`, parameters, `let`s of a block), the
//! paper's families (`x xs u s C`, Pipeline Grammar, Figure 2) and built-in
//! functions. Navigation, hover, rename and semantic tokens read it; the
//! scoping follows `parser::resolve`.

use std::collections::HashMap;

use crate::parser::ast::*;
use crate::parser::resolve::{family, Entity, FUNCTIONS, GENERATORS};
use crate::span::Span;

/// One occurrence of a name in the text.
#[derive(Clone, Debug, PartialEq)]
pub struct Occurrence {
    pub span: Span,
    /// The name as resolved (`T'`, ASCII primes).
    pub key: String,
    /// What it names, if known.
    pub entity: Option<Entity>,
    /// The declaration's span: the same as `span` for a declaration, `None`
    /// for families, built-ins and unknown names.
    pub decl: Option<Span>,
}

impl Occurrence {
    /// Whether this occurrence is the name's declaration.
    pub fn is_decl(&self) -> bool {
        self.decl == Some(self.span)
    }
}

/// Every name occurrence of `program`, in text order.
pub fn occurrences(program: &Program) -> Vec<Occurrence> {
    let mut ix = Indexer::default();
    for item in &program.items {
        ix.declare_item(item);
    }
    for item in &program.items {
        ix.uses_of_item(item);
    }
    ix.out.sort_by_key(|o| (o.span.start, o.span.end));
    ix.out.dedup_by_key(|o| o.span);
    ix.out
}

/// The occurrence under `offset` (a cursor just after a name counts).
pub fn at(occurrences: &[Occurrence], offset: usize) -> Option<&Occurrence> {
    let o = offset as u32;
    occurrences
        .iter()
        .find(|x| x.span.start <= o && o < x.span.end)
        .or_else(|| occurrences.iter().find(|x| x.span.end == o))
}

/// The occurrences of the entity declared at `decl`: its declaration first.
pub fn references(occurrences: &[Occurrence], decl: Span) -> Vec<&Occurrence> {
    occurrences.iter().filter(|o| o.decl == Some(decl)).collect()
}

type Locals = Vec<(String, Entity, Span)>;

#[derive(Default)]
struct Indexer {
    globals: HashMap<String, (Entity, Span)>,
    out: Vec<Occurrence>,
}

impl Indexer {
    fn declare(&mut self, n: &Name, entity: Entity) {
        // A second declaration is an error the resolver reports; uses go to the first.
        let decl = self.globals.entry(n.key()).or_insert((entity, n.span)).1;
        self.out.push(Occurrence { span: n.span, key: n.key(), entity: Some(entity), decl: Some(decl) });
    }

    fn declare_item(&mut self, item: &Item) {
        match &item.kind {
            ItemKind::Target(_) | ItemKind::Statement(_) => {}
            ItemKind::Texture(t) => t.names.iter().for_each(|n| self.declare(n, Entity::Texture)),
            ItemKind::Framebuffer(f) => f.names.iter().for_each(|n| self.declare(n, Entity::Framebuffer)),
            ItemKind::Vector(v) => v.names.iter().for_each(|n| self.declare(n, Entity::Vector)),
            ItemKind::Params(p) => self.declare(&p.name, Entity::Params),
            ItemKind::Const(c) => self.declare(&c.name, Entity::Const),
            ItemKind::Uniform(u) => self.declare(&u.name, Entity::Uniform),
            ItemKind::Let(l) => self.declare(&l.name, Entity::Let),
            ItemKind::Shader(s) => self.declare(&s.name, Entity::Shader),
        }
    }

    fn uses_of_item(&mut self, item: &Item) {
        let none = Locals::new();
        match &item.kind {
            ItemKind::Target(_) | ItemKind::Framebuffer(_) => {}
            ItemKind::Texture(t) => t.source.iter().for_each(|e| self.expr(e, &none)),
            ItemKind::Vector(v) => v.value.iter().for_each(|e| self.expr(e, &none)),
            ItemKind::Params(p) => p.members.iter().for_each(|m| self.use_name(m, &none)),
            ItemKind::Const(c) => self.expr(&c.value, &none),
            ItemKind::Uniform(u) => u.default.iter().for_each(|e| self.expr(e, &none)),
            ItemKind::Let(l) => self.expr(&l.value, &none),
            ItemKind::Shader(s) => self.shader(s),
            ItemKind::Statement(st) => {
                self.use_name(&st.target.table, &none);
                self.expr(&st.target.index, &none);
                self.expr(&st.value, &none);
            }
        }
    }

    fn local(&mut self, n: &Name, entity: Entity, locals: &mut Locals) {
        self.out.push(Occurrence { span: n.span, key: n.key(), entity: Some(entity), decl: Some(n.span) });
        locals.push((n.key(), entity, n.span));
    }

    fn shader(&mut self, s: &ShaderDecl) {
        let mut locals = Locals::new();
        self.local(&s.input, Entity::Params, &mut locals);
        for p in &s.params {
            if let Some(d) = &p.default {
                self.expr(d, &locals);
            }
            self.local(&p.name, Entity::ShaderParam, &mut locals);
        }
        for l in &s.lets {
            self.expr(&l.value, &locals);
            self.local(&l.name, Entity::Let, &mut locals);
        }
        self.expr(&s.body, &locals);
    }

    fn use_name(&mut self, n: &Name, locals: &Locals) {
        let key = n.key();
        let (entity, decl) = if let Some((_, e, s)) = locals.iter().rev().find(|(k, _, _)| *k == key) {
            (Some(*e), Some(*s))
        } else if let Some((e, s)) = self.globals.get(&key) {
            (Some(*e), Some(*s))
        } else if FUNCTIONS.contains(&key.as_str()) || GENERATORS.contains(&key.as_str()) {
            (Some(Entity::Function), None)
        } else {
            (family(n), None)
        };
        self.out.push(Occurrence { span: n.span, key, entity, decl });
    }

    fn expr(&mut self, e: &Expr, locals: &Locals) {
        let mut stack = vec![e];
        while let Some(e) = stack.pop() {
            match &e.kind {
                ExprKind::Number(_) | ExprKind::String(_) => {}
                ExprKind::Name(n) => self.use_name(n, locals),
                ExprKind::Tuple(items) => stack.extend(items),
                ExprKind::Apply { func, arg } => {
                    if let FuncKind::Name(n) = &func.kind {
                        self.use_name(n, locals);
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
}
