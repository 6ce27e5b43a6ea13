//! A recursive-descent reader for the grammar of NV_vertex_program (NVIDIA
//! 2001, Section 2.14.1.2): `OP dst, src, …;` instructions up to `END`,
//! keeping the span of every operand so that [`super::validate()`] can
//! point at the register that breaks a rule.

use crate::diag::{did_you_mean, Diagnostic};
use crate::span::Span;

use super::lexer::{Tok, VP1};
use super::program::*;
use crate::backends::readers::cursor::Cursor;
use crate::backends::readers::lex::syntax;

/// Where one instruction came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InstructionSpans {
    pub opcode: Span,
    pub dst: Span,
    pub src: Vec<Span>,
}

/// A parsed program and the spans of its instructions (in order).
#[derive(Clone, Debug, PartialEq)]
pub struct Parsed {
    pub program: VertexProgram,
    pub spans: Vec<InstructionSpans>,
    /// The header, for errors about the whole program.
    pub header: Span,
}

type PResult<T> = Result<T, Diagnostic>;

fn range(
    message: impl Into<String>,
    span: Span,
    label: impl Into<String>,
    help: impl Into<String>,
) -> Diagnostic {
    Diagnostic::error("register-range", message, span, label).with_help(help)
}

/// Reads the text after the header (`base`: its byte offset in the file).
pub fn parse(text: &str, base: usize, version: Version, header: Span) -> PResult<Parsed> {
    let mut p = Parser::new(text, base, &VP1, Vp1 { version })?;
    let mut program = VertexProgram { version, ..Default::default() };
    let mut spans = Vec::new();
    loop {
        let t = p.peek();
        match t.tok {
            Tok::Name("END") => {
                p.bump();
                p.end_of_text()?;
                break;
            }
            Tok::Name("OPTION") => {
                p.option(spans.is_empty())?;
                program.position_invariant = true;
            }
            Tok::Eof(_) => {
                return Err(syntax(
                    "the program has no `END`",
                    t.span,
                    "the text ends here",
                    "a vertex program ends with `END` after its last instruction",
                ))
            }
            _ => {
                let (instruction, s) = p.instruction()?;
                program.instructions.push(instruction);
                spans.push(s);
            }
        }
    }
    Ok(Parsed { program, spans, header })
}

/// The `!!VP1.0` grammar, walked on the shared cursor; the version decides
/// what the few differences allow.
struct Vp1 {
    version: Version,
}

type Parser<'a> = Cursor<'a, Vp1>;

impl<'a> Parser<'a> {
    /// Nothing but blanks and comments may follow `END` (the grammar's
    /// program ends there; Mesa's and NVIDIA's readers refuse more).
    fn end_of_text(&mut self) -> PResult<()> {
        let t = self.peek();
        if t.tok.is_eof() {
            return Ok(());
        }
        Err(syntax(
            format!("{} after `END`", t.tok.describe()),
            t.span,
            "the program ended at `END`",
            "remove the text after `END`, or make it a `#` comment",
        ))
    }

    /// `OPTION NV_position_invariant;`: NV_vertex_program1_1's one option,
    /// only in `!!VP1.1` and only before the first instruction.
    fn option(&mut self, first: bool) -> PResult<()> {
        let t = self.bump();
        if self.state.version != Version::V11 {
            return Err(syntax(
                format!("`OPTION` is not part of `{}`", self.state.version.header()),
                t.span,
                "an NV_vertex_program1_1 statement",
                "`OPTION NV_position_invariant;` needs the `!!VP1.1` header (NV_vertex_program1_1)",
            ));
        }
        if !first {
            return Err(syntax(
                "`OPTION` after an instruction",
                t.span,
                "options come first",
                "move `OPTION NV_position_invariant;` before the first instruction",
            ));
        }
        self.expect_name("NV_position_invariant", "the only option is `NV_position_invariant`")?;
        self.expect(Tok::Semi, "`;`", "end the option with `;`")?;
        Ok(())
    }

