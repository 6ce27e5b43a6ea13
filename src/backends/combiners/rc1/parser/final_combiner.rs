//! The final combiner's part of the `!!RC1.0` reader (Kilgard 2000,
//! Section 4.2 and Appendix B.5): its operands (`r`, `unsigned(r)`,
//! `unsigned_invert(r)`, `color_sum`, `final_product`), the
//! `final_product` and `out.rgb = lerp(…) + d` statements, and the
//! `out.a` statement.

use super::*;

impl<'a> Parser<'a> {
    /// A final-combiner operand: `r`, `unsigned(r)`, `unsigned_invert(r)`,
    /// with `color_sum` and `final_product` allowed as `r`.
    fn final_operand(&mut self) -> PResult<Operand> {
        let t = self.peek();
        match t.tok {
            Tok::Minus => Err(syntax("the final combiner has no signed mappings", t.span, "negation", "the final combiner reads `r`, `unsigned(r)` or `unsigned_invert(r)`; negate in a general combiner")),
            Tok::Name(name @ ("unsigned" | "unsigned_invert")) if self.peek2().tok == Tok::LParen => {
                self.bump();
                self.bump();
                let inner = self.register_operand()?;
                let close = self.expect_token(Tok::RParen, "`)`")?;
                let mapping = if name == "unsigned" { InputMapping::UnsignedIdentity } else { InputMapping::UnsignedInvert };
                Ok(Operand { mapping, span: t.span.join(close), ..inner })
            }
            Tok::Name(name @ ("expand" | "half_bias")) => Err(syntax(format!("`{name}()` is not available in the final combiner"), t.span, "signed mapping", "the final combiner reads `r`, `unsigned(r)` or `unsigned_invert(r)`")),
            _ => self.register_operand(),
        }
    }

    fn final_input(&mut self, op: Operand, var: char, has_product: bool) -> PResult<FinalInput> {
        let (source, mapping) = op.resolve();
        let default_usage = if var == 'G' { ComponentUsage::Alpha } else { ComponentUsage::Rgb };
        let usage = op.selector.unwrap_or(default_usage);
        let source = match source {
            Source::Register(r) => FinalSource::Register(r),
            Source::FinalProduct => {
                if !has_product && matches!(var, 'A' | 'B' | 'C' | 'D') {
                    return Err(Diagnostic::error(
                        "final-product-unset",
                        "`final_product` is used but not set",
                        op.span,
                        "used here",
                    )
                    .with_help("set it before `out.rgb`: `final_product = tex0 * col0;`"));
                }
                FinalSource::EfProduct
            }
            Source::ColorSum => FinalSource::Spare0PlusSecondary,
            Source::Discard => {
                return Err(Diagnostic::error(
                    "read-discard",
                    "reading from `discard`",
                    op.span,
                    "`discard` can only be written",
                )
                .with_help("read a register such as `zero` or `spare0`"))
            }
            Source::One => unreachable_one(op.span)?,
        };
        self.state.spans.insert(Place::FinalInput(var), op.span);
        Ok(FinalInput::new(source, mapping, usage))
    }

