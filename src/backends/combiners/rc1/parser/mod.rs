//! A recursive-descent parser for `!!RC1.0` following nvparse's
//! `rc1.0_grammar.y` and the checks of its validator (`rc1.0_general.cpp`,
//! `rc1.0_final.cpp`, `rc1.0_combiners.cpp`), producing a `CombinerConfig`
//! plus the span of every place in it, so that validation errors point at
//! the source.

use std::collections::HashMap;

use crate::diag::{did_you_mean, Diagnostic};
use crate::span::Span;

use super::lexer::{Tok, RC1};
use super::REGISTERS;
use crate::backends::combiners::config::{
    Bias, Color, CombinerConfig, ComponentUsage, FinalCombiner, FinalInput, FinalSource, GeneralInput,
    GeneralPortion, GeneralStage, InputMapping, PortionKind, Register, Scale,
};
use crate::backends::combiners::ts1;
use crate::backends::combiners::validate::{OutputSlot, Place};
use crate::backends::readers::cursor::Cursor;
use crate::backends::readers::lex::syntax;

mod final_combiner;

/// A parsed program: the config and where each of its places came from.
#[derive(Clone, Debug)]
pub struct Parsed {
    pub config: CombinerConfig,
    pub spans: HashMap<Place, Span>,
    /// Where each stage of the `!!TS1.0` block came from.
    pub texture_shader_spans: Vec<ts1::StageSpans>,
}

impl Parsed {
    /// The span of `place` in the `!!RC1.0` text, when the reader recorded one: where a
    /// validation error is shown.
    pub fn span_of(&self, place: Place) -> Option<Span> {
        self.spans.get(&place).copied()
    }
}

/// Every name an operand can take: the registers, then `one` and `discard`.
fn register_names() -> impl Iterator<Item = &'static str> {
    REGISTERS.iter().map(|(name, _)| *name).chain(["one", "discard"])
}

/// Parses an `!!RC1.0` program (optionally preceded by a `!!TS1.0` block).
pub fn parse(text: &str) -> Result<Parsed, Diagnostic> {
    // A `!!VP1.0` vertex program after the combiners (`compile --emit
    // combiners` on geforce3) belongs to the vertex stage: the combiner
    // text ends where it begins.
    let text = text.find("\n!!VP1.").map_or(text, |at| &text[..at + 1]);
    let lead = text.len() - text.trim_start().len();
    let body = &text[lead..];
    let (texture_shader, rc_start) = if let Some(rest) = body.strip_prefix("!!TS1.0") {
        match rest.find("!!RC1.0") {
            Some(at) => (Some(ts1::parse(&rest[..at], lead + "!!TS1.0".len())?), lead + "!!TS1.0".len() + at),
            None => {
                return Err(Diagnostic::error(
                    "syntax",
                    "a `!!TS1.0` texture-shader block must be followed by an `!!RC1.0` program",
                    Span::new(lead, lead + 7),
                    "texture shader starts here",
                )
                .with_help("append the register-combiner program, starting with the line `!!RC1.0`"))
            }
        }
    } else {
        (None, lead)
    };
    if !text[rc_start..].starts_with("!!RC1.0") {
        let end = text[rc_start..].find(char::is_whitespace).map_or(text.len(), |e| rc_start + e);
        return Err(Diagnostic::error(
            "syntax",
            "expected the `!!RC1.0` header",
            Span::new(rc_start, end),
            "a register-combiner program starts with `!!RC1.0`",
        )
        .with_help(
            crate::backends::readers::comment_before_header(&text[rc_start..], &["!!TS1.0", "!!RC1.0"])
                .unwrap_or_else(|| "put `!!RC1.0` on the first line".into()),
        ));
    }
    let start = rc_start + "!!RC1.0".len();
    let mut parser = Parser::new(&text[start..], start, &RC1, Rc1 { spans: HashMap::new() })?;
    let mut config = parser.program()?;
    let texture_shader_spans = texture_shader.as_ref().map(|t| t.spans.clone()).unwrap_or_default();
    config.texture_shader = texture_shader.map(|t| t.program);
    Ok(Parsed { config, spans: parser.state.spans, texture_shader_spans })
}