    fn expect_name(&mut self, name: &str, help: &str) -> PResult<Span> {
        let t = self.peek();
        if t.tok == Tok::Name(name) {
            self.bump();
            return Ok(t.span);
        }
        Err(syntax(
            format!("expected `{name}`, found {}", t.tok.describe()),
            t.span,
            format!("expected `{name}`"),
            help,
        ))
    }

    fn instruction(&mut self) -> PResult<(Instruction, InstructionSpans)> {
        let t = self.bump();
        let Tok::Name(name) = t.tok else {
            return Err(syntax(
                format!("expected an instruction, found {}", t.tok.describe()),
                t.span,
                "expected an instruction such as `MOV`",
                "each instruction is `OPCODE destination, sources;`, and the program ends with `END`",
            ));
        };
        let op = Opcode::from_name(name).ok_or_else(|| unknown_opcode(name, t.span))?;
        let usage = usage(op);
        let (dst, dst_span) = self.destination(op, &usage)?;
        let mut src = Vec::new();
        let mut src_spans = Vec::new();
        for _ in 0..op.sources() {
            self.expect(
                Tok::Comma,
                "`,`",
                &format!("{} takes {} operands: `{usage}`", op.name(), op.sources() + 1),
            )?;
            let (s, span) = self.source(op, &usage)?;
            src.push(s);
            src_spans.push(span);
        }
        self.expect(Tok::Semi, "`;`", &format!("end the instruction with `;`: `{usage}`"))?;
        Ok((Instruction { op, dst, src }, InstructionSpans { opcode: t.span, dst: dst_span, src: src_spans }))
    }

    fn index(&mut self, what: &str, help: &str) -> PResult<(u32, Span)> {
        let t = self.bump();
        match t.tok {
            Tok::Int(n) => Ok((n, t.span)),
            other => Err(syntax(
                format!("expected {what}, found {}", other.describe()),
                t.span,
                format!("expected {what}"),
                help,
            )),
        }
    }

    fn destination(&mut self, op: Opcode, usage: &str) -> PResult<(Dest, Span)> {
        let t = self.bump();
        let start = t.span;
        let reg = match t.tok {
            Tok::Name("A0") => {
                self.expect(Tok::Dot, "`.x`", "the address register is written as `A0.x`")?;
                self.expect_name("x", "the address register has one component, `A0.x`")?;
                if op != Opcode::Arl {
                    return Err(syntax(
                        format!("{} cannot write the address register", op.name()),
                        start.join(self.prev_end()),
                        "only ARL writes `A0.x`",
                        "load the address register with `ARL A0.x, <scalar>;`",
                    ));
                }
                return Ok((Dest { reg: DstReg::Address, mask: 1 }, start.join(self.prev_end())));
            }
            Tok::Name("o") if self.state.version.is_state_program() => {
                return Err(Diagnostic::error(
                    "state-program-result",
                    "a vertex state program cannot write a result register",
                    t.span,
                    "`!!VSP1.0` has no vertex results",
                )
                .with_help(
                    "a vertex state program writes program parameters `c[0]`..`c[95]` (and temporaries)",
                ))
            }
            Tok::Name("o") => self.result_register()?,
            Tok::Name(name) if temporary(name).is_some() => DstReg::Temporary(self.temp_index(name, t.span)?),
            Tok::Name("c") if self.state.version.is_state_program() => self.written_parameter(start)?,
            Tok::Name("v") | Tok::Name("c") => {
                let kind = if t.tok == Tok::Name("v") { "vertex attribute" } else { "program parameter" };
                return Err(Diagnostic::error(
                    "read-only-register",
                    format!("a vertex program cannot write a {kind} register"),
                    t.span,
                    "read-only here",
                )
                .with_help("write a temporary `R0`..`R11` or a result register `o[…]`"));
            }
            other => {
                return Err(syntax(
                    format!("expected a destination register, found {}", other.describe()),
                    t.span,
                    "expected `R0`..`R11`, `o[…]` or `A0.x`",
                    format!("write `{usage}`"),
                ))
            }
        };
        if op == Opcode::Arl {
            return Err(syntax(
                "ARL writes the address register",
                start,
                "expected `A0.x`",
                "write `ARL A0.x, <scalar>;`",
            ));
        }
        let mask = self.mask()?;
        Ok((Dest { reg, mask }, start.join(self.prev_end())))
    }

