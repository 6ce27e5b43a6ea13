//! A `!!VP1.0` program as data: NV_vertex_program's instruction set (NVIDIA
//! 2001, Section 2.14.1), its register files and the operand modifiers
//! (negation, swizzle, write mask). `!!VP1.1` (NV_vertex_program1_1) adds
//! four instructions and the position-invariant option.

/// Vertex attribute registers `v[0]`..`v[15]`.
pub const ATTRIBUTES: usize = 16;
/// Program parameter registers `c[0]`..`c[95]`.
pub const PARAMETERS: usize = 96;
/// Temporary registers `R0`..`R11`.
pub const TEMPORARIES: usize = 12;
/// Instructions in one vertex program.
pub const MAX_INSTRUCTIONS: usize = 128;
/// Vertex result registers (`o[HPOS]` … `o[TEX7]`).
pub const OUTPUTS: usize = 15;
/// The relative offset of `c[A0.x + k]`: −64 ≤ k ≤ 63.
pub const RELATIVE_OFFSETS: std::ops::RangeInclusive<i32> = -64..=63;

/// The conventional names of the attribute registers (`v[OPOS]` is `v[0]`).
pub const ATTRIBUTE_NAMES: [(&str, u8); 14] = [
    ("OPOS", 0),
    ("WGHT", 1),
    ("NRML", 2),
    ("COL0", 3),
    ("COL1", 4),
    ("FOGC", 5),
    ("TEX0", 8),
    ("TEX1", 9),
    ("TEX2", 10),
    ("TEX3", 11),
    ("TEX4", 12),
    ("TEX5", 13),
    ("TEX6", 14),
    ("TEX7", 15),
];

/// The vertex result registers, in the order [`Output::index`] numbers them.
pub const OUTPUT_NAMES: [&str; OUTPUTS] = [
    "HPOS", "COL0", "COL1", "BFC0", "BFC1", "FOGC", "PSIZ", "TEX0", "TEX1", "TEX2", "TEX3", "TEX4", "TEX5",
    "TEX6", "TEX7",
];

/// Which format a program was written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Version {
    /// `!!VP1.0`: NV_vertex_program.
    #[default]
    V10,
    /// `!!VP1.1`: NV_vertex_program1_1 (adds DPH, RCC, SUB, ABS).
    V11,
    /// `!!VSP1.0`: a vertex state program (NV_vertex_program, Section
    /// 2.14.4): run once by `ExecuteProgramNV` on one attribute `v[0]`, it
    /// writes program parameters `c[n]` instead of a vertex's results.
    Vsp10,
}

impl Version {
    /// The header line the version's programs start with.
    pub fn header(self) -> &'static str {
        match self {
            Version::V10 => "!!VP1.0",
            Version::V11 => "!!VP1.1",
            Version::Vsp10 => "!!VSP1.0",
        }
    }

    /// Whether the program is a vertex state program (`!!VSP1.0`).
    pub fn is_state_program(self) -> bool {
        self == Version::Vsp10
    }
}

/// The instructions, named as in the spec.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Opcode {
    Mov,
    Mul,
    Add,
    Mad,
    Dst,
    Min,
    Max,
    Slt,
    Sge,
    Rcp,
    Rsq,
    Dp3,
    Dp4,
    Log,
    Exp,
    Lit,
    Arl,
    // NV_vertex_program1_1.
    Dph,
    Rcc,
    Sub,
    Abs,
}

/// How an instruction's operands are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Vector sources.
    Vector(usize),
    /// One scalar source (a one-component swizzle `.x`).
    Scalar,
}

impl Opcode {
    /// Every opcode of NV_vertex_program 1.1, for the reader and exhaustive tests.
    pub const ALL: [Opcode; 21] = [
        Opcode::Mov,
        Opcode::Mul,
        Opcode::Add,
        Opcode::Mad,
        Opcode::Dst,
        Opcode::Min,
        Opcode::Max,
        Opcode::Slt,
        Opcode::Sge,
        Opcode::Rcp,
        Opcode::Rsq,
        Opcode::Dp3,
        Opcode::Dp4,
        Opcode::Log,
        Opcode::Exp,
        Opcode::Lit,
        Opcode::Arl,
        Opcode::Dph,
        Opcode::Rcc,
        Opcode::Sub,
        Opcode::Abs,
    ];