    /// `[clamp_color_sum();] [final_product = E * F;] out.rgb = ...; out.a = G;`
    pub(super) fn final_combiner(&mut self) -> PResult<FinalCombiner> {
        let mut fc = unset_final_combiner();
        let mut clamp: Option<Span> = None;
        let mut product: Option<Span> = None;
        let mut rgb: Option<Span> = None;
        let mut alpha: Option<Span> = None;
        loop {
            let t = self.peek();
            let twice = |first: Span, what: &str| {
                Diagnostic::error("final-twice", format!("`{what}` appears twice"), t.span, "again here")
                    .with_label(first, "first here")
                    .with_help(format!("write `{what}` once"))
            };
            let late = |what: &str| {
                syntax(
                    format!("`{what}` must come before `out.rgb` and `out.a`"),
                    t.span,
                    "too late",
                    format!("move `{what}` above the `out.rgb` / `out.a` statements"),
                )
            };
            match t.tok {
                Tok::Name("clamp_color_sum") => {
                    if let Some(first) = clamp {
                        return Err(twice(first, "clamp_color_sum();"));
                    }
                    if rgb.is_some() || alpha.is_some() {
                        return Err(late("clamp_color_sum();"));
                    }
                    clamp = Some(self.call_statement(t.span)?);
                    fc.color_sum_clamp = true;
                }
                Tok::Name("final_product") if self.peek2().tok == Tok::Equals => {
                    if let Some(first) = product {
                        return Err(twice(first, "final_product"));
                    }
                    if rgb.is_some() || alpha.is_some() {
                        return Err(late("final_product = ...;"));
                    }
                    product = Some(self.final_product(&mut fc, t.span)?);
                }
                Tok::Selected("out", "rgb") => {
                    if let Some(first) = rgb {
                        return Err(twice(first, "out.rgb"));
                    }
                    self.bump();
                    self.expect_token(Tok::Equals, "`=`")?;
                    self.final_rgb(&mut fc, product.is_some())?;
                    rgb = Some(t.span.join(self.expect_token(Tok::Semi, "`;`")?));
                }
                Tok::Selected("out", "a") => {
                    if let Some(first) = alpha {
                        return Err(twice(first, "out.a"));
                    }
                    self.bump();
                    self.expect_token(Tok::Equals, "`=`")?;
                    fc.g = self.final_alpha(product.is_some())?;
                    alpha = Some(t.span.join(self.expect_token(Tok::Semi, "`;`")?));
                }
                _ => break,
            }
        }
        if rgb.is_none() && alpha.is_none() {
            return Err(self.missing_output());
        }
        self.move_color_sum_out_of_a(&mut fc);
        Ok(fc)
    }

    /// A call with no arguments, `name();`, its name at `at`: the span of
    /// the statement.
    fn call_statement(&mut self, at: Span) -> PResult<Span> {
        self.bump();
        self.expect_token(Tok::LParen, "`(`")?;
        self.expect_token(Tok::RParen, "`)`")?;
        Ok(at.join(self.expect_token(Tok::Semi, "`;`")?))
    }

    /// `final_product = E * F;` (Kilgard 2000, Table 6): E and F read ordinary
    /// registers. Returns the statement's span.
    fn final_product(&mut self, fc: &mut FinalCombiner, start: Span) -> PResult<Span> {
        self.bump();
        self.bump();
        let e = self.final_operand()?;
        self.expect_token(Tok::Star, "`*` (final_product = E * F;)")?;
        let f = self.final_operand()?;
        let span = start.join(self.expect_token(Tok::Semi, "`;`")?);
        for (op, var) in [(e, 'E'), (f, 'F')] {
            ordinary(&op, "final_product", "E and F read ordinary registers")?;
            let input = self.final_input(op, var, true)?;
            if var == 'E' {
                fc.e = input
            } else {
                fc.f = input
            }
        }
        Ok(span)
    }

    /// `out.a = G;`: the alpha of an ordinary register.
    fn final_alpha(&mut self, has_product: bool) -> PResult<FinalInput> {
        let g = self.final_operand()?;
        ordinary(&g, "final alpha", "`out.a` reads the alpha of an ordinary register")?;
        self.final_input(g, 'G', has_product)
    }

    /// Neither `out.rgb` nor `out.a`: what was found instead, with the name it resembles.
    fn missing_output(&self) -> Diagnostic {
        let t = self.peek();
        let help = match t.tok {
            Tok::Name(n) | Tok::Selected(n, _) => {
                match did_you_mean(n, ["out.rgb", "out.a", "clamp_color_sum", "final_product"]) {
                    Some(m) => format!("did you mean `{m}`?"),
                    None => "end the program with `out.rgb = ...;` and/or `out.a = ...;`".into(),
                }
            }
            _ => "end the program with `out.rgb = ...;` and/or `out.a = ...;`".into(),
        };
        syntax(
            format!("expected the final combiner (`out.rgb = ...;`), found {}", t.tok.describe()),
            t.span,
            "expected `out.rgb` or `out.a`",
            help,
        )
    }

