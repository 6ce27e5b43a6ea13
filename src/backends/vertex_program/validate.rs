//! The load-time rules of NV_vertex_program (NVIDIA 2001, Section
//! 2.14.1.2 and the errors of `LoadProgramNV`) that the grammar alone does
//! not enforce: at most 128 instructions; an instruction reads at most one
//! vertex attribute register and at most one program parameter register
//! (each may be read several times, with different swizzles); `o[HPOS]` is
//! written; the NV_vertex_program1_1 instructions only in `!!VP1.1`; and a
//! vertex state program (`!!VSP1.0`) reads only `v[0]` and writes a `c[n]`.

use std::fmt;

use crate::diag::Diagnostic;
use crate::span::Span;

use super::parser::InstructionSpans;
use super::program::*;

/// Which span of an instruction an error points at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum At {
    Opcode,
    Dst,
    Src(usize),
    /// The whole program (its header).
    Program,
}

/// One broken rule, at instruction `instruction`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VpError {
    pub code: &'static str,
    pub instruction: usize,
    pub at: At,
    pub message: String,
    pub label: String,
    pub help: String,
}

impl fmt::Display for VpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "instruction {}: {}", self.instruction + 1, self.message)
    }
}

impl VpError {
    /// The error as a located diagnostic: at the instruction's opcode or operand in `spans`,
    /// else at the `header`.
    pub fn to_diagnostic(&self, spans: &[InstructionSpans], header: Span) -> Diagnostic {
        let span = spans.get(self.instruction).map_or(header, |s| match self.at {
            At::Opcode => s.opcode,
            At::Dst => s.dst,
            At::Src(k) => s.src.get(k).copied().unwrap_or(s.opcode),
            At::Program => header,
        });
        Diagnostic::error(self.code, self.message.clone(), span, self.label.clone())
            .with_help(self.help.clone())
    }
}

/// Every rule `program` breaks (empty when it loads).
pub fn validate(program: &VertexProgram) -> Vec<VpError> {
    let mut errors = Vec::new();
    let n = program.instructions.len();
    if n > MAX_INSTRUCTIONS {
        errors.push(VpError {
            code: "too-many-instructions",
            instruction: MAX_INSTRUCTIONS,
            at: At::Opcode,
            message: format!(
                "the program has {n} instructions; a vertex program holds at most {MAX_INSTRUCTIONS}"
            ),
            label: format!("instruction {} is past the limit", MAX_INSTRUCTIONS + 1),
            help: "shorten the program (share subexpressions, fold constants into parameters)".into(),
        });
    }
    for (i, ins) in program.instructions.iter().enumerate() {
        if ins.op.version() == Version::V11 && program.version != Version::V11 {
            errors.push(VpError {
                code: "not-in-vp1.0",
                instruction: i,
                at: At::Opcode,
                message: format!(
                    "{} is an NV_vertex_program1_1 instruction, not in `{}`",
                    ins.op.name(),
                    program.version.header()
                ),
                label: "needs `!!VP1.1`".into(),
                help: "start the program with `!!VP1.1`, or write it with VP1.0 instructions".into(),
            });
        }
        one_register(ins, i, "attribute", |r| matches!(r, SrcReg::Attribute(_)), &mut errors);
        one_register(
            ins,
            i,
            "parameter",
            |r| matches!(r, SrcReg::Parameter(_) | SrcReg::Relative(_)),
            &mut errors,
        );
    }
    if program.version.is_state_program() {
        state_program(program, &mut errors);
    } else {
        hpos(program, &mut errors);
    }
    errors
}

