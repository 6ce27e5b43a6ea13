//! pest pairs of one item → AST, with spans shifted to file offsets.
//!
//! Words with a closed vocabulary (texture kinds, formats, ⊕ modes, …) are
//! classified here, with "did you mean" suggestions. Operator chains are folded
//! iteratively and refused beyond `MAX_EXPR_DEPTH`, so the tree handed on is
//! shallow enough for every recursive pass (and for `Drop`).

use pest::iterators::Pair;

use super::ast::*;
use super::{Rule, MAX_EXPR_DEPTH};
use crate::diag::{did_you_mean, Diagnostic};
use crate::span::Span;

type Errors = Vec<Diagnostic>;

/// An expression and the depth of its tree.
struct Deep {
    expr: Expr,
    depth: usize,
}

/// Runs of one associative operator longer than this are built balanced
/// (a flat sum is not nesting); shorter ones nest to the left as written, so that every
/// program of ordinary size keeps the order of its operations.
const BALANCE_FROM: usize = 64;

/// An operand on the operator fold's stack: a finished tree, or a run of
/// `+` or `*` still growing.
enum Operand {
    Tree(Deep),
    Chain(Chain),
}

/// `t₀ op t₁ op … op tₙ`, one associative operator.
struct Chain {
    op: BinaryOp,
    terms: Vec<Deep>,
}

/// Builds the AST of one top-level item from its parse tree; `offset` is
/// the item's byte offset in the file, added to every span.
#[allow(clippy::expect_used)] // the grammar's `item` rule always has one child, a declaration or statement
pub fn item(pair: Pair<'_, Rule>, offset: usize) -> Result<Item, Errors> {
    let mut b = Builder { offset, errors: Vec::new() };
    let children: Vec<Pair<'_, Rule>> = pair.into_inner().filter(|p| p.as_rule() != Rule::EOI).collect();
    let span = b.span(&children[0]).join(b.span(children.last().expect("an item has children")));
    let inner = children.into_iter().next().expect("item holds a declaration or statement");
    let kind = b.item_kind(inner);
    match kind {
        Some(kind) if b.errors.is_empty() => Ok(Item { kind, span, comments: Comments::default() }),
        _ => Err(b.errors),
    }
}

struct Builder {
    offset: usize,
    errors: Errors,
}

impl Builder {
    fn span(&self, pair: &Pair<'_, Rule>) -> Span {
        let s = pair.as_span();
        Span::new(s.start() + self.offset, s.end() + self.offset)
    }

    fn item_kind(&mut self, pair: Pair<'_, Rule>) -> Option<ItemKind> {
        let rule = pair.as_rule();
        let mut it = pair.into_inner().filter(|p| !is_keyword(p.as_rule())).peekable();
        Some(match rule {
            Rule::target_decl => {
                let word = it.next()?;
                ItemKind::Target(TargetDecl {
                    profile: Word { value: word.as_str().to_string(), span: self.span(&word) },
                })
            }
            Rule::texture_decl => ItemKind::Texture(self.texture_decl(it)?),
            Rule::framebuffer_decl => {
                let names = self.name_list(it.next()?);
                let channels = it
                    .filter_map(|w| {
                        self.classify(
                            &w,
                            "framebuffer channel",
                            FramebufferChannel::from_word,
                            FramebufferChannel::ALL,
                        )
                    })
                    .collect();
                ItemKind::Framebuffer(FramebufferDecl { names, channels })
            }
            Rule::vector_decl => {
                let names = self.name_list(it.next()?);
                let role = match it.next_if(|p| p.as_rule() == Rule::vector_kind) {
                    Some(k) => Some(self.vector_role(k)?),
                    None => None,
                };
                let value = match it.next() {
                    Some(e) => Some(self.expr(e)?.expr),
                    None => None,
                };
                ItemKind::Vector(VectorDecl { names, role, value })
            }
            Rule::params_decl => {
                let name = self.name(it.next()?);
                let members = self.name_list(it.next()?);
                ItemKind::Params(ParamsDecl { name, members })
            }
            Rule::const_decl => {
                let name = self.name(it.next()?);
                let ty = self.opt_type(&mut it)?;
                let value = self.expr(it.next()?)?.expr;
                ItemKind::Const(ConstDecl { name, ty, value })
            }
            Rule::uniform_decl => {
                let name = self.name(it.next()?);
                let ty = self.opt_type(&mut it)?;
                let default = match it.next() {
                    Some(e) => Some(self.expr(e)?.expr),
                    None => None,
                };
                ItemKind::Uniform(UniformDecl { name, ty, default })
            }
            Rule::let_decl => ItemKind::Let(self.let_decl(it)?),
            Rule::shader_decl => ItemKind::Shader(self.shader_decl(it)?),
            Rule::statement => {
                let lhs = it.next()?;
                it.next_if(|p| p.as_rule() == Rule::assign);
                let target = self.target(lhs)?;
                let value = self.expr(it.next()?)?.expr;
                ItemKind::Statement(Statement { target, value })
            }
            other => unreachable!("not an item: {other:?}"),
        })
    }

