//! Prints a [`TextureShader`] as `!!TS1.0` text that [`super::parse`] reads
//! back to the same program (tested by a property in `tests/texture_shaders.rs`).

use std::fmt::Write as _;

use super::program::{DotMapping, Operation, TextureShader};

/// The program with its `!!TS1.0` header, one instruction per line.
pub fn print(program: &TextureShader) -> String {
    let mut out = String::from("!!TS1.0\n");
    for op in &program.stages {
        let _ = writeln!(out, "{}", instruction(op));
    }
    out
}

/// One instruction, `name(arguments);`.
pub fn instruction(op: &Operation) -> String {
    let args = match *op {
        Operation::CullFragment(c) => c.map(|c| c.name()).join(", "),
        Operation::Offset { previous, matrix, scale, .. } => {
            let mut a = format!("tex{previous}, {}, {}, {}, {}", matrix[0], matrix[1], matrix[2], matrix[3]);
            if let Some((scale, bias)) = scale {
                let _ = write!(a, ", {scale}, {bias}");
            }
            a
        }
        Operation::Dependent { previous, .. } => format!("tex{previous}"),
        Operation::DotProduct { previous, mapping, eye, .. } => {
            let mut a = match mapping {
                DotMapping::ExpandNormal => format!("expand(tex{previous})"),
                DotMapping::UnsignedIdentity => format!("tex{previous}"),
            };
            if let Some(e) = eye {
                let _ = write!(a, ", {}, {}, {}", e[0], e[1], e[2]);
            }
            a
        }
        _ => String::new(),
    };
    format!("{}({args});", op.name())
}