/// A vertex state program's own rules (NV_vertex_program, Section 2.14.4,
/// and the errors of `LoadProgramNV`): it reads no attribute but `v[0]`
/// (the one `ExecuteProgramNV` passes), and it writes at least one program
/// parameter register.
fn state_program(program: &VertexProgram, errors: &mut Vec<VpError>) {
    for (i, ins) in program.instructions.iter().enumerate() {
        let other = ins.src.iter().position(|s| matches!(s.reg, SrcReg::Attribute(k) if k != 0));
        if let Some(k) = other {
            errors.push(VpError {
                code: "state-program-attribute",
                instruction: i,
                at: At::Src(k),
                message: format!(
                    "a vertex state program reads only `v[0]`, not {}",
                    reg_name(ins.src[k].reg)
                ),
                label: "not the attribute `ExecuteProgramNV` passes".into(),
                help: "read `v[0]`, or pass the value in a program parameter `c[n]`".into(),
            });
        }
    }
    if !program.instructions.iter().any(|ins| matches!(ins.dst.reg, DstReg::Parameter(_))) {
        errors.push(VpError {
            code: "state-program-no-parameter",
            instruction: program.instructions.len(),
            at: At::Program,
            message: "the vertex state program never writes a program parameter `c[n]`".into(),
            label: "a vertex state program must write at least one".into(),
            help: "write its result to a parameter, e.g. `MOV c[4], R0;`".into(),
        });
    }
}

/// The spec: "a vertex program instruction may read at most one unique
/// vertex attribute register" (and likewise one program parameter).
fn one_register(
    ins: &Instruction,
    i: usize,
    kind: &str,
    is: impl Fn(&SrcReg) -> bool,
    errors: &mut Vec<VpError>,
) {
    let mut first: Option<SrcReg> = None;
    for (k, s) in ins.src.iter().enumerate() {
        if !is(&s.reg) {
            continue;
        }
        match first {
            None => first = Some(s.reg),
            Some(f) if f == s.reg => {}
            Some(f) => {
                let (code, name) = if kind == "attribute" {
                    ("two-attributes", "vertex attribute")
                } else {
                    ("two-parameters", "program parameter")
                };
                errors.push(VpError {
                    code,
                    instruction: i,
                    at: At::Src(k),
                    message: format!("{} reads two {name} registers, {} and {}", ins.op.name(), reg_name(f), reg_name(s.reg)),
                    label: format!("a second {name} register"),
                    help: format!("an instruction reads at most one {name} register: move one of them to a temporary first (`MOV R0, {};`)", super::printer::register(s.reg)),
                });
                return;
            }
        }
    }
}

fn hpos(program: &VertexProgram, errors: &mut Vec<VpError>) {
    let writes = program.instructions.iter().position(|ins| ins.dst.reg == DstReg::Output(Output::HPOS));
    match (program.position_invariant, writes) {
        (false, None) => errors.push(VpError {
            code: "no-hpos",
            instruction: program.instructions.len(),
            at: At::Program,
            message: "the program never writes `o[HPOS]`".into(),
            label: "a vertex program must write the homogeneous clip position".into(),
            help: "transform the position, e.g. `DP4 o[HPOS].x, c[0], v[OPOS];` … for rows c[0]..c[3]".into(),
        }),
        (true, Some(i)) => errors.push(VpError {
            code: "hpos-invariant",
            instruction: i,
            at: At::Dst,
            message: "a position-invariant program cannot write `o[HPOS]`".into(),
            label: "written here".into(),
            help: "remove `OPTION NV_position_invariant;` or this write".into(),
        }),
        _ => {}
    }
}

pub(super) fn reg_name(r: SrcReg) -> String {
    match r {
        SrcReg::Attribute(k) => format!("`v[{k}]`"),
        SrcReg::Parameter(k) => format!("`c[{k}]`"),
        SrcReg::Relative(0) => "`c[A0.x]`".into(),
        SrcReg::Relative(k) if k < 0 => format!("`c[A0.x - {}]`", -i32::from(k)),
        SrcReg::Relative(k) => format!("`c[A0.x + {k}]`"),
        SrcReg::Temporary(k) => format!("`R{k}`"),
    }
}
