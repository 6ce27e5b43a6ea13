//! A recursive-descent parser for `!!TS1.0` after nvparse's
//! `ts1.0_grammar.y`: one `instruction(arguments);` per texture unit, with
//! the span of each instruction and of the stage it reads, so that
//! [`super::validate()`] can point at the source.

use crate::diag::{did_you_mean, Diagnostic};
use crate::span::Span;

use super::lexer::{Tok, TS1};
use super::program::{CullCondition, DotFamily, DotMapping, Operation, TextureShader};
use crate::backends::readers::cursor::Cursor;
use crate::backends::readers::lex::syntax;

/// Where one stage came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StageSpans {
    /// The instruction name.
    pub name: Span,
    /// The `texN` argument of a dependent stage.
    pub previous: Option<Span>,
    /// The whole instruction, name to `;`.
    pub whole: Span,
}

/// A parsed program and the spans of its stages (in order).
#[derive(Clone, Debug, PartialEq)]
pub struct Parsed {
    pub program: TextureShader,
    pub spans: Vec<StageSpans>,
}

/// Every instruction nvparse knows, for "did you mean" help.
pub fn instruction_names() -> Vec<String> {
    let mut names: Vec<String> = [
        "nop",
        "texture_1d",
        "texture_2d",
        "texture_rectangle",
        "texture_3d",
        "texture_cube_map",
        "cull_fragment",
        "pass_through",
        "offset_2d",
        "offset_2d_scale",
        "offset_rectangle",
        "offset_rectangle_scale",
        "dependent_ar",
        "dependent_gb",
    ]
    .map(String::from)
    .to_vec();
    for family in DotFamily::ALL {
        for k in 1..=family.stages() {
            names.push(format!("dot_product_{}_{k}of{}", family.stem(), family.stages()));
        }
    }
    names
}

/// Parses the text after `!!TS1.0`; `base` is its byte offset in the file.
pub fn parse(text: &str, base: usize) -> Result<Parsed, Diagnostic> {
    let mut p = Parser::new(text, base, &TS1, Ts1)?;
    let mut program = TextureShader::default();
    let mut spans = Vec::new();
    while !p.peek().tok.is_eof() {
        let (op, stage) = p.instruction()?;
        program.stages.push(op);
        spans.push(stage);
    }
    Ok(Parsed { program, spans })
}

/// The `!!TS1.0` grammar, walked on the shared cursor.
struct Ts1;

type Parser<'a> = Cursor<'a, Ts1>;

type PResult<T> = Result<T, Diagnostic>;

/// What an instruction name stands for, before its arguments are read.
enum Kind {
    Plain(Operation),
    Cull,
    Offset { rectangle: bool, scale: bool },
    Dependent { green_blue: bool },
    Dot { family: DotFamily, step: u8 },
}

fn kind_of(name: &str) -> Option<Kind> {
    let plain = match name {
        "nop" => Some(Operation::Nop),
        "texture_1d" => Some(Operation::Texture1d),
        "texture_2d" => Some(Operation::Texture2d),
        "texture_rectangle" => Some(Operation::TextureRectangle),
        "texture_3d" => Some(Operation::Texture3d),
        "texture_cube_map" => Some(Operation::TextureCubeMap),
        "pass_through" => Some(Operation::PassThrough),
        _ => None,
    };
    if let Some(op) = plain {
        return Some(Kind::Plain(op));
    }
    match name {
        "cull_fragment" => return Some(Kind::Cull),
        "offset_2d" => return Some(Kind::Offset { rectangle: false, scale: false }),
        "offset_2d_scale" => return Some(Kind::Offset { rectangle: false, scale: true }),
        "offset_rectangle" => return Some(Kind::Offset { rectangle: true, scale: false }),
        "offset_rectangle_scale" => return Some(Kind::Offset { rectangle: true, scale: true }),
        "dependent_ar" => return Some(Kind::Dependent { green_blue: false }),
        "dependent_gb" => return Some(Kind::Dependent { green_blue: true }),
        _ => {}
    }
    let rest = name.strip_prefix("dot_product_")?;
    DotFamily::ALL.into_iter().find_map(|family| {
        let n = family.stages();
        let step = rest.strip_prefix(family.stem())?.strip_prefix('_')?.strip_suffix(&format!("of{n}"))?;
        let k: u8 = step.parse().ok()?;
        (1..=n).contains(&k).then(|| Kind::Dot { family, step: k - 1 })
    })
}