/// An operand as written: a register (or a pseudo-register) with its mapping.
#[derive(Clone, Copy, Debug)]
struct Operand {
    source: Source,
    selector: Option<ComponentUsage>,
    mapping: InputMapping,
    span: Span,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Source {
    Register(Register),
    One,
    Discard,
    FinalProduct,
    ColorSum,
}

impl Operand {
    /// nvparse's `MappedRegisterStruct::Init`: `one` is `zero` with the
    /// mapping that turns 0 into the value `one` would have given.
    fn resolve(self) -> (Source, InputMapping) {
        if self.source != Source::One {
            return (self.source, self.mapping);
        }
        use InputMapping::*;
        let mapping = match self.mapping {
            UnsignedIdentity => UnsignedInvert,
            UnsignedInvert => UnsignedIdentity,
            ExpandNormal => UnsignedInvert,
            ExpandNegate => ExpandNormal,
            HalfBiasNormal => HalfBiasNegate,
            HalfBiasNegate => HalfBiasNormal,
            SignedIdentity => UnsignedInvert,
            SignedNegate => ExpandNormal,
        };
        (Source::Register(Register::Zero), mapping)
    }
}

enum Op {
    Product { dest: (Option<Register>, Span), a: Operand, b: Operand, dot: bool, span: Span },
    Sum { dest: (Option<Register>, Span), mux: bool, span: Span },
}

/// The `!!RC1.0` grammar, walked on the shared cursor, keeping where each
/// place of the config was written.
struct Rc1 {
    spans: HashMap<Place, Span>,
}

type Parser<'a> = Cursor<'a, Rc1>;

type PResult<T> = Result<T, Diagnostic>;

impl<'a> Parser<'a> {
    /// `expect` with the statement's help: `;` ends every statement.
    fn expect_token(&mut self, want: Tok<'static>, what: &str) -> PResult<Span> {
        let help = if want == Tok::Semi {
            "end every statement with `;`".into()
        } else {
            format!("write {what} here")
        };
        self.expect(want, what, &help)
    }

    fn is_name(&self, name: &str) -> bool {
        matches!(self.peek().tok, Tok::Name(n) if n == name)
    }

    fn program(&mut self) -> PResult<CombinerConfig> {
        let mut config = CombinerConfig { general: Vec::new(), ..CombinerConfig::default() };
        // Global constants.
        while let Tok::Name(n @ ("const0" | "const1")) = self.peek().tok {
            if self.peek2().tok != Tok::Equals {
                break;
            }
            let idx = u8::from(n == "const1");
            let (color, span) = self.constant()?;
            let slot = if idx == 0 { &mut config.constant0 } else { &mut config.constant1 };
            if slot.is_some() {
                let first = self.state.spans[&Place::GlobalConstant(idx)];
                return Err(Diagnostic::error(
                    "constant-twice",
                    format!("global constant `{n}` set twice"),
                    span,
                    "set again here",
                )
                .with_label(first, "first set here")
                .with_help("set each constant colour once"));
            }
            *slot = Some(color);
            self.state.spans.insert(Place::GlobalConstant(idx), span);
        }
        // General combiners.
        while self.peek().tok == Tok::LBrace {
            let stage_idx = config.general.len();
            let stage = self.stage(stage_idx)?;
            config.general.push(stage);
        }
        config.final_combiner = self.final_combiner()?;
        let t = self.peek();
        if !t.tok.is_eof() {
            let help = match t.tok {
                Tok::LBrace => "general combiners come before the final combiner statements",
                Tok::Name("const0" | "const1") | Tok::Selected("const0" | "const1", _) => {
                    "global constants come first, before any general combiner"
                }
                _ => "the program ends after `out.rgb` and `out.a`",
            };
            return Err(syntax(
                format!("unexpected {}", t.tok.describe()),
                t.span,
                "not expected here",
                help,
            ));
        }
        Ok(config)
    }

    fn number(&mut self) -> PResult<f32> {
        let t = self.bump();
        let (sign, t) = match t.tok {
            Tok::Minus => (-1.0, self.bump()),
            Tok::Plus => (1.0, self.bump()),
            _ => (1.0, t),
        };
        match t.tok {
            Tok::Number(x) => Ok(sign * x),
            _ => Err(syntax(
                format!("expected a number, found {}", t.tok.describe()),
                t.span,
                "expected a number",
                "constants are written `const0 = (r, g, b, a);`",
            )),
        }
    }