    /// `texture T kind format attributes = source`: every word classified before giving up.
    fn texture_decl<'a>(
        &mut self,
        mut it: std::iter::Peekable<impl Iterator<Item = Pair<'a, Rule>>>,
    ) -> Option<TextureDecl> {
        let names = self.name_list(it.next()?);
        let mut words = Vec::new();
        while let Some(p) = it.next_if(|p| p.as_rule() == Rule::word) {
            words.push(p);
        }
        let source = match it.next() {
            Some(e) => Some(self.expr(e)?.expr),
            None => None,
        };
        let mut words = words.into_iter();
        // Classify every word before giving up, so each unknown one is reported.
        let kind = self.classify::<TextureKind>(
            &words.next()?,
            "texture kind",
            TextureKind::from_word,
            TextureKind::ALL,
        );
        let (mut format, mut attrs) = (None, Vec::new());
        for w in words {
            if let Some(f) = TextureFormat::from_word(w.as_str()) {
                if format.is_some() {
                    self.errors.push(
                        Diagnostic::error(
                            "duplicate-format",
                            "a texture has one format",
                            self.span(&w),
                            "second format",
                        )
                        .with_help("keep one of the formats"),
                    );
                }
                format = Some(Word { value: f, span: self.span(&w) });
            } else if let Some(a) = TextureAttr::from_word(w.as_str()) {
                attrs.push(Word { value: a, span: self.span(&w) });
            } else {
                let all: Vec<&str> = TextureFormat::ALL.iter().chain(TextureAttr::ALL).copied().collect();
                self.unknown_word(&w, "texture format or attribute", &all);
            }
        }
        Some(TextureDecl { names, kind: kind?, format, attrs, source })
    }

    /// `shader f(params) x -> type = body`, the body an expression or a block of lets.
    fn shader_decl<'a>(
        &mut self,
        mut it: std::iter::Peekable<impl Iterator<Item = Pair<'a, Rule>>>,
    ) -> Option<ShaderDecl> {
        let name = self.name(it.next()?);
        let mut params = Vec::new();
        if let Some(ps) = it.next_if(|p| p.as_rule() == Rule::shader_params) {
            for p in ps.into_inner() {
                let mut parts = p.into_inner().peekable();
                let name = self.name(parts.next()?);
                let ty = self.opt_type(&mut parts)?;
                let default = match parts.next() {
                    Some(e) => Some(self.expr(e)?.expr),
                    None => None,
                };
                params.push(ShaderParam { name, ty, default });
            }
        }
        let input = self.name(it.next()?);
        it.next_if(|p| p.as_rule() == Rule::arrow);
        let output = self.classify(&it.next()?, "type", Type::from_word, Type::ALL)?;
        let body = it.next()?;
        let block = body.as_str().trim_start().starts_with('{');
        let mut lets = Vec::new();
        let mut result = None;
        for p in body.into_inner() {
            match p.as_rule() {
                Rule::let_decl => {
                    let inner = p.into_inner().filter(|p| !is_keyword(p.as_rule())).peekable();
                    lets.push(self.let_decl(inner)?);
                }
                Rule::expr => result = Some(self.expr(p)?.expr),
                _ => {}
            }
        }
        Some(ShaderDecl { name, params, input, output, lets, body: result?, block })
    }

    fn let_decl<'a>(&mut self, mut it: impl Iterator<Item = Pair<'a, Rule>>) -> Option<LetDecl> {
        let name = self.name(it.next()?);
        let value = self.expr(it.next()?)?.expr;
        Some(LetDecl { name, value })
    }

    fn opt_type<'a>(
        &mut self,
        it: &mut std::iter::Peekable<impl Iterator<Item = Pair<'a, Rule>>>,
    ) -> Option<Option<Word<Type>>> {
        match it.next_if(|p| p.as_rule() == Rule::word) {
            Some(w) => Some(Some(self.classify(&w, "type", Type::from_word, Type::ALL)?)),
            None => Some(None),
        }
    }

    fn vector_role(&mut self, pair: Pair<'_, Rule>) -> Option<VectorRole> {
        let mut it = pair.into_inner().filter(|p| !is_keyword(p.as_rule()));
        let kind = self.classify(&it.next()?, "vector kind", VectorKind::from_word, VectorKind::ALL)?;
        let (mut index, mut space) = (None, None);
        for p in it {
            match p.as_rule() {
                Rule::number => match p.as_str().parse::<u32>() {
                    Ok(i) => index = Some(Word { value: i, span: self.span(&p) }),
                    Err(_) => {
                        self.errors.push(
                            Diagnostic::error(
                                "bad-index",
                                "a light index is a whole number",
                                self.span(&p),
                                "not a whole number",
                            )
                            .with_help("write `light(0)`, `light(1)`, …"),
                        );
                        return None;
                    }
                },
                _ => space = Some(self.classify(&p, "space", Space::from_word, Space::ALL)?),
            }
        }
        Some(VectorRole { kind, index, space })
    }

    fn classify<T>(
        &mut self,
        pair: &Pair<'_, Rule>,
        what: &str,
        from: fn(&str) -> Option<T>,
        all: &[&str],
    ) -> Option<Word<T>> {
        match from(pair.as_str()) {
            Some(value) => Some(Word { value, span: self.span(pair) }),
            None => {
                self.unknown_word(pair, what, all);
                None
            }
        }
    }

    fn unknown_word(&mut self, pair: &Pair<'_, Rule>, what: &str, all: &[&str]) {
        let word = pair.as_str();
        let help = match did_you_mean(word, all.iter().copied()) {
            Some(s) => format!("did you mean `{s}`? (expected one of: {})", all.join(", ")),
            None => format!("expected one of: {}", all.join(", ")),
        };
        self.errors.push(
            Diagnostic::error(
                "unknown-word",
                format!("unknown {what} `{word}`"),
                self.span(pair),
                format!("not a {what}"),
            )
            .with_help(help),
        );
    }

    fn name_list(&mut self, pair: Pair<'_, Rule>) -> Vec<Name> {
        pair.into_inner().map(|p| self.name(p)).collect()
    }

    fn name(&mut self, pair: Pair<'_, Rule>) -> Name {
        let span = self.span(&pair);
        let text = pair.as_str();
        let mut primes = 0u8;
        let mut star = false;
        let mut base_end = text.len();
        for p in pair.into_inner() {
            match p.as_rule() {
                Rule::primes => {
                    base_end = base_end.min(p.as_span().start() - (span.start as usize - self.offset));
                    primes = p
                        .as_str()
                        .chars()
                        .map(|c| match c {
                            '″' => 2,
                            '‴' => 3,
                            _ => 1,
                        })
                        .sum::<u8>();
                }
                Rule::star_mark => star = true,
                _ => {}
            }
        }
        Name { base: text[..base_end].to_string(), primes, star, span }
    }

    fn target(&mut self, pair: Pair<'_, Rule>) -> Option<Target> {
        let span = self.span(&pair);
        let mut parts: Vec<Pair<'_, Rule>> = pair.into_inner().collect();
        let arg = parts.pop()?;
        let mut funcs = parts.into_iter();
        let help = "the left of `←` is a table and its index: `C δπx` (a pixel of framebuffer C), `C xs`, `T δu` (texels of T), `u x` (a vertex attribute), `α C xs` (a channel)";
        let mut first = match funcs.next() {
            Some(f) => f,
            None => {
                self.errors.push(
                    Diagnostic::error(
                        "bad-target",
                        "nothing to assign into: the left of `←` has no index",
                        span,
                        "a table needs an index",
                    )
                    .with_help(help),
                );
                return None;
            }
        };
        let channel = if first.as_rule() == Rule::channel {
            let c = Word { value: channel_of(first.as_str()), span: self.span(&first) };
            first = match funcs.next() {
                Some(f) => f,
                None => {
                    self.errors.push(
                        Diagnostic::error(
                            "bad-target",
                            "a channel selector needs a framebuffer and an index",
                            span,
                            "incomplete target",
                        )
                        .with_help(help),
                    );
                    return None;
                }
            };
            Some(c)
        } else {
            None
        };
        let table = match self.atom_name(&first) {
            Some(name) => name,
            None => {
                let what = describe_func(first.as_rule());
                self.errors.push(
                    Diagnostic::error(
                        "bad-target",
                        format!("cannot assign into {what}"),
                        self.span(&first),
                        "expected a framebuffer, texture or attribute name",
                    )
                    .with_help(help),
                );
                return None;
            }
        };
        let rest: Vec<Pair<'_, Rule>> = funcs.collect();
        let index = self.fold_application(rest, arg)?.expr;
        Some(Target { channel, table, index, span })
    }

    fn expr(&mut self, pair: Pair<'_, Rule>) -> Option<Deep> {
        match pair.as_rule() {
            Rule::expr => self.fold_operators(pair),
            Rule::application => {
                let mut parts: Vec<Pair<'_, Rule>> = pair.into_inner().collect();
                let arg = parts.pop()?;
                self.fold_application(parts, arg)
            }
            Rule::postfix => self.postfix(pair),
            other => unreachable!("not an expression: {other:?}"),
        }
    }

    fn check_depth(&mut self, depth: usize, span: Span) -> Option<()> {
        if depth > MAX_EXPR_DEPTH {
            self.errors.push(
                Diagnostic::error(
                    "nesting-too-deep",
                    format!("expression nests more than {MAX_EXPR_DEPTH} levels deep"),
                    span,
                    "this expression",
                )
                .with_help("split it into `let` bindings or several statements"),
            );
            return None;
        }
        Some(())
    }

    /// Folds `operand (infix operand)*` by precedence with an explicit stack
    /// (shunting-yard), so no input length can recurse. `c ? a : b` is a
    /// right-associative ternary at the loosest level; `c ? a` without `:`
    /// is a conditional write (Pipeline Grammar, shadow volumes).
    fn fold_operators(&mut self, pair: Pair<'_, Rule>) -> Option<Deep> {
        let mut operands: Vec<Operand> = Vec::new();
        let mut ops: Vec<(Op, Span)> = Vec::new();
        for p in pair.into_inner() {
            match p.as_rule() {
                Rule::operand => {
                    let mut parts: Vec<Pair<'_, Rule>> = p.into_inner().collect();
                    let application = parts.pop()?;
                    for prefix in parts {
                        let op = if prefix.as_rule() == Rule::op_not { UnaryOp::Not } else { UnaryOp::Neg };
                        ops.push((Op::Prefix(op), self.span(&prefix)));
                    }
                    operands.push(Operand::Tree(self.expr(application)?));
                }
                Rule::colon => {
                    let span = self.span(&p);
                    loop {
                        match ops.last() {
                            Some((Op::Question, _)) => break,
                            Some((Op::QuestionColon, _)) | None => {
                                self.errors.push(
                                    Diagnostic::error(
                                        "syntax",
                                        "`:` without a matching `?`",
                                        span,
                                        "no `?` before this",
                                    )
                                    .with_help("a select reads `condition ? value : otherwise`"),
                                );
                                return None;
                            }
                            Some(_) => self.reduce(&mut operands, &mut ops)?,
                        }
                    }
                    ops.last_mut()?.0 = Op::QuestionColon;
                }
                _ => {
                    let op = self.infix(p)?;
                    let (prec, right) = op.0.precedence();
                    while let Some((top, _)) = ops.last() {
                        let (top_prec, _) = top.precedence();
                        if top_prec > prec || (top_prec == prec && !right) {
                            self.reduce(&mut operands, &mut ops)?;
                        } else {
                            break;
                        }
                    }
                    ops.push(op);
                }
            }
        }
        while !ops.is_empty() {
            self.reduce(&mut operands, &mut ops)?;
        }
        let last = operands.pop()?;
        self.finish(last)
    }

    fn infix(&mut self, p: Pair<'_, Rule>) -> Option<(Op, Span)> {
        let span = self.span(&p);
        let op = match p.as_rule() {
            Rule::question => Op::Question,
            Rule::op_combine => {
                let mode = match p.into_inner().next() {
                    Some(m) => {
                        let word = m.into_inner().next()?;
                        Some(self.classify(&word, "⊕ mode", CombineMode::from_word, CombineMode::ALL)?)
                    }
                    None => None,
                };
                Op::Combine(mode)
            }
            _ => Op::Binary(binary_op(&p)),
        };
        Some((op, span))
    }

    /// Applies the operator on top of the stack to its operands. A `+` or
    /// `*` whose left operand is a run of the same operator joins the run
    /// instead of nesting: a flat sum is not nesting.
    fn reduce(&mut self, operands: &mut Vec<Operand>, ops: &mut Vec<(Op, Span)>) -> Option<()> {
        let (op, op_span) = ops.pop()?;
        let arity = match op {
            Op::Prefix(_) => 1,
            Op::QuestionColon => 3,
            _ => 2,
        };
        if operands.len() < arity {
            return None;
        }
        let args: Vec<Operand> = operands.split_off(operands.len() - arity);
        if let Op::Binary(bop @ (BinaryOp::Add | BinaryOp::Mul)) = op {
            let [lhs, rhs]: [Operand; 2] = args.try_into().ok()?;
            let rhs = self.finish(rhs)?;
            let chain = match lhs {
                Operand::Chain(mut chain) if chain.op == bop => {
                    chain.terms.push(rhs);
                    chain
                }
                lhs => Chain { op: bop, terms: vec![self.finish(lhs)?, rhs] },
            };
            operands.push(Operand::Chain(chain));
            return Some(());
        }
        let mut args = args.into_iter().map(|a| self.finish(a)).collect::<Option<Vec<Deep>>>()?;
        let depth = 1 + args.iter().map(|d| d.depth).max().unwrap_or(0);
        let span = args.iter().fold(op_span, |s, d| s.join(d.expr.span));
        self.check_depth(depth, span)?;
        let mut args = args.drain(..).map(|d| Box::new(d.expr));
        #[allow(clippy::expect_used)] // `args` holds the operator's arity, checked by the grammar
        let mut next = || args.next().expect("arity checked");
        let kind = match op {
            Op::Prefix(op) => ExprKind::Unary { op, operand: next() },
            Op::Binary(op) => ExprKind::Binary { op, lhs: next(), rhs: next() },
            Op::Combine(mode) => ExprKind::Combine { mode, lhs: next(), rhs: next() },
            Op::Question => ExprKind::Select { cond: next(), then: next(), otherwise: None },
            Op::QuestionColon => ExprKind::Select { cond: next(), then: next(), otherwise: Some(next()) },
        };
        operands.push(Operand::Tree(Deep { expr: Expr { kind, span }, depth }));
        Some(())
    }

    /// The tree of an operand: a run of up to [`BALANCE_FROM`] terms
    /// nests to the left as written; a longer one is built balanced, pairs
    /// of neighbours first, so that its depth is the logarithm of its
    /// length and only true nesting meets `MAX_EXPR_DEPTH`.
    fn finish(&mut self, operand: Operand) -> Option<Deep> {
        let Chain { op, terms } = match operand {
            Operand::Tree(d) => return Some(d),
            Operand::Chain(c) => c,
        };
        if terms.len() <= BALANCE_FROM {
            let mut terms = terms.into_iter();
            let first = terms.next()?;
            return terms.try_fold(first, |lhs, rhs| self.node(op, lhs, rhs));
        }
        let mut level = terms;
        while level.len() > 1 {
            let mut next = Vec::with_capacity(level.len().div_ceil(2));
            let mut it = level.into_iter();
            while let Some(lhs) = it.next() {
                next.push(match it.next() {
                    Some(rhs) => self.node(op, lhs, rhs)?,
                    None => lhs,
                });
            }
            level = next;
        }
        level.pop()
    }

    /// `lhs op rhs`, its depth checked.
    fn node(&mut self, op: BinaryOp, lhs: Deep, rhs: Deep) -> Option<Deep> {
        let depth = 1 + lhs.depth.max(rhs.depth);
        let span = lhs.expr.span.join(rhs.expr.span);
        self.check_depth(depth, span)?;
        let kind = ExprKind::Binary { op, lhs: Box::new(lhs.expr), rhs: Box::new(rhs.expr) };
        Some(Deep { expr: Expr { kind, span }, depth })
    }

    /// `f g h x` → f(g(h(x))); swizzles after the argument apply to the
    /// whole chain: `T δu x.a` is `(T δu x).a`.
    fn fold_application(&mut self, funcs: Vec<Pair<'_, Rule>>, arg: Pair<'_, Rule>) -> Option<Deep> {
        let arg_span = self.span(&arg);
        let arg = match arg.as_rule() {
            Rule::postfix => arg,
            // `z` at the end of a chain is a name, not the depth channel.
            Rule::channel if arg.as_str() == "z" => {
                let name = Name { base: "z".into(), primes: 0, star: false, span: arg_span };
                return self.fold_funcs(
                    funcs,
                    Deep { expr: Expr { kind: ExprKind::Name(name), span: arg_span }, depth: 1 },
                    Vec::new(),
                );
            }
            rule => {
                let (what, help) = match rule {
                    Rule::channel => (
                        "a channel selector needs a framebuffer to read",
                        "write `α C xs` (alpha of framebuffer C at pixel xs)",
                    ),
                    Rule::delta => (
                        "δ needs a value to interpolate",
                        "write `δ u x` (texture coordinates of vertex x, interpolated)",
                    ),
                    _ => ("π needs a vertex to project", "write `π x` or `δπx`"),
                };
                self.errors.push(
                    Diagnostic::error("incomplete-application", what, arg_span, "nothing follows")
                        .with_help(help),
                );
                return None;
            }
        };
        if funcs.is_empty() {
            return self.expr(arg);
        }
        let mut parts = arg.into_inner();
        let acc = self.primary(parts.next()?.into_inner().next()?)?;
        let swizzles: Vec<Pair<'_, Rule>> = parts.collect();
        self.fold_funcs(funcs, acc, swizzles)
    }

    fn fold_funcs(
        &mut self,
        funcs: Vec<Pair<'_, Rule>>,
        mut acc: Deep,
        swizzles: Vec<Pair<'_, Rule>>,
    ) -> Option<Deep> {
        if funcs.is_empty() {
            return Some(self.swizzle(acc, swizzles));
        }
        let first_span = self.span(&funcs[0]);
        self.check_depth(acc.depth + funcs.len(), first_span.join(acc.expr.span))?;
        self.parenthesized_in_chain(&funcs, acc.expr.span)?;
        self.parameters_at_use(&funcs, acc.expr.span)?;
        for f in funcs.into_iter().rev() {
            let func = self.func(f)?;
            let span = func.span.join(acc.expr.span);
            acc = Deep {
                expr: Expr { kind: ExprKind::Apply { func, arg: Box::new(acc.expr) }, span },
                depth: acc.depth + 1,
            };
        }
        Some(self.swizzle(acc, swizzles))
    }

    /// `p(16) δ s x`: a name followed by a parenthesized value in an
    /// application chain reads as setting a shader's parameters where it is
    /// used, which the language cannot do yet (examples/GAPS.md item 6).
    /// Says so, with what works instead, rather than "to multiply, write
    /// `*`". `None` after reporting it.
    fn parameters_at_use(&mut self, funcs: &[Pair<'_, Rule>], arg: Span) -> Option<()> {
        for (k, pair) in funcs.windows(2).enumerate() {
            let (Some(name), value) = (self.atom_name(&pair[0]), &pair[1]) else { continue };
            if value.as_rule() != Rule::postfix || !value.as_str().starts_with('(') {
                continue;
            }
            let key = name.key();
            let args = value.as_str();
            let span = name.span.join(self.span(value));
            if super::resolve::FUNCTIONS.contains(&key.as_str()) {
                let rest = funcs.get(k + 2).map_or(arg, |p| self.span(p)).join(arg);
                let input = pair[0].get_input();
                let rest_text = &input[rest.start as usize - self.offset..rest.end as usize - self.offset];
                self.errors.push(builtin_in_chain(&format!("{key}{args}"), span, rest_text, rest, "p"));
                return None;
            }
            self.errors.push(
                Diagnostic::error(
                    "not-supported",
                    format!("`{key}{args}`: a shader's parameters cannot be set where it is used"),
                    span,
                    "parameters set here",
                )
                .with_help(parameters_help(&key, args, None)),
            );
            return None;
        }
        Some(())
    }

    /// `δ (kd * max(0, N·L)) s x`: a parenthesized value applied to the
    /// shading parameters, meant as a function of them — a shader, as for a
    /// built-in ([`builtin_in_chain`]), rather than "to multiply, write `*`".
    /// A parenthesized value after a name is [`Self::parameters_at_use`]'s;
    /// one applied to anything else is left to `func`. `None` after reporting it.
    fn parenthesized_in_chain(&mut self, funcs: &[Pair<'_, Rule>], arg: Span) -> Option<()> {
        for (k, pair) in funcs.iter().enumerate() {
            let after_name = k > 0 && self.atom_name(&funcs[k - 1]).is_some();
            if after_name || pair.as_rule() != Rule::postfix || !pair.as_str().starts_with('(') {
                continue;
            }
            let rest = funcs.get(k + 1).map_or(arg, |p| self.span(p)).join(arg);
            let input = pair.get_input();
            let rest_text = &input[rest.start as usize - self.offset..rest.end as usize - self.offset];
            if !on_shading_parameters(rest_text) {
                continue;
            }
            self.errors.push(builtin_in_chain(pair.as_str(), self.span(pair), rest_text, rest, "p"));
            return None;
        }
        Some(())
    }

    /// The name inside an atom that is a plain name (no swizzle).
    fn atom_name(&mut self, pair: &Pair<'_, Rule>) -> Option<Name> {
        if pair.as_rule() != Rule::postfix {
            return None;
        }
        let mut inner = pair.clone().into_inner();
        let primary = inner.next()?.into_inner().next()?;
        if inner.next().is_some() || primary.as_rule() != Rule::name {
            return None;
        }
        Some(self.name(primary))
    }

    fn func(&mut self, pair: Pair<'_, Rule>) -> Option<Func> {
        let span = self.span(&pair);
        if pair.as_rule() == Rule::postfix {
            if let Some(name) = self.atom_name(&pair) {
                return Some(Func { kind: FuncKind::Name(name), span });
            }
            let text = pair.as_str();
            let (what, help) = if text.starts_with('(') {
                (
                    "a parenthesized value cannot be applied to what follows",
                    "to multiply, write `*` between them",
                )
            } else if text.starts_with('"') {
                (
                    "a string cannot be applied to a value",
                    "strings name files inside texture sources: `image(\"brick.png\")`",
                )
            } else if text.contains('.') && !text.starts_with(|c: char| c.is_ascii_digit()) {
                (
                    "a swizzled value cannot be applied to what follows",
                    "put parentheses around the swizzle or write `*` to multiply",
                )
            } else {
                ("a number cannot be applied to a value", "to multiply, write `*` after the number: `2 * x`")
            };
            self.errors.push(
                Diagnostic::error("not-a-function", what, span, "in function position").with_help(help),
            );
            return None;
        }
        let kind = match pair.as_rule() {
            Rule::delta => FuncKind::Delta,
            Rule::channel => FuncKind::Channel(channel_of(pair.as_str())),
            Rule::projection => {
                let mut proj = Projection::default();
                for p in pair.into_inner() {
                    match p.as_rule() {
                        Rule::proj_sub => proj.subscript = Some(p.as_str().to_string()),
                        Rule::proj_star => proj.star = true,
                        Rule::proj_inverse => proj.inverse = true,
                        _ => {}
                    }
                }
                FuncKind::Projection(proj)
            }
            other => unreachable!("not a function atom: {other:?}"),
        };
        Some(Func { kind, span })
    }

    fn postfix(&mut self, pair: Pair<'_, Rule>) -> Option<Deep> {
        let mut iter = pair.into_inner();
        let primary = iter.next()?.into_inner().next()?;
        let acc = self.primary(primary)?;
        Some(self.swizzle(acc, iter.collect()))
    }

    fn swizzle(&mut self, mut acc: Deep, swizzles: Vec<Pair<'_, Rule>>) -> Deep {
        for sw in swizzles {
            let span = acc.expr.span.join(self.span(&sw));
            acc = Deep {
                expr: Expr {
                    kind: ExprKind::Swizzle {
                        base: Box::new(acc.expr),
                        components: sw.as_str()[1..].to_string(),
                    },
                    span,
                },
                depth: acc.depth + 1,
            };
        }
        acc
    }

    fn primary(&mut self, pair: Pair<'_, Rule>) -> Option<Deep> {
        let span = self.span(&pair);
        let leaf = |kind| Some(Deep { expr: Expr { kind, span }, depth: 1 });
        match pair.as_rule() {
            Rule::number => match pair.as_str().parse::<f64>() {
                Ok(v) if v.is_finite() => leaf(ExprKind::Number(v)),
                _ => {
                    self.errors.push(
                        Diagnostic::error(
                            "bad-number",
                            format!("number `{}` is out of range", pair.as_str()),
                            span,
                            "too large for a 64-bit float",
                        )
                        .with_help("shading values lie far inside ±1e308; check the exponent"),
                    );
                    None
                }
            },
            Rule::string => leaf(ExprKind::String(unescape(pair.as_str()))),
            Rule::name => {
                let name = self.name(pair);
                leaf(ExprKind::Name(name))
            }
            Rule::tuple => {
                let mut items = Vec::new();
                for p in pair.into_inner() {
                    items.push(self.expr(p)?);
                }
                if items.len() == 1 {
                    // `(e)` is grouping only; its span keeps the parentheses, so
                    // an operator's span covers `kd * (N·L)` to the last `)`.
                    return items.pop().map(|d| Deep { expr: Expr { span, ..d.expr }, ..d });
                }
                let depth = 1 + items.iter().map(|d| d.depth).max().unwrap_or(0);
                leaf(ExprKind::Tuple(items.into_iter().map(|d| d.expr).collect()))
                    .map(|d| Deep { depth, ..d })
            }
            other => unreachable!("not a primary: {other:?}"),
        }
    }
}

/// An operator waiting on the stack of `fold_operators`.
enum Op {
    Prefix(UnaryOp),
    Binary(BinaryOp),
    Combine(Option<Word<CombineMode>>),
    /// `?` seen, no `:` yet.
    Question,
    /// `? … :` seen: a ternary.
    QuestionColon,
}

impl Op {
    /// Binding strength (larger binds tighter) and right-associativity; the
    /// levels of `grammar/shade.pest` and of the printer's `Prec`.
    fn precedence(&self) -> (u8, bool) {
        match self {
            Op::Question | Op::QuestionColon => (1, true),
            Op::Binary(BinaryOp::Or) => (2, false),
            Op::Binary(BinaryOp::And) => (3, false),
            Op::Binary(
                BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge | BinaryOp::Eq | BinaryOp::Ne,
            ) => (4, false),
            Op::Combine(_) => (5, false),
            Op::Binary(BinaryOp::Add | BinaryOp::Sub) => (6, false),
            Op::Binary(BinaryOp::Mul | BinaryOp::Div) => (7, false),
            Op::Binary(BinaryOp::Dot) => (8, false),
            Op::Prefix(_) => (9, true),
            Op::Binary(BinaryOp::Pow) => (10, true),
        }
    }
}

fn is_keyword(rule: Rule) -> bool {
    matches!(
        rule,
        Rule::kw_target
            | Rule::kw_texture
            | Rule::kw_framebuffer
            | Rule::kw_vector
            | Rule::kw_params
            | Rule::kw_const
            | Rule::kw_uniform
            | Rule::kw_shader
            | Rule::kw_let
            | Rule::kw_in
            | Rule::semi
    )
}

fn channel_of(text: &str) -> Channel {
    match text {
        "α" | "alpha" => Channel::Alpha,
        "σ" | "stencil" => Channel::Stencil,
        _ => Channel::Depth,
    }
}

fn describe_func(rule: Rule) -> &'static str {
    match rule {
        Rule::delta => "δ (rasterization is an operation, not a table)",
        Rule::projection => "π (the projection is an operation, not a table)",
        Rule::channel => "a channel of a channel (one selector per target)",
        _ => "a value (only a named table can be assigned into)",
    }
}