impl<'a> Parser<'a> {
    fn instruction(&mut self) -> PResult<(Operation, StageSpans)> {
        let t = self.bump();
        let Tok::Name(name) = t.tok else {
            return Err(syntax(
                format!("expected an instruction, found {}", t.tok.describe()),
                t.span,
                "expected an instruction name",
                "each texture unit takes one instruction such as `texture_2d();`",
            ));
        };
        let kind = kind_of(name).ok_or_else(|| unknown_instruction(name, t.span))?;
        let usage = usage(&kind);
        self.expect(Tok::LParen, "`(`", &format!("write the arguments in parentheses: `{usage}`"))?;
        let mut previous = None;
        let op = match kind {
            Kind::Plain(op) => op,
            Kind::Cull => Operation::CullFragment(self.conditions(&usage)?),
            Kind::Offset { rectangle, scale } => {
                let (unit, span) = self.texture(&usage)?;
                previous = Some(span);
                let matrix = [0, 1, 2, 3].map(|_| 0.0);
                let mut matrix = matrix;
                for m in &mut matrix {
                    *m = self.comma_number(&usage)?;
                }
                let scale =
                    if scale { Some((self.comma_number(&usage)?, self.comma_number(&usage)?)) } else { None };
                Operation::Offset { rectangle, previous: unit, matrix, scale }
            }
            Kind::Dependent { green_blue } => {
                let (unit, span) = self.texture(&usage)?;
                previous = Some(span);
                Operation::Dependent { green_blue, previous: unit }
            }
            Kind::Dot { family, step } => {
                let (unit, mapping, span) = self.mapped_texture(&usage)?;
                previous = Some(span);
                let eye = if step == 0 && family.has_const_eye() {
                    Some([self.comma_number(&usage)?, self.comma_number(&usage)?, self.comma_number(&usage)?])
                } else {
                    None
                };
                Operation::DotProduct { family, step, previous: unit, mapping, eye }
            }
        };
        self.close(&usage)?;
        let end = self.expect(Tok::Semi, "`;`", "end every instruction with `;`")?;
        Ok((op, StageSpans { name: t.span, previous, whole: t.span.join(end) }))
    }

    /// The closing `)`, or an error saying the instruction takes no more arguments.
    fn close(&mut self, usage: &str) -> PResult<()> {
        let t = self.peek();
        if t.tok == Tok::RParen {
            self.bump();
            return Ok(());
        }
        let message = if t.tok == Tok::Comma {
            format!("too many arguments: expected `)`, found {}", t.tok.describe())
        } else {
            format!("expected `)`, found {}", t.tok.describe())
        };
        Err(syntax(message, t.span, "expected `)`", format!("the instruction is written `{usage}`")))
    }

    fn comma_number(&mut self, usage: &str) -> PResult<f32> {
        let t = self.peek();
        if t.tok == Tok::RParen {
            return Err(syntax(
                "too few arguments",
                t.span,
                "more arguments expected before `)`",
                format!("the instruction is written `{usage}`"),
            ));
        }
        self.expect(Tok::Comma, "`,`", &format!("the instruction is written `{usage}`"))?;
        let t = self.bump();
        match t.tok {
            Tok::Number(x) => Ok(x),
            _ => Err(syntax(
                format!("expected a number, found {}", t.tok.describe()),
                t.span,
                "expected a number",
                format!("the instruction is written `{usage}`"),
            )),
        }
    }

    /// `tex0`, `tex1` or `tex2`: an earlier texture unit.
    fn texture(&mut self, usage: &str) -> PResult<(u8, Span)> {
        let t = self.bump();
        let unit = match t.tok {
            Tok::Name("tex0") => 0,
            Tok::Name("tex1") => 1,
            Tok::Name("tex2") => 2,
            Tok::Name("tex3") => {
                return Err(Diagnostic::error(
                    "syntax",
                    "`tex3` cannot be read by a texture shader stage",
                    t.span,
                    "unit 3 is the last stage",
                )
                .with_help("a dependent stage reads an earlier unit: `tex0`, `tex1` or `tex2`"))
            }
            _ => {
                return Err(syntax(
                    format!("expected `tex0`, `tex1` or `tex2`, found {}", t.tok.describe()),
                    t.span,
                    "expected the unit this stage reads",
                    format!("the instruction is written `{usage}`"),
                ))
            }
        };
        Ok((unit, t.span))
    }

    /// `texN` or `expand(texN)`.
    fn mapped_texture(&mut self, usage: &str) -> PResult<(u8, DotMapping, Span)> {
        if self.peek().tok == Tok::Name("expand") {
            let start = self.bump().span;
            self.expect(Tok::LParen, "`(`", "write `expand(tex0)`")?;
            let (unit, _) = self.texture(usage)?;
            let end = self.expect(Tok::RParen, "`)`", "write `expand(tex0)`")?;
            return Ok((unit, DotMapping::ExpandNormal, start.join(end)));
        }
        let (unit, span) = self.texture(usage)?;
        Ok((unit, DotMapping::UnsignedIdentity, span))
    }

