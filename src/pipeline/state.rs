//! The fixed-function state of a pass — culling, depth and stencil tests,
//! blending, the colour write mask — as GL defines it (Pipeline Grammar, Section 3:
//! the multipass forms (9)-(10), `C ← C ⊕ …`, are framebuffer blends;
//! Kilgard 2000, Section 5 re-renders with the `Equal` depth test). It is part
//! of the plan contract: the planner chooses it, every executor applies it.

use serde::{Deserialize, Serialize};

/// Which faces are culled. Front faces are counter-clockwise in normalized
/// device coordinates (y up), as in GL's default `glFrontFace(GL_CCW)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CullMode {
    None,
    Back,
    Front,
}

/// The fixed-function state of a pass.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderState {
    pub cull: CullMode,
    pub depth: DepthState,
    pub stencil: StencilState,
    pub blend: BlendState,
    /// The alpha test (OpenGL 1.2.1, Section 4.1.4), which drops a fragment
    /// before the stencil and depth tests. Disabled unless the planner
    /// routes a discard's condition to the fragment's alpha (a register-
    /// combiner target, whose final combiner's alpha is its G input,
    /// NV_register_combiners). Absent from older plans: disabled.
    #[serde(default, skip_serializing_if = "AlphaTest::is_disabled")]
    pub alpha_test: AlphaTest,
}

impl Default for RenderState {
    /// Back-face culling, depth `Less` with write, no stencil, replace, no alpha test.
    fn default() -> RenderState {
        RenderState {
            cull: CullMode::Back,
            depth: DepthState::LESS_WRITE,
            stencil: StencilState::DISABLED,
            blend: BlendState::REPLACE,
            alpha_test: AlphaTest::DISABLED,
        }
    }
}

/// `glAlphaFunc(func, reference)` enabled, or disabled (`func: Always`):
/// the fragment passes where `alpha func reference` (OpenGL 1.2.1, Section
/// 4.1.4). The reference is clamped to [0, 1] and, on a fixed-point
/// machine, converted to the alpha's fixed-point form before the
/// comparison ([`AlphaTest::reference_steps`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlphaTest {
    pub func: CompareFunc,
    pub reference: f32,
}

impl Default for AlphaTest {
    fn default() -> AlphaTest {
        AlphaTest::DISABLED
    }
}

impl AlphaTest {
    /// GL's initial state: the test disabled (every fragment passes).
    pub const DISABLED: AlphaTest = AlphaTest { func: CompareFunc::Always, reference: 0.0 };

    /// Whether the test keeps every fragment.
    pub fn is_disabled(&self) -> bool {
        self.func == CompareFunc::Always
    }

    /// The reference as an 8-bit machine compares it: clamped to [0, 1]
    /// and converted as a colour component is (OpenGL 1.2.1, Section
    /// 2.13.9), to the nearest 1/255 with ties up, as the combiner
    /// emulator rounds (`numerics::fixed9`).
    pub fn reference_steps(&self) -> u8 {
        (self.reference.clamp(0.0, 1.0) as f64 * 255.0 + 0.5).floor() as u8
    }

    /// Whether an 8-bit fragment alpha (0-255) passes.
    pub fn passes_steps(&self, alpha: u8) -> bool {
        self.func.test(alpha, self.reference_steps())
    }

    /// Whether a fragment alpha passes in float: the alpha clamped to
    /// [0, 1] (a fixed-point colour buffer's fragment, Section 2.13.9),
    /// the reference clamped.
    pub fn passes(&self, alpha: f32) -> bool {
        self.func.test(alpha.clamp(0.0, 1.0), self.reference.clamp(0.0, 1.0))
    }

    /// The GL call that sets this state: `glAlphaFunc(GL_GREATER, 0.5)`,
    /// or `glDisable(GL_ALPHA_TEST)`.
    pub fn gl_call(&self) -> String {
        if self.is_disabled() {
            return "glDisable(GL_ALPHA_TEST)".to_string();
        }
        format!("glEnable(GL_ALPHA_TEST); glAlphaFunc({}, {})", self.func.gl_name(), self.reference)
    }
}

/// A GL comparison function, used by the depth and stencil tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CompareFunc {
    Never,
    Less,
    LessEqual,
    Equal,
    Greater,
    GreaterEqual,
    NotEqual,
    Always,
}