    /// nvparse's FinalCombinerStruct::Validate: move color_sum out of A
    /// when the expression allows it.
    fn move_color_sum_out_of_a(&mut self, fc: &mut FinalCombiner) {
        let is_cs = |i: &FinalInput| i.source == FinalSource::Spare0PlusSecondary;
        let is_reg = |i: &FinalInput, m: InputMapping| {
            i.source == FinalSource::Register(Register::Zero) && i.mapping == m
        };
        if is_cs(&fc.a) && !is_cs(&fc.b) && is_reg(&fc.c, InputMapping::UnsignedIdentity) {
            std::mem::swap(&mut fc.a, &mut fc.b);
            self.swap_spans('A', 'B');
        }
        if is_cs(&fc.a)
            && is_reg(&fc.b, InputMapping::UnsignedInvert)
            && is_reg(&fc.c, InputMapping::UnsignedIdentity)
            && !is_cs(&fc.d)
        {
            std::mem::swap(&mut fc.a, &mut fc.d);
            self.swap_spans('A', 'D');
        }
    }

    fn swap_spans(&mut self, x: char, y: char) {
        let sx = self.state.spans.remove(&Place::FinalInput(x));
        let sy = self.state.spans.remove(&Place::FinalInput(y));
        if let Some(s) = sx {
            self.state.spans.insert(Place::FinalInput(y), s);
        }
        if let Some(s) = sy {
            self.state.spans.insert(Place::FinalInput(x), s);
        }
    }

    /// The right-hand side of `out.rgb =`: `lerp(A, B, C) + D`,
    /// `D + lerp(A, B, C)`, `lerp(A, B, C)`, `A * B`, `A * B + D`, `D`, `A + D`.
    fn final_rgb(&mut self, fc: &mut FinalCombiner, has_product: bool) -> PResult<()> {
        let zero = Operand {
            source: Source::Register(Register::Zero),
            selector: None,
            mapping: InputMapping::UnsignedIdentity,
            span: self.peek().span,
        };
        let one = Operand { mapping: InputMapping::UnsignedInvert, ..zero };
        let (a, b, c, d);
        if self.is_name("lerp") {
            (a, b, c) = self.lerp()?;
            d = if self.peek().tok == Tok::Plus {
                self.bump();
                self.final_operand()?
            } else {
                zero
            };
        } else {
            let first = self.final_operand()?;
            match self.peek().tok {
                Tok::Star => {
                    self.bump();
                    let second = self.final_operand()?;
                    (a, b, c) = (first, second, zero);
                    d = if self.peek().tok == Tok::Plus {
                        self.bump();
                        self.final_operand()?
                    } else {
                        zero
                    };
                }
                Tok::Plus => {
                    self.bump();
                    if self.is_name("lerp") {
                        (a, b, c) = self.lerp()?;
                        d = first;
                    } else {
                        let second = self.final_operand()?;
                        (a, b, c, d) = (first, one, zero, second);
                    }
                }
                _ => (a, b, c, d) = (zero, zero, zero, first),
            }
        }
        let is_filler = |o: &Operand| {
            o.span == zero.span && o.source == Source::Register(Register::Zero) && o.selector.is_none()
        };
        for (op, var) in [(a, 'A'), (b, 'B'), (c, 'C'), (d, 'D')] {
            let input = self.final_input(op, var, has_product)?;
            if is_filler(&op) {
                self.state.spans.remove(&Place::FinalInput(var));
            }
            match var {
                'A' => fc.a = input,
                'B' => fc.b = input,
                'C' => fc.c = input,
                _ => fc.d = input,
            }
        }
        Ok(())
    }

    fn lerp(&mut self) -> PResult<(Operand, Operand, Operand)> {
        self.bump();
        self.expect_token(Tok::LParen, "`(`")?;
        let a = self.final_operand()?;
        self.expect_token(Tok::Comma, "`,` (lerp takes three operands)")?;
        let b = self.final_operand()?;
        self.expect_token(Tok::Comma, "`,` (lerp takes three operands)")?;
        let c = self.final_operand()?;
        self.expect_token(Tok::RParen, "`)`")?;
        Ok((a, b, c))
    }
}

/// The final combiner before its statements: every input zero (RGB, and
/// alpha for G), the colour-sum clamp off until `clamp_color_sum();`.
fn unset_final_combiner() -> FinalCombiner {
    let zero_rgb = FinalInput::register(Register::Zero, ComponentUsage::Rgb);
    FinalCombiner {
        a: zero_rgb,
        b: zero_rgb,
        c: zero_rgb,
        d: zero_rgb,
        e: zero_rgb,
        f: zero_rgb,
        g: FinalInput::register(Register::Zero, ComponentUsage::Alpha),
        color_sum_clamp: false,
    }
}