    fn conditions(&mut self, usage: &str) -> PResult<[CullCondition; 4]> {
        let mut out = [CullCondition::GequalToZero; 4];
        for (k, slot) in out.iter_mut().enumerate() {
            if k > 0 {
                if self.peek().tok == Tok::RParen {
                    return Err(syntax(
                        "too few arguments: `cull_fragment` tests all four coordinates s, t, r, q",
                        self.peek().span,
                        "more arguments expected before `)`",
                        format!("the instruction is written `{usage}`"),
                    ));
                }
                self.expect(Tok::Comma, "`,`", &format!("the instruction is written `{usage}`"))?;
            }
            let t = self.bump();
            *slot = match t.tok {
                Tok::Name("GEQUAL_TO_ZERO") => CullCondition::GequalToZero,
                Tok::Name("LESS_THAN_ZERO") => CullCondition::LessThanZero,
                _ => return Err(syntax(
                    format!("expected `GEQUAL_TO_ZERO` or `LESS_THAN_ZERO`, found {}", t.tok.describe()),
                    t.span,
                    "expected a cull condition",
                    "each of s, t, r, q keeps the fragment where it is `GEQUAL_TO_ZERO` or `LESS_THAN_ZERO`",
                )),
            };
        }
        Ok(out)
    }
}

/// How an instruction is written, for help lines.
fn usage(kind: &Kind) -> String {
    match kind {
        Kind::Plain(op) => format!("{}();", op.name()),
        Kind::Cull => "cull_fragment(GEQUAL_TO_ZERO, GEQUAL_TO_ZERO, LESS_THAN_ZERO, GEQUAL_TO_ZERO);".into(),
        Kind::Offset { rectangle, scale } => {
            let name = Operation::Offset {
                rectangle: *rectangle,
                previous: 0,
                matrix: [0.0; 4],
                scale: scale.then_some((0.0, 0.0)),
            }
            .name();
            if *scale {
                format!("{name}(tex0, m0, m1, m2, m3, scale, bias);")
            } else {
                format!("{name}(tex0, m0, m1, m2, m3);")
            }
        }
        Kind::Dependent { green_blue } => {
            format!("{}(tex0);", if *green_blue { "dependent_gb" } else { "dependent_ar" })
        }
        Kind::Dot { family, step } => {
            let name = format!("dot_product_{}_{}of{}", family.stem(), step + 1, family.stages());
            if *step == 0 && family.has_const_eye() {
                format!("{name}(expand(tex0), eye_x, eye_y, eye_z);")
            } else {
                format!("{name}(expand(tex0));")
            }
        }
    }
}

fn unknown_instruction(name: &str, span: Span) -> Diagnostic {
    let names = instruction_names();
    let help = match did_you_mean(name, names.iter().map(String::as_str)) {
        Some(best) => format!("did you mean `{best}`?"),
        None => "the instructions are nop, texture_1d/2d/rectangle/3d/cube_map, cull_fragment, pass_through, offset_2d(_scale), offset_rectangle(_scale), dependent_ar/gb and the dot_product_* families".into(),
    };
    Diagnostic::error(
        "syntax",
        format!("unknown texture-shader instruction `{name}`"),
        span,
        "not a !!TS1.0 instruction",
    )
    .with_help(help)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_instruction_name_has_a_kind_and_a_usage_that_parses() {
        for name in instruction_names() {
            let kind = kind_of(&name).unwrap_or_else(|| panic!("{name}"));
            // The usage line a help message shows is a valid instruction once
            // its placeholders are numbers.
            let mut text = usage(&kind);
            for placeholder in
                [", m0", ", m1", ", m2", ", m3", ", scale", ", bias", ", eye_x", ", eye_y", ", eye_z"]
            {
                text = text.replace(placeholder, ", 1");
            }
            let parsed = parse(&text, 0).unwrap_or_else(|d| panic!("{text}: {d:?}"));
            assert_eq!(parsed.program.stages[0].name(), name);
        }
        assert!(kind_of("dot_product_2d_3of2").is_none());
        assert!(kind_of("dot_product_2d_0of2").is_none());
        assert!(kind_of("dot_product_2d").is_none());
    }

    #[test]
    fn spans_cover_the_instruction_and_the_stage_it_reads() {
        let text = "texture_2d();\n  dependent_gb( tex0 ) ;";
        let parsed = parse(text, 100).unwrap();
        let s = parsed.spans[1];
        assert_eq!((s.name.start, s.name.end), (116, 128));
        let p = s.previous.unwrap();
        assert_eq!((p.start, p.end), (130, 134));
        assert_eq!(s.whole.end, 138);
    }

    #[test]
    fn numbers_take_a_sign_and_no_exponent() {
        let parsed = parse("offset_2d(tex0, -1, +0.5, -.25, 2.);", 0).unwrap();
        assert_eq!(
            parsed.program.stages[0],
            Operation::Offset { rectangle: false, previous: 0, matrix: [-1.0, 0.5, -0.25, 2.0], scale: None }
        );
        assert!(parse("offset_2d(tex0, 1e3, 0, 0, 1);", 0).is_err());
    }
}