    /// `const0 = (r, g, b, a);`
    fn constant(&mut self) -> PResult<(Color, Span)> {
        let start = self.bump().span;
        self.expect_token(Tok::Equals, "`=`")?;
        self.expect_token(Tok::LParen, "`(`")?;
        let mut c = [0.0; 4];
        for (i, slot) in c.iter_mut().enumerate() {
            if i > 0 {
                self.expect_token(Tok::Comma, "`,` (a constant has four components)")?;
            }
            *slot = self.number()?;
        }
        self.expect_token(Tok::RParen, "`)` (a constant has four components)")?;
        let end = self.expect_token(Tok::Semi, "`;`")?;
        Ok((c, start.join(end)))
    }

    /// `{ [const0 = ...;] [const1 = ...;] rgb {...} [alpha {...}] }`
    fn stage(&mut self, s: usize) -> PResult<GeneralStage> {
        let open = self.bump().span;
        let mut stage = GeneralStage {
            rgb: GeneralPortion::discard_all(),
            alpha: GeneralPortion::discard_all(),
            constant0: None,
            constant1: None,
        };
        let mut seen: [Option<Span>; 2] = [None, None];
        loop {
            let t = self.peek();
            match t.tok {
                Tok::Name(n @ ("const0" | "const1")) if self.peek2().tok == Tok::Equals => {
                    if seen.iter().any(Option::is_some) {
                        return Err(syntax(
                            "per-stage constants come before the portions",
                            t.span,
                            "constant after a portion",
                            "move the constant to the top of the stage",
                        ));
                    }
                    self.stage_constant(s, n, &mut stage)?;
                }
                Tok::Name(n @ ("rgb" | "alpha")) => {
                    let kind = if n == "rgb" { PortionKind::Rgb } else { PortionKind::Alpha };
                    let k = kind as usize;
                    if let Some(first) = seen[k] {
                        return Err(Diagnostic::error(
                            "portion-twice",
                            format!("the {n} portion of general combiner {s} is declared twice"),
                            t.span,
                            "declared again here",
                        )
                        .with_label(first, "first declared here")
                        .with_help("a general combiner has one rgb and one alpha portion"));
                    }
                    seen[k] = Some(t.span);
                    let portion = self.portion(s, kind)?;
                    match kind {
                        PortionKind::Rgb => stage.rgb = portion,
                        PortionKind::Alpha => stage.alpha = portion,
                    }
                }
                Tok::RBrace => {
                    let close = self.bump().span;
                    if seen.iter().all(Option::is_none) {
                        return Err(syntax(
                            format!("general combiner {s} has no portion"),
                            open.join(close),
                            "empty general combiner",
                            "give it an `rgb { ... }` and/or `alpha { ... }` portion, or remove it",
                        ));
                    }
                    self.state.spans.insert(Place::Stage(s), open.join(close));
                    return Ok(stage);
                }
                _ => return Err(not_a_portion(t)),
            }
        }
    }

    /// `constN = (r, g, b, a);` inside general combiner `s`.
    fn stage_constant(&mut self, s: usize, n: &str, stage: &mut GeneralStage) -> PResult<()> {
        let idx = u8::from(n == "const1");
        let (color, span) = self.constant()?;
        let slot = if idx == 0 { &mut stage.constant0 } else { &mut stage.constant1 };
        if slot.is_some() {
            return Err(Diagnostic::error(
                "constant-twice",
                format!("local constant `{n}` set twice in general combiner {s}"),
                span,
                "set again here",
            )
            .with_help("set each constant colour once per stage"));
        }
        *slot = Some(color);
        self.state.spans.insert(Place::StageConstant(s, idx), span);
        Ok(())
    }