impl CompareFunc {
    /// GL's name of the function (`GL_GREATER`).
    pub fn gl_name(self) -> &'static str {
        match self {
            CompareFunc::Never => "GL_NEVER",
            CompareFunc::Less => "GL_LESS",
            CompareFunc::LessEqual => "GL_LEQUAL",
            CompareFunc::Equal => "GL_EQUAL",
            CompareFunc::Greater => "GL_GREATER",
            CompareFunc::GreaterEqual => "GL_GEQUAL",
            CompareFunc::NotEqual => "GL_NOTEQUAL",
            CompareFunc::Always => "GL_ALWAYS",
        }
    }

    /// `incoming FUNC stored`, as GL defines it.
    #[inline]
    pub fn test<T: PartialOrd>(self, incoming: T, stored: T) -> bool {
        match self {
            CompareFunc::Never => false,
            CompareFunc::Less => incoming < stored,
            CompareFunc::LessEqual => incoming <= stored,
            CompareFunc::Equal => incoming == stored,
            CompareFunc::Greater => incoming > stored,
            CompareFunc::GreaterEqual => incoming >= stored,
            CompareFunc::NotEqual => incoming != stored,
            CompareFunc::Always => true,
        }
    }
}

/// Depth test and depth write. `func: Equal` with `write: false` is the state
/// for re-rendering the same geometry in a later pass (Kilgard 2000, Section 5:
/// the diffuse and specular passes are drawn over the ambient pass).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DepthState {
    pub func: CompareFunc,
    pub write: bool,
}

impl DepthState {
    /// No test, no write.
    pub const DISABLED: DepthState = DepthState { func: CompareFunc::Always, write: false };
    /// The usual first pass: `Less`, write.
    pub const LESS_WRITE: DepthState = DepthState { func: CompareFunc::Less, write: true };
    /// Later passes over the same geometry: `Equal`, no write.
    pub const EQUAL_NO_WRITE: DepthState = DepthState { func: CompareFunc::Equal, write: false };
}

/// What the stencil buffer does on a test outcome.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum StencilOp {
    Keep,
    Zero,
    Replace,
    /// Increment, saturating at 255.
    Incr,
    /// Decrement, saturating at 0.
    Decr,
    Invert,
    IncrWrap,
    DecrWrap,
}

impl StencilOp {
    #[inline]
    fn apply(self, stored: u8, reference: u8) -> u8 {
        match self {
            StencilOp::Keep => stored,
            StencilOp::Zero => 0,
            StencilOp::Replace => reference,
            StencilOp::Incr => stored.saturating_add(1),
            StencilOp::Decr => stored.saturating_sub(1),
            StencilOp::Invert => !stored,
            StencilOp::IncrWrap => stored.wrapping_add(1),
            StencilOp::DecrWrap => stored.wrapping_sub(1),
        }
    }
}

/// The GL stencil state (one face; draw twice with opposite culling for
/// two-sided techniques such as shadow volumes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct StencilState {
    pub enabled: bool,
    /// Compares `reference & read_mask` with `stored & read_mask`.
    pub func: CompareFunc,
    pub reference: u8,
    pub read_mask: u8,
    pub write_mask: u8,
    /// Stencil test failed.
    pub fail: StencilOp,
    /// Stencil passed, depth failed.
    pub depth_fail: StencilOp,
    /// Both passed.
    pub pass: StencilOp,
    /// Both passed, on a back face, where it differs from `pass` (two-sided
    /// stencil: EXT_stencil_two_side, WebGPU's per-face state; a shadow
    /// volume counted by facing in one pass). `None`: both faces `pass`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub back_pass: Option<StencilOp>,
}

impl StencilState {
    /// No stencil test, nothing written: OpenGL's initial state.
    pub const DISABLED: StencilState = StencilState {
        enabled: false,
        func: CompareFunc::Always,
        reference: 0,
        read_mask: 0xff,
        write_mask: 0xff,
        fail: StencilOp::Keep,
        depth_fail: StencilOp::Keep,
        pass: StencilOp::Keep,
        back_pass: None,
    };

    #[inline]
    pub(crate) fn test(&self, stored: u8) -> bool {
        !self.enabled || self.func.test(self.reference & self.read_mask, stored & self.read_mask)
    }

    #[inline]
    pub(crate) fn update(&self, stored: &mut u8, op: StencilOp) {
        if self.enabled && op != StencilOp::Keep {
            let new = op.apply(*stored, self.reference);
            *stored = (*stored & !self.write_mask) | (new & self.write_mask);
        }
    }
}

/// A GL blend factor (`glBlendFunc`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum BlendFactor {
    Zero,
    One,
    SrcColor,
    OneMinusSrcColor,
    DstColor,
    OneMinusDstColor,
    SrcAlpha,
    OneMinusSrcAlpha,
    DstAlpha,
    OneMinusDstAlpha,
    /// The blend state's `constant` colour.
    ConstantColor,
    OneMinusConstantColor,
    /// min(As, 1 − Ad) for RGB, 1 for alpha.
    SrcAlphaSaturate,
}