fn binary_op(pair: &Pair<'_, Rule>) -> BinaryOp {
    match (pair.as_rule(), pair.as_str()) {
        (Rule::op_or, _) => BinaryOp::Or,
        (Rule::op_and, _) => BinaryOp::And,
        (Rule::op_cmp, ">=" | "≥") => BinaryOp::Ge,
        (Rule::op_cmp, "<=" | "≤") => BinaryOp::Le,
        (Rule::op_cmp, "==") => BinaryOp::Eq,
        (Rule::op_cmp, "!=" | "≠") => BinaryOp::Ne,
        (Rule::op_cmp, ">") => BinaryOp::Gt,
        (Rule::op_cmp, _) => BinaryOp::Lt,
        (Rule::op_add, _) => BinaryOp::Add,
        (Rule::op_sub, _) => BinaryOp::Sub,
        (Rule::op_mul, _) => BinaryOp::Mul,
        (Rule::op_div, _) => BinaryOp::Div,
        (Rule::op_dot, _) => BinaryOp::Dot,
        (Rule::op_pow, _) => BinaryOp::Pow,
        (other, text) => unreachable!("not a binary operator: {other:?} `{text}`"),
    }
}

fn unescape(quoted: &str) -> String {
    let inner = &quoted[1..quoted.len() - 1];
    let mut out = String::with_capacity(inner.len());
    let mut chars = inner.chars();
    while let Some(c) = chars.next() {
        if c == '\\' {
            match chars.next() {
                Some('n') => out.push('\n'),
                Some('t') => out.push('\t'),
                Some(other) => out.push(other),
                None => {}
            }
        } else {
            out.push(c);
        }
    }
    out
}