    fn portion(&mut self, s: usize, kind: PortionKind) -> PResult<GeneralPortion> {
        let start = self.bump().span;
        self.expect_token(Tok::LBrace, "`{`")?;
        let mut ops: Vec<Op> = Vec::new();
        let mut scale: Option<(Scale, Span)> = None;
        let mut bias: Option<(Bias, Span)> = None;
        loop {
            let t = self.peek();
            match t.tok {
                Tok::RBrace => break,
                Tok::Name(n)
                    if self.peek2().tok == Tok::LParen
                        && !matches!(n, "expand" | "half_bias" | "unsigned" | "unsigned_invert") =>
                {
                    self.scale_bias(n, t.span, &mut scale, &mut bias)?;
                }
                Tok::Name(_) | Tok::Selected(..) => {
                    if scale.is_some() || bias.is_some() {
                        return Err(syntax(
                            "the scale/bias call comes after the portion's operations",
                            t.span,
                            "operation after scale/bias",
                            "move the scale/bias call to the end of the portion",
                        ));
                    }
                    ops.push(self.op(kind)?);
                }
                _ => {
                    let help = if t.tok.is_eof() {
                        "close the portion with `}`"
                    } else {
                        "write `register = operation;` or a scale/bias call"
                    };
                    return Err(syntax(
                        format!("expected an operation or `}}`, found {}", t.tok.describe()),
                        t.span,
                        "not an operation",
                        help,
                    ));
                }
            }
        }
        let close = self.bump().span;
        self.state.spans.insert(Place::Portion(s, kind), start.join(close));
        let scale_bias_span = scale.map(|x| x.1).into_iter().chain(bias.map(|x| x.1)).reduce(Span::join);
        if let Some(span) = scale_bias_span {
            self.state.spans.insert(Place::ScaleBias(s, kind), span);
        }
        self.assemble(
            s,
            kind,
            ops,
            scale.map_or(Scale::One, |x| x.0),
            bias.map_or(Bias::Zero, |x| x.0),
            start.join(close),
        )
    }

    /// A scale/bias call `n();` at `at`, into `scale` and `bias` (each once).
    fn scale_bias(
        &mut self,
        n: &str,
        at: Span,
        scale: &mut Option<(Scale, Span)>,
        bias: &mut Option<(Bias, Span)>,
    ) -> PResult<()> {
        let (sc, bi) = scale_bias_call(n, at)?;
        self.bump();
        self.expect_token(Tok::LParen, "`(`")?;
        self.expect_token(Tok::RParen, "`)`")?;
        let span = at.join(self.expect_token(Tok::Semi, "`;`")?);
        if let Some(sc) = sc {
            if let Some((_, first)) = *scale {
                return Err(set_twice("scale", span, first));
            }
            *scale = Some((sc, span));
        }
        if let Some(bi) = bi {
            if let Some((_, first)) = *bias {
                return Err(set_twice("bias", span, first));
            }
            *bias = Some((bi, span));
        }
        Ok(())
    }

    /// Maps the portion's operations onto AB, CD and sum/mux as nvparse does.
    fn assemble(
        &mut self,
        s: usize,
        kind: PortionKind,
        ops: Vec<Op>,
        scale: Scale,
        bias: Bias,
        span: Span,
    ) -> PResult<GeneralPortion> {
        let mut p = unset_portion(kind, scale, bias);
        if ops.is_empty() {
            return Err(syntax(
                format!("the {} portion of general combiner {s} has no operation", kind.name()),
                span,
                "empty portion",
                "write e.g. `spare0 = tex0 * col0;`, or leave the portion out",
            ));
        }
        let mut products = 0;
        let mut sum_seen = false;
        for op in ops {
            match op {
                Op::Product { dest, a, b, dot, span } => {
                    if sum_seen {
                        return Err(syntax(
                            "`sum()` / `mux()` comes after the products",
                            span,
                            "product after sum/mux",
                            "write the AB and CD products first",
                        ));
                    }
                    let (a_span, b_span) = (a.span, b.span);
                    let (a, b) = (self.general_input(kind, a)?, self.general_input(kind, b)?);
                    let (slot, names) = match products {
                        0 => {
                            (p.a, p.b, p.ab_output, p.ab_dot) = (a, b, dest.0, dot);
                            (OutputSlot::Ab, ['A', 'B'])
                        }
                        1 => {
                            (p.c, p.d, p.cd_output, p.cd_dot) = (a, b, dest.0, dot);
                            (OutputSlot::Cd, ['C', 'D'])
                        }
                        _ => {
                            return Err(syntax(
                                "a portion computes at most two products (AB and CD)",
                                span,
                                "third product",
                                "split the work over another general combiner",
                            ));
                        }
                    };
                    let spans = &mut self.state.spans;
                    spans.insert(Place::Output(s, kind, slot), dest.1);
                    spans.insert(Place::Input(s, kind, names[0]), a_span);
                    spans.insert(Place::Input(s, kind, names[1]), b_span);
                    products += 1;
                }
                Op::Sum { dest, mux, span } => {
                    if sum_seen {
                        return Err(syntax(
                            "a portion has one `sum()` / `mux()` output",
                            span,
                            "second sum/mux",
                            "remove one of them",
                        ));
                    }
                    if products < 2 {
                        return Err(syntax(
                            format!("`{}()` needs both an AB and a CD product before it", if mux { "mux" } else { "sum" }),
                            span,
                            "missing a product",
                            "write two products first, e.g. `discard = tex0 * col0; discard = tex1 * col1; spare0 = sum();`",
                        ));
                    }
                    sum_seen = true;
                    p.sum_output = dest.0;
                    p.mux_sum = mux;
                    self.state.spans.insert(Place::Output(s, kind, OutputSlot::Sum), dest.1);
                }
            }
        }
        Ok(p)
    }