/// A GL blend equation (`glBlendEquation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum BlendEquation {
    /// src·Fs + dst·Fd
    Add,
    /// src·Fs − dst·Fd
    Subtract,
    /// dst·Fd − src·Fs
    ReverseSubtract,
    Min,
    Max,
}

/// Framebuffer blending: `C ← src·Fs (eq) C·Fd`, separately for RGB and alpha,
/// plus a per-channel write mask.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlendState {
    pub src_rgb: BlendFactor,
    pub dst_rgb: BlendFactor,
    pub src_alpha: BlendFactor,
    pub dst_alpha: BlendFactor,
    pub equation: BlendEquation,
    pub constant: [f32; 4],
    /// Which of R, G, B, A are written.
    pub write_mask: [bool; 4],
}

impl BlendState {
    /// The same factor pair for RGB and alpha.
    pub const fn factors(src: BlendFactor, dst: BlendFactor) -> BlendState {
        BlendState {
            src_rgb: src,
            dst_rgb: dst,
            src_alpha: src,
            dst_alpha: dst,
            equation: BlendEquation::Add,
            constant: [0.0; 4],
            write_mask: [true; 4],
        }
    }
    /// No blending: `C ← src`.
    pub const REPLACE: BlendState = BlendState::factors(BlendFactor::One, BlendFactor::Zero);
    /// `C ← C + src` (ONE, ONE).
    pub const ADD: BlendState = BlendState::factors(BlendFactor::One, BlendFactor::One);
    /// `C ← C · src` (DST_COLOR, ZERO).
    pub const MODULATE: BlendState = BlendState::factors(BlendFactor::DstColor, BlendFactor::Zero);
    /// `C ← src·As + C·(1 − As)`.
    pub const ALPHA_BLEND: BlendState =
        BlendState::factors(BlendFactor::SrcAlpha, BlendFactor::OneMinusSrcAlpha);
    /// `C ← src · Ad` (DST_ALPHA, ZERO): modulate by a term stashed in destination alpha.
    pub const DEST_ALPHA_MODULATE: BlendState = BlendState::factors(BlendFactor::DstAlpha, BlendFactor::Zero);
    /// `C ← C + src · Ad` (DST_ALPHA, ONE): Kilgard 2000, Section 5.5, the specular
    /// pass added under the self-shadowing term kept in destination alpha.
    pub const DEST_ALPHA_ADD: BlendState = BlendState::factors(BlendFactor::DstAlpha, BlendFactor::One);

    /// This state with another write mask.
    pub const fn with_write_mask(mut self, mask: [bool; 4]) -> BlendState {
        self.write_mask = mask;
        self
    }

    #[inline]
    fn factor(&self, factor: BlendFactor, src: &[f32; 4], dst: &[f32; 4], channel: usize) -> f32 {
        match factor {
            BlendFactor::Zero => 0.0,
            BlendFactor::One => 1.0,
            BlendFactor::SrcColor => src[channel],
            BlendFactor::OneMinusSrcColor => 1.0 - src[channel],
            BlendFactor::DstColor => dst[channel],
            BlendFactor::OneMinusDstColor => 1.0 - dst[channel],
            BlendFactor::SrcAlpha => src[3],
            BlendFactor::OneMinusSrcAlpha => 1.0 - src[3],
            BlendFactor::DstAlpha => dst[3],
            BlendFactor::OneMinusDstAlpha => 1.0 - dst[3],
            BlendFactor::ConstantColor => self.constant[channel],
            BlendFactor::OneMinusConstantColor => 1.0 - self.constant[channel],
            BlendFactor::SrcAlphaSaturate => {
                if channel == 3 {
                    1.0
                } else {
                    src[3].min(1.0 - dst[3])
                }
            }
        }
    }

    /// The blended colour (before the write mask and before storage rounding).
    #[inline]
    pub fn blend(&self, src: &[f32; 4], dst: &[f32; 4]) -> [f32; 4] {
        if *self == BlendState::REPLACE {
            return *src;
        }
        let mut out = [0.0f32; 4];
        for c in 0..4 {
            let (fs, fd) = if c == 3 {
                (self.factor(self.src_alpha, src, dst, c), self.factor(self.dst_alpha, src, dst, c))
            } else {
                (self.factor(self.src_rgb, src, dst, c), self.factor(self.dst_rgb, src, dst, c))
            };
            out[c] = match self.equation {
                BlendEquation::Add => src[c] * fs + dst[c] * fd,
                BlendEquation::Subtract => src[c] * fs - dst[c] * fd,
                BlendEquation::ReverseSubtract => dst[c] * fd - src[c] * fs,
                BlendEquation::Min => src[c].min(dst[c]),
                BlendEquation::Max => src[c].max(dst[c]),
            };
        }
        out
    }
}