    /// `o[NAME]`, the result register a vertex program writes.
    fn result_register(&mut self) -> PResult<DstReg> {
        self.expect(Tok::LBracket, "`[`", "a result register is written `o[HPOS]`, `o[COL0]`, `o[TEX0]` …")?;
        let n = self.bump();
        let out = match n.tok {
            Tok::Name(name) => OUTPUT_NAMES.iter().position(|o| *o == name),
            _ => None,
        };
        let Some(k) = out else {
            let hint = match n.tok {
                Tok::Name(name) => {
                    did_you_mean(name, OUTPUT_NAMES).map(|s| format!("did you mean `o[{s}]`? "))
                }
                _ => None,
            };
            return Err(syntax(
                format!("no result register `o[{}]`", n.tok.describe().trim_matches('`')),
                n.span,
                "not a result register",
                format!("{}the result registers are {}", hint.unwrap_or_default(), OUTPUT_NAMES.join(", ")),
            ));
        };
        self.expect(Tok::RBracket, "`]`", "close the register with `]`")?;
        Ok(DstReg::Output(Output(k as u8)))
    }

    /// The `c[n]` a vertex state program writes: a number, not `A0.x`.
    fn written_parameter(&mut self, start: Span) -> PResult<DstReg> {
        match self.parameter()? {
            SrcReg::Parameter(k) => Ok(DstReg::Parameter(k)),
            _ => Err(syntax(
                "a vertex state program writes a parameter register by its number",
                start.join(self.prev_end()),
                "relative addressing is for reading",
                "write `c[0]`..`c[95]`",
            )),
        }
    }

    fn temp_index(&mut self, name: &str, span: Span) -> PResult<u8> {
        match temporary(name) {
            Some(k) if (k as usize) < TEMPORARIES => Ok(k as u8),
            Some(12) => Err(range(
                "no temporary register `R12`",
                span,
                "out of range",
                "NV_vertex_program has 12 temporaries, `R0`..`R11`; `R12` is the Xbox's (NV2A) name of the position result, which NV_vertex_program reads nowhere: compute the position in a temporary and write it to `o[HPOS]`",
            )),
            _ => Err(range(
                format!("no temporary register `{name}`"),
                span,
                "out of range",
                format!("a vertex program has {TEMPORARIES} temporaries, `R0`..`R11`"),
            )),
        }
    }

    fn mask(&mut self) -> PResult<u8> {
        if self.peek().tok != Tok::Dot {
            return Ok(Dest::ALL);
        }
        self.bump();
        let t = self.bump();
        let Tok::Name(letters) = t.tok else {
            return Err(syntax(
                format!("expected a write mask, found {}", t.tok.describe()),
                t.span,
                "expected a mask",
                "write a mask such as `.xyz`",
            ));
        };
        let mut mask = 0u8;
        let mut last = -1i32;
        for ch in letters.chars() {
            let k = component(ch).map(i32::from).filter(|&k| k > last);
            let Some(k) = k else {
                return Err(syntax(
                    format!("`.{letters}` is not a write mask"),
                    t.span,
                    "not a mask",
                    "a write mask names components among x, y, z, w once each, in that order (`.xzw`)",
                ));
            };
            last = k;
            mask |= 1 << k;
        }
        Ok(mask)
    }