    fn general_input(&mut self, kind: PortionKind, op: Operand) -> PResult<GeneralInput> {
        let (source, mapping) = op.resolve();
        let usage = op.selector.unwrap_or(match kind {
            PortionKind::Rgb => ComponentUsage::Rgb,
            PortionKind::Alpha => ComponentUsage::Alpha,
        });
        match source {
            Source::Register(register) => Ok(GeneralInput::new(register, mapping, usage)),
            Source::Discard => Err(Diagnostic::error(
                "read-discard",
                "reading from `discard`",
                op.span,
                "`discard` can only be written",
            )
            .with_help("read a register such as `zero`, `spare0` or `tex0`")),
            Source::FinalProduct | Source::ColorSum => Err(Diagnostic::error(
                "final-only",
                format!(
                    "`{}` exists only in the final combiner",
                    if source == Source::ColorSum { "color_sum" } else { "final_product" }
                ),
                op.span,
                "final-combiner pseudo-register",
            )
            .with_help("compute the value in this stage from registers instead")),
            Source::One => unreachable_one(op.span),
        }
    }

    /// `dest = a . b;`, `dest = a * b;`, `dest = a;`, `dest = sum();`, `dest = mux();`
    fn op(&mut self, kind: PortionKind) -> PResult<Op> {
        let t = self.bump();
        let Some((name, selector)) = t.tok.name() else { unreachable_name(t.span)? };
        let dest = match register_by_name(name) {
            Some(Source::Register(r)) => Some(r),
            Some(Source::Discard) => None,
            Some(Source::One) => {
                return Err(Diagnostic::error(
                    "read-only-output",
                    "`one` is read-only",
                    t.span,
                    "cannot be written",
                )
                .with_help("write to spare0, spare1, or another read/write register"))
            }
            Some(Source::FinalProduct | Source::ColorSum) | None => {
                return Err(unknown_register(name, t.span, "an output register"));
            }
        };
        if let Some(sel) = selector {
            let ok = matches!((kind, sel), (PortionKind::Rgb, "rgb") | (PortionKind::Alpha, "a"));
            if !ok {
                return Err(syntax(
                    format!("the {} portion cannot write `{name}.{sel}`", kind.name()),
                    t.span,
                    "wrong component",
                    format!("write `{name}` (the {} portion writes {} components)", kind.name(), kind.name()),
                ));
            }
        }
        self.expect_token(Tok::Equals, "`=`")?;
        if let Tok::Name(f @ ("sum" | "mux")) = self.peek().tok {
            self.bump();
            self.expect_token(Tok::LParen, "`(`")?;
            self.expect_token(Tok::RParen, "`)`")?;
            let end = self.expect_token(Tok::Semi, "`;`")?;
            return Ok(Op::Sum { dest: (dest, t.span), mux: f == "mux", span: t.span.join(end) });
        }
        let a = self.general_operand()?;
        let (b, dot) = match self.peek().tok {
            Tok::Dot => {
                self.bump();
                (self.general_operand()?, true)
            }
            Tok::Star => {
                self.bump();
                (self.general_operand()?, false)
            }
            _ => (
                Operand {
                    source: Source::One,
                    selector: None,
                    mapping: InputMapping::SignedIdentity,
                    span: a.span,
                },
                false,
            ),
        };
        let end = self.expect_token(Tok::Semi, "`;`")?;
        Ok(Op::Product { dest: (dest, t.span), a, b, dot, span: t.span.join(end) })
    }

