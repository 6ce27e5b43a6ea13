//! A program back to `!!VP1.0` text, in the form [`super::parse_file`] reads.

use super::program::*;

const XYZW: [char; 4] = ['x', 'y', 'z', 'w'];

/// The whole program, header to `END`.
pub fn print(program: &VertexProgram) -> String {
    let mut out = format!("{}\n", program.version.header());
    if program.position_invariant {
        out.push_str("OPTION NV_position_invariant;\n");
    }
    for ins in &program.instructions {
        out.push_str(&instruction(ins));
        out.push('\n');
    }
    out.push_str("END\n");
    out
}

/// One instruction, `;` included.
pub fn instruction(ins: &Instruction) -> String {
    let mut s = format!("{} {}", ins.op.name(), dest(&ins.dst));
    for src in &ins.src {
        s.push_str(", ");
        s.push_str(&source(src, ins.op.shape() == Shape::Scalar));
    }
    s.push(';');
    s
}

fn dest(d: &Dest) -> String {
    let reg = match d.reg {
        DstReg::Address => return "A0.x".into(),
        DstReg::Temporary(k) => format!("R{k}"),
        DstReg::Output(o) => format!("o[{}]", o.name()),
        DstReg::Parameter(k) => format!("c[{k}]"),
    };
    if d.mask & 15 == Dest::ALL {
        return reg;
    }
    let mask: String = (0..4).filter(|k| d.mask & (1 << k) != 0).map(|k| XYZW[k]).collect();
    format!("{reg}.{mask}")
}

pub(super) fn register(r: SrcReg) -> String {
    match r {
        SrcReg::Attribute(k) => format!("v[{k}]"),
        SrcReg::Parameter(k) => format!("c[{k}]"),
        SrcReg::Relative(0) => "c[A0.x]".into(),
        SrcReg::Relative(k) if k < 0 => format!("c[A0.x - {}]", -i32::from(k)),
        SrcReg::Relative(k) => format!("c[A0.x + {k}]"),
        SrcReg::Temporary(k) => format!("R{k}"),
    }
}

fn source(s: &Source, scalar: bool) -> String {
    let sign = if s.negate { "-" } else { "" };
    let reg = register(s.reg);
    let c = |k: u8| XYZW[usize::from(k & 3)];
    let swizzle = if scalar || s.swizzle.iter().all(|&k| k == s.swizzle[0]) {
        format!(".{}", c(s.swizzle[0]))
    } else if s.swizzle == Source::IDENTITY {
        String::new()
    } else {
        format!(".{}", s.swizzle.iter().map(|&k| c(k)).collect::<String>())
    };
    format!("{sign}{reg}{swizzle}")
}