    fn source(&mut self, op: Opcode, usage: &str) -> PResult<(Source, Span)> {
        let first = self.peek().span;
        let negate = self.peek().tok == Tok::Minus;
        if negate {
            self.bump();
        }
        let reg = self.source_register(usage)?;
        let swizzle_at = self.peek().span;
        let swizzle = self.swizzle()?;
        let span = first.join(self.prev_end());
        if op.shape() == Shape::Scalar && swizzle.is_none_or(|s| s.iter().any(|&c| c != s[0])) {
            return Err(syntax(
                format!("{} reads a scalar: the operand needs one component", op.name()),
                if swizzle.is_some() { swizzle_at } else { span },
                "expected a component such as `.x`",
                format!("name the component it reads: `{usage}`"),
            ));
        }
        Ok((Source { negate, reg, swizzle: swizzle.unwrap_or(Source::IDENTITY) }, span))
    }

    fn swizzle(&mut self) -> PResult<Option<[u8; 4]>> {
        if self.peek().tok != Tok::Dot {
            return Ok(None);
        }
        self.bump();
        let t = self.bump();
        let Tok::Name(letters) = t.tok else {
            return Err(syntax(
                format!("expected a swizzle, found {}", t.tok.describe()),
                t.span,
                "expected a swizzle",
                "write a swizzle such as `.x` or `.yzxw`",
            ));
        };
        let comps: Option<Vec<u8>> = letters.chars().map(component).collect();
        match comps {
            Some(c) if c.len() == 1 => Ok(Some([c[0]; 4])),
            Some(c) if c.len() == 4 => Ok(Some([c[0], c[1], c[2], c[3]])),
            _ => Err(syntax(
                format!("`.{letters}` is not a swizzle"),
                t.span,
                "not a swizzle",
                "a source swizzle has one component (`.x`, replicated) or four (`.xyzw`), each of x, y, z, w",
            )),
        }
    }

    fn source_register(&mut self, usage: &str) -> PResult<SrcReg> {
        let t = self.bump();
        match t.tok {
            Tok::Name("v") => {
                self.expect(
                    Tok::LBracket,
                    "`[`",
                    "an attribute register is read as `v[0]`..`v[15]` or `v[OPOS]`",
                )?;
                let n = self.bump();
                let k = match n.tok {
                    Tok::Int(k) if (k as usize) < ATTRIBUTES => k as u8,
                    Tok::Int(k) => {
                        return Err(range(
                            format!("no vertex attribute register `v[{k}]`"),
                            n.span,
                            "out of range",
                            "the attribute registers are `v[0]`..`v[15]`",
                        ))
                    }
                    Tok::Name(name) => ATTRIBUTE_NAMES
                        .iter()
                        .find(|(a, _)| *a == name)
                        .map(|(_, k)| *k)
                        .ok_or_else(|| {
                            let names: Vec<&str> = ATTRIBUTE_NAMES.iter().map(|(a, _)| *a).collect();
                            let hint = did_you_mean(name, names.iter().copied())
                                .map(|s| format!("did you mean `v[{s}]`? "))
                                .unwrap_or_default();
                            syntax(
                                format!("no vertex attribute named `{name}`"),
                                n.span,
                                "not an attribute name",
                                format!("{hint}the names are {}, or write a number 0..15", names.join(", ")),
                            )
                        })?,
                    other => {
                        return Err(syntax(
                            format!("expected an attribute number, found {}", other.describe()),
                            n.span,
                            "expected 0..15 or a name",
                            "write `v[0]`..`v[15]` or `v[OPOS]`",
                        ))
                    }
                };
                self.expect(Tok::RBracket, "`]`", "close the register with `]`")?;
                Ok(SrcReg::Attribute(k))
            }
            Tok::Name("c") => self.parameter(),
            Tok::Name(name) if temporary(name).is_some() => {
                Ok(SrcReg::Temporary(self.temp_index(name, t.span)?))
            }
            Tok::Name("o") => Err(Diagnostic::error(
                "write-only-register",
                "a vertex program cannot read a result register",
                t.span,
                "write-only",
            )
            .with_help("compute the value in a temporary `R0`..`R11`, read that, and move it to the result")),
            Tok::Name("A0") => Err(syntax(
                "the address register is read only inside `c[A0.x + k]`",
                t.span,
                "not a source",
                "index a parameter with it: `c[A0.x + 4]`",
            )),
            other => Err(syntax(
                format!("expected a source register, found {}", other.describe()),
                t.span,
                "expected `v[…]`, `c[…]` or `R0`..`R11`",
                format!("write `{usage}`"),
            )),
        }
    }