    /// A general-combiner operand: `r`, `-r`, `expand(r)`, `-expand(r)`,
    /// `half_bias(r)`, `-half_bias(r)`, `unsigned(r)`, `unsigned_invert(r)`.
    fn general_operand(&mut self) -> PResult<Operand> {
        let start = self.peek().span;
        let negate = if self.peek().tok == Tok::Minus {
            self.bump();
            true
        } else {
            false
        };
        let t = self.peek();
        let Some((name, selector)) = t.tok.name() else {
            return Err(syntax(
                format!("expected a register, found {}", t.tok.describe()),
                t.span,
                "expected a register",
                "operands are registers such as `tex0`, `col0.a`, `expand(tex1)`",
            ));
        };
        let wrapper = match name {
            "expand" => Some(if negate { InputMapping::ExpandNegate } else { InputMapping::ExpandNormal }),
            "half_bias" => {
                Some(if negate { InputMapping::HalfBiasNegate } else { InputMapping::HalfBiasNormal })
            }
            "unsigned" | "unsigned_invert" => {
                if negate {
                    return Err(syntax(
                        format!("`-{name}(...)` is not an input mapping"),
                        start.join(t.span),
                        "no such mapping",
                        "the negated mappings are `-r`, `-expand(r)` and `-half_bias(r)`",
                    ));
                }
                Some(if name == "unsigned" {
                    InputMapping::UnsignedIdentity
                } else {
                    InputMapping::UnsignedInvert
                })
            }
            _ => None,
        };
        if selector.is_some() && wrapper.is_some() {
            return Err(syntax(
                format!("`{name}` is a mapping, not a register"),
                t.span,
                "selector on a mapping",
                format!("put the selector on the register: `{name}(tex0.a)`"),
            ));
        }
        let mut op = match wrapper {
            Some(mapping) => {
                self.bump();
                self.expect_token(Tok::LParen, "`(`")?;
                let inner = self.register_operand()?;
                let close = self.expect_token(Tok::RParen, "`)`")?;
                Operand { mapping, span: start.join(close), ..inner }
            }
            None => {
                let inner = self.register_operand()?;
                Operand {
                    mapping: if negate { InputMapping::SignedNegate } else { InputMapping::SignedIdentity },
                    span: start.join(inner.span),
                    ..inner
                }
            }
        };
        if matches!(op.source, Source::FinalProduct | Source::ColorSum) {
            op.span = t.span;
        }
        Ok(op)
    }