/// The help for `p(16) δ s x` (`Builder::parameters_at_use`): `param` is
/// the declared shader's first parameter (`n: scalar`) when `parser::check`
/// knows it, so the example given is the user's own declaration.
pub(super) fn parameters_help(key: &str, args: &str, param: Option<&str>) -> String {
    let value = args.trim_start_matches('(').trim_end_matches(')').trim();
    let param = param.unwrap_or("n: scalar");
    format!(
        "set the value as the parameter's default where `{key}` is declared, `shader {key}({param} = {value}) : …`, and use it as `{key} δ s x`; for two values declare two shaders (examples/GAPS.md item 6); to multiply instead, write `*`"
    )
}

/// Whether the rest of a chain, `rest`, is the shading parameters (`s x`,
/// `δ s x`, `s′ x`): what a shader is applied to.
fn on_shading_parameters(rest: &str) -> bool {
    let params = rest.trim_start_matches(['δ', ' ']).trim_start_matches("delta ").trim_start();
    params.starts_with('s') && !params.starts_with("stencil")
}

/// `δ max(0, N·L) s x`: a built-in's value in an application chain, which
/// application (right to left) would apply to `s x` — a value is not a
/// function. What was meant is a function of the shading parameters,
/// evaluated per vertex and interpolated (Pipeline Grammar, eq. (1),
/// `δ p s x`) or per fragment (eq. (4), `p δ s x`): a shader. The help
/// declares one, named `shader` (`parser::check` picks a name the program
/// does not use), and rewrites the chain with it where the chain's rest
/// is the shading parameters.
pub(super) fn builtin_in_chain(
    value: &str,
    span: Span,
    rest: &str,
    rest_span: Span,
    shader: &str,
) -> Diagnostic {
    let declare = format!("declare it as a shader, `shader {shader} : s → c = {value};`");
    let what = if value.starts_with('(') { "a parenthesized value" } else { "a built-in's value" };
    let help = if on_shading_parameters(rest) {
        format!(
            "{what} cannot be applied to what follows: application reads right to left, so this applies `{value}` to `{rest}`; to compute it from the shading parameters, {declare} and replace `{value}` by `{shader}`: `{shader} {rest}`"
        )
    } else {
        format!(
            "{what} cannot be applied to what follows: application reads right to left, so this applies `{value}` to `{rest}`; to multiply, write `*` between them; to compute it from the shading parameters, {declare} and use it as `δ {shader} s x` (per vertex, interpolated) or `{shader} δ s x` (per fragment)"
        )
    };
    Diagnostic::error(
        "value-applied",
        format!("`{value}` is a value, not a function to apply"),
        span,
        "a value",
    )
    .with_label(rest_span, "applied to this")
    .with_help(help)
}