    fn parameter(&mut self) -> PResult<SrcReg> {
        self.expect(
            Tok::LBracket,
            "`[`",
            "a parameter register is read as `c[0]`..`c[95]` or `c[A0.x + k]`",
        )?;
        let t = self.bump();
        let reg = match t.tok {
            Tok::Int(k) if (k as usize) < PARAMETERS => SrcReg::Parameter(k as u8),
            Tok::Int(k) => {
                return Err(range(
                    format!("no program parameter register `c[{k}]`"),
                    t.span,
                    "out of range",
                    "the parameter registers are `c[0]`..`c[95]`",
                ))
            }
            Tok::Name("A0") => {
                self.expect(Tok::Dot, "`.x`", "the address register is read as `A0.x`")?;
                self.expect_name("x", "the address register has one component, `A0.x`")?;
                let sign = match self.peek().tok {
                    Tok::Plus => 1,
                    Tok::Minus => -1,
                    _ => 0,
                };
                let mut offset = 0i64;
                if sign != 0 {
                    self.bump();
                    let (k, span) = self.index("an offset", "write `c[A0.x + 4]` or `c[A0.x - 2]`")?;
                    offset = sign * i64::from(k);
                    if !RELATIVE_OFFSETS.contains(&(offset.clamp(-1000, 1000) as i32)) {
                        return Err(range(
                            format!("the relative offset {offset} is out of range"),
                            span,
                            "out of range",
                            "a relative offset is −64..63 (`c[A0.x - 64]` .. `c[A0.x + 63]`)",
                        ));
                    }
                }
                SrcReg::Relative(offset as i8)
            }
            other => {
                return Err(syntax(
                    format!("expected a parameter number, found {}", other.describe()),
                    t.span,
                    "expected 0..95 or `A0.x`",
                    "write `c[0]`..`c[95]` or `c[A0.x + k]`",
                ))
            }
        };
        self.expect(Tok::RBracket, "`]`", "close the register with `]`")?;
        Ok(reg)
    }
}

fn temporary(name: &str) -> Option<u32> {
    let digits = name.strip_prefix('R')?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) || digits.len() > 3 {
        return None;
    }
    digits.parse().ok()
}

fn component(ch: char) -> Option<u8> {
    match ch {
        'x' => Some(0),
        'y' => Some(1),
        'z' => Some(2),
        'w' => Some(3),
        _ => None,
    }
}

fn usage(op: Opcode) -> String {
    let srcs = match op.shape() {
        Shape::Scalar => vec!["<scalar>.x"],
        Shape::Vector(n) => vec!["<source>"; n],
    };
    let dst = if op == Opcode::Arl { "A0.x" } else { "<destination>" };
    format!("{} {dst}, {};", op.name(), srcs.join(", "))
}

fn unknown_opcode(name: &str, span: Span) -> Diagnostic {
    let upper = name.to_ascii_uppercase();
    let hint = if Opcode::from_name(&upper).is_some() {
        format!("instructions are upper case: `{upper}`")
    } else if let Some(s) = did_you_mean(name, Opcode::ALL.iter().map(|o| o.name())) {
        format!("did you mean `{s}`?")
    } else {
        let all: Vec<&str> = Opcode::ALL[..17].iter().map(|o| o.name()).collect();
        format!("the instructions are {}", all.join(", "))
    };
    syntax(format!("unknown instruction `{name}`"), span, "not an NV_vertex_program instruction", hint)
}