    fn register_operand(&mut self) -> PResult<Operand> {
        let t = self.bump();
        let Some((name, selector)) = t.tok.name() else {
            return Err(syntax(
                format!("expected a register, found {}", t.tok.describe()),
                t.span,
                "expected a register",
                "registers are tex0-tex3, col0, col1, spare0, spare1, fog, const0, const1, zero, one",
            ));
        };
        let Some(source) = register_by_name(name) else {
            return Err(unknown_register(name, t.span, "a register"));
        };
        let selector = selector.map(|s| match s {
            "rgb" => ComponentUsage::Rgb,
            "a" => ComponentUsage::Alpha,
            _ => ComponentUsage::Blue,
        });
        if selector.is_some() && matches!(source, Source::FinalProduct | Source::ColorSum | Source::Discard) {
            return Err(syntax(
                format!("`{name}` takes no component selector"),
                t.span,
                "selector not allowed",
                format!("write `{name}`"),
            ));
        }
        Ok(Operand { source, selector, mapping: InputMapping::UnsignedIdentity, span: t.span })
    }
}

const SCALE_BIAS: [&str; 5] = [
    "scale_by_two",
    "scale_by_four",
    "scale_by_one_half",
    "bias_by_negative_one_half",
    "bias_by_negative_one_half_scale_by_two",
];

fn register_by_name(name: &str) -> Option<Source> {
    if let Some((_, r)) = REGISTERS.iter().find(|(n, _)| *n == name) {
        return Some(Source::Register(*r));
    }
    Some(match name {
        "one" => Source::One,
        "discard" => Source::Discard,
        "final_product" => Source::FinalProduct,
        "color_sum" => Source::ColorSum,
        _ => return None,
    })
}

fn unknown_register(name: &str, span: Span, what: &str) -> Diagnostic {
    // The paper's names (`primary`, `texture0`, ...) for the registers
    // `!!RC1.0` spells `col0`, `tex0`, ...
    let paper = Register::ALL.into_iter().find(|r| r.name() == name).map(super::register_name);
    let help = match paper.or_else(|| did_you_mean(name, register_names())) {
        Some(m) => format!("did you mean `{m}`?"),
        None => format!(
            "the registers are {}",
            register_names().map(|r| format!("`{r}`")).collect::<Vec<_>>().join(", ")
        ),
    };
    Diagnostic::error(
        "unknown-register",
        format!("unknown register `{name}`"),
        span,
        format!("expected {what}"),
    )
    .with_help(help)
}

/// A portion before its operations: every input zero read in the
/// portion's default component usage, every output discarded.
fn unset_portion(kind: PortionKind, scale: Scale, bias: Bias) -> GeneralPortion {
    let usage = match kind {
        PortionKind::Rgb => ComponentUsage::Rgb,
        PortionKind::Alpha => ComponentUsage::Alpha,
    };
    let mut p = GeneralPortion { scale, bias, ..GeneralPortion::discard_all() };
    for input in [&mut p.a, &mut p.b, &mut p.c, &mut p.d] {
        input.usage = usage;
    }
    p
}

/// The output `what` (scale or bias) set a second time in one portion.
fn set_twice(what: &str, again: Span, first: Span) -> Diagnostic {
    Diagnostic::error(
        "scale-twice",
        format!("the output {what} is set twice in this portion"),
        again,
        "set again here",
    )
    .with_label(first, "first set here")
    .with_help("a portion has one scale/bias call")
}

/// A token where a general combiner holds a portion, a constant or `}`.
fn not_a_portion(t: crate::backends::readers::lex::Token) -> Diagnostic {
    let portions = "a general combiner holds `rgb { ... }` and `alpha { ... }` portions";
    let help = match t.tok {
        Tok::Name(n) | Tok::Selected(n, _) => match did_you_mean(n, ["rgb", "alpha", "const0", "const1"]) {
            Some(m) => format!("did you mean `{m}`?"),
            None => portions.into(),
        },
        Tok::Eof(_) => "close the general combiner with `}`".into(),
        _ => portions.into(),
    };
    syntax(
        format!("expected `rgb`, `alpha` or `}}`, found {}", t.tok.describe()),
        t.span,
        "not a portion",
        help,
    )
}

fn unreachable_one<T>(span: Span) -> PResult<T> {
    Err(Diagnostic::error("internal", "internal error: unresolved `one`", span, "here"))
}

fn unreachable_name<T>(span: Span) -> PResult<T> {
    Err(Diagnostic::error("internal", "internal error: expected a name", span, "here"))
}

/// Refuses a pseudo-register (`final_product`, `color_sum`) where the
/// final combiner reads only ordinary registers (Kilgard 2000, Appendix B).
fn ordinary(op: &Operand, what: &str, help: &str) -> PResult<()> {
    if !matches!(op.source, Source::FinalProduct | Source::ColorSum) {
        return Ok(());
    }
    Err(Diagnostic::error(
        if op.source == Source::FinalProduct { "ef-product-input" } else { "color-sum-input" },
        format!("invalid input register for {what}"),
        op.span,
        "pseudo-register",
    )
    .with_help(help))
}

/// The output scale and bias of a general combiner portion named by a
/// scale/bias call (Kilgard 2000, Appendix B: `scale_by_two()`, …).
fn scale_bias_call(n: &str, span: Span) -> PResult<(Option<Scale>, Option<Bias>)> {
    Ok(match n {
        "scale_by_two" => (Some(Scale::Two), None),
        "scale_by_four" => (Some(Scale::Four), None),
        "scale_by_one_half" => (Some(Scale::OneHalf), None),
        "bias_by_negative_one_half" => (None, Some(Bias::NegativeOneHalf)),
        "bias_by_negative_one_half_scale_by_two" => (Some(Scale::Two), Some(Bias::NegativeOneHalf)),
        _ => {
            let help = match did_you_mean(n, SCALE_BIAS) {
                Some(m) => format!("did you mean `{m}()`?"),
                None => format!(
                    "the output scale/bias calls are {}",
                    SCALE_BIAS.map(|s| format!("`{s}()`")).join(", ")
                ),
            };
            return Err(syntax(format!("unknown function `{n}`"), span, "not a scale/bias call", help));
        }
    })
}