    /// The opcode's mnemonic as the program text spells it.
    pub fn name(self) -> &'static str {
        use Opcode::*;
        match self {
            Mov => "MOV",
            Mul => "MUL",
            Add => "ADD",
            Mad => "MAD",
            Dst => "DST",
            Min => "MIN",
            Max => "MAX",
            Slt => "SLT",
            Sge => "SGE",
            Rcp => "RCP",
            Rsq => "RSQ",
            Dp3 => "DP3",
            Dp4 => "DP4",
            Log => "LOG",
            Exp => "EXP",
            Lit => "LIT",
            Arl => "ARL",
            Dph => "DPH",
            Rcc => "RCC",
            Sub => "SUB",
            Abs => "ABS",
        }
    }

    /// The opcode of `name` (a mnemonic), if it is one.
    pub fn from_name(name: &str) -> Option<Opcode> {
        Opcode::ALL.into_iter().find(|o| o.name() == name)
    }

    /// The sources it reads, and whether they are scalars.
    pub fn shape(self) -> Shape {
        use Opcode::*;
        match self {
            Mov | Lit | Abs => Shape::Vector(1),
            Mul | Add | Dst | Min | Max | Slt | Sge | Dp3 | Dp4 | Dph | Sub => Shape::Vector(2),
            Mad => Shape::Vector(3),
            Rcp | Rsq | Log | Exp | Arl | Rcc => Shape::Scalar,
        }
    }

    /// How many source operands the opcode reads.
    pub fn sources(self) -> usize {
        match self.shape() {
            Shape::Vector(n) => n,
            Shape::Scalar => 1,
        }
    }

    /// The first format that has it.
    pub fn version(self) -> Version {
        match self {
            Opcode::Dph | Opcode::Rcc | Opcode::Sub | Opcode::Abs => Version::V11,
            _ => Version::V10,
        }
    }
}

/// A register an instruction reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SrcReg {
    /// `v[n]`.
    Attribute(u8),
    /// `c[n]`.
    Parameter(u8),
    /// `c[A0.x + k]`.
    Relative(i8),
    /// `Rn`.
    Temporary(u8),
}

/// A source operand: `-c[4].xyzw`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Source {
    pub negate: bool,
    pub reg: SrcReg,
    /// Component `k` of the operand is component `swizzle[k]` of the register.
    pub swizzle: [u8; 4],
}

impl Source {
    /// The swizzle that reads x, y, z, w as they are.
    pub const IDENTITY: [u8; 4] = [0, 1, 2, 3];

    /// `reg` read as it is: not negated, not swizzled.
    pub fn new(reg: SrcReg) -> Source {
        Source { negate: false, reg, swizzle: Source::IDENTITY }
    }

    /// The scalar component `c` replicated.
    pub fn scalar(reg: SrcReg, c: u8) -> Source {
        Source { negate: false, reg, swizzle: [c; 4] }
    }
}

/// A vertex result register.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Output(pub u8);

impl Output {
    /// `o[HPOS]`: the clip-space position.
    pub const HPOS: Output = Output(0);
    /// `o[COL0]`: the primary colour.
    pub const COL0: Output = Output(1);
    /// `o[COL1]`: the secondary colour.
    pub const COL1: Output = Output(2);
    /// `o[BFC0]`: the back-facing primary colour.
    pub const BFC0: Output = Output(3);
    /// `o[BFC1]`: the back-facing secondary colour.
    pub const BFC1: Output = Output(4);
    /// `o[FOGC]`: the fog coordinate.
    pub const FOGC: Output = Output(5);
    /// `o[PSIZ]`: the point size.
    pub const PSIZ: Output = Output(6);
    /// The four colour results, which the rasterizer receives clamped to
    /// [0, 1] (NV_vertex_program, Section 2.14.1.5).
    pub const COLOURS: [Output; 4] = [Output::COL0, Output::COL1, Output::BFC0, Output::BFC1];

    /// `o[TEXk]`: texture coordinate set `k`.
    pub fn tex(k: u8) -> Output {
        Output(7 + k)
    }

    /// Whether this is a texture coordinate set, `o[TEX0]`..`o[TEX7]`.
    pub fn is_texture(self) -> bool {
        self.0 >= 7
    }

    /// The register's name as the program text spells it.
    pub fn name(self) -> &'static str {
        OUTPUT_NAMES[usize::from(self.0).min(OUTPUTS - 1)]
    }

    /// The register's index in the emulator's output array.
    pub fn index(self) -> usize {
        usize::from(self.0)
    }
}

/// A register an instruction writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DstReg {
    Temporary(u8),
    Output(Output),
    /// `A0.x`, written only by ARL.
    Address,
    /// `c[n]`, written only by a vertex state program (`!!VSP1.0`).
    Parameter(u8),
}

/// A destination with its write mask (bit `k` set: component `k` written).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Dest {
    pub reg: DstReg,
    pub mask: u8,
}

impl Dest {
    /// The write mask of every component (`.xyzw`).
    pub const ALL: u8 = 0b1111;
}

/// One instruction: the opcode, its destination with write mask, and its sources.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Instruction {
    pub op: Opcode,
    pub dst: Dest,
    pub src: Vec<Source>,
}

/// A whole program.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct VertexProgram {
    pub version: Version,
    /// `OPTION NV_position_invariant;` (VP1.1): `o[HPOS]` is computed by the
    /// fixed-function transform, and the program must not write it.
    pub position_invariant: bool,
    pub instructions: Vec<Instruction>,
}
