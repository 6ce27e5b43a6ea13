//! The plan contract's GL-style fixed-function state
//! ([`RenderState`](crate::pipeline::RenderState)) in wgpu's terms: depth
//! and stencil comparisons and operations, blending, the write mask.

use crate::pipeline::{BlendEquation, BlendFactor, BlendState, CompareFunc, StencilOp, StencilState};

pub(super) fn compare(func: CompareFunc) -> wgpu::CompareFunction {
    match func {
        CompareFunc::Never => wgpu::CompareFunction::Never,
        CompareFunc::Less => wgpu::CompareFunction::Less,
        CompareFunc::LessEqual => wgpu::CompareFunction::LessEqual,
        CompareFunc::Equal => wgpu::CompareFunction::Equal,
        CompareFunc::Greater => wgpu::CompareFunction::Greater,
        CompareFunc::GreaterEqual => wgpu::CompareFunction::GreaterEqual,
        CompareFunc::NotEqual => wgpu::CompareFunction::NotEqual,
        CompareFunc::Always => wgpu::CompareFunction::Always,
    }
}

/// GL's stencil state applies to both faces (`glStencilFunc`/`glStencilOp`).
pub(super) fn stencil_state(stencil: &StencilState) -> wgpu::StencilState {
    if !stencil.enabled {
        return wgpu::StencilState::default();
    }
    let op = |op: StencilOp| match op {
        StencilOp::Keep => wgpu::StencilOperation::Keep,
        StencilOp::Zero => wgpu::StencilOperation::Zero,
        StencilOp::Replace => wgpu::StencilOperation::Replace,
        StencilOp::Incr => wgpu::StencilOperation::IncrementClamp,
        StencilOp::Decr => wgpu::StencilOperation::DecrementClamp,
        StencilOp::Invert => wgpu::StencilOperation::Invert,
        StencilOp::IncrWrap => wgpu::StencilOperation::IncrementWrap,
        StencilOp::DecrWrap => wgpu::StencilOperation::DecrementWrap,
    };
    let face = wgpu::StencilFaceState {
        compare: compare(stencil.func),
        fail_op: op(stencil.fail),
        depth_fail_op: op(stencil.depth_fail),
        pass_op: op(stencil.pass),
    };
    // Two-sided stencil: the back face's own pass operation.
    let back = wgpu::StencilFaceState { pass_op: op(stencil.back_pass.unwrap_or(stencil.pass)), ..face };
    wgpu::StencilState {
        front: face,
        back,
        read_mask: u32::from(stencil.read_mask),
        write_mask: u32::from(stencil.write_mask),
    }
}

pub(super) fn blend_state(blend: &BlendState) -> wgpu::BlendState {
    let factor = |f: BlendFactor| match f {
        BlendFactor::Zero => wgpu::BlendFactor::Zero,
        BlendFactor::One => wgpu::BlendFactor::One,
        BlendFactor::SrcColor => wgpu::BlendFactor::Src,
        BlendFactor::OneMinusSrcColor => wgpu::BlendFactor::OneMinusSrc,
        BlendFactor::DstColor => wgpu::BlendFactor::Dst,
        BlendFactor::OneMinusDstColor => wgpu::BlendFactor::OneMinusDst,
        BlendFactor::SrcAlpha => wgpu::BlendFactor::SrcAlpha,
        BlendFactor::OneMinusSrcAlpha => wgpu::BlendFactor::OneMinusSrcAlpha,
        BlendFactor::DstAlpha => wgpu::BlendFactor::DstAlpha,
        BlendFactor::OneMinusDstAlpha => wgpu::BlendFactor::OneMinusDstAlpha,
        BlendFactor::ConstantColor => wgpu::BlendFactor::Constant,
        BlendFactor::OneMinusConstantColor => wgpu::BlendFactor::OneMinusConstant,
        BlendFactor::SrcAlphaSaturate => wgpu::BlendFactor::SrcAlphaSaturated,
    };
    let component = |src: BlendFactor, dst: BlendFactor| {
        let operation = match blend.equation {
            BlendEquation::Add => wgpu::BlendOperation::Add,
            BlendEquation::Subtract => wgpu::BlendOperation::Subtract,
            BlendEquation::ReverseSubtract => wgpu::BlendOperation::ReverseSubtract,
            BlendEquation::Min => wgpu::BlendOperation::Min,
            BlendEquation::Max => wgpu::BlendOperation::Max,
        };
        // GL ignores the factors of MIN and MAX; WebGPU requires them to be One.
        if matches!(blend.equation, BlendEquation::Min | BlendEquation::Max) {
            wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::One,
                operation,
            }
        } else {
            wgpu::BlendComponent { src_factor: factor(src), dst_factor: factor(dst), operation }
        }
    };
    wgpu::BlendState {
        color: component(blend.src_rgb, blend.dst_rgb),
        alpha: component(blend.src_alpha, blend.dst_alpha),
    }
}

pub(super) fn write_mask([r, g, b, a]: [bool; 4]) -> wgpu::ColorWrites {
    let mut mask = wgpu::ColorWrites::empty();
    for (on, bit) in [
        (r, wgpu::ColorWrites::RED),
        (g, wgpu::ColorWrites::GREEN),
        (b, wgpu::ColorWrites::BLUE),
        (a, wgpu::ColorWrites::ALPHA),
    ] {
        if on {
            mask |= bit;
        }
    }
    mask
}
