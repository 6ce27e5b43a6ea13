//! Fixed-function state: culling, stencil, blending, discard.
use crate::common;

use common::{ClipVertices, Constant};
use shadec::renderer::{
    draw, BlendState, ColorFormat, CompareFunc, CullMode, DepthState, Fragment, FragmentResult,
    FragmentStage, Framebuffer, Pass, RenderState, StencilOp, StencilState,
};

const W: u32 = 32;
const H: u32 = 32;

fn full_screen() -> (ClipVertices, Vec<[u32; 3]>) {
    let v = ClipVertices::from_pixels(
        &[[0.0, 0.0], [W as f32, 0.0], [W as f32, H as f32], [0.0, H as f32]],
        W,
        H,
    );
    // Counter-clockwise in NDC (y up): (0,H) is bottom-left.
    (v, vec![[3, 2, 1], [3, 1, 0]])
}

fn count(fb: &Framebuffer, pred: impl Fn([f32; 4]) -> bool) -> usize {
    fb.to_rgba_f32().into_iter().filter(|c| pred(*c)).count()
}

#[test]
fn back_face_culling_follows_ndc_winding() {
    let (v, ccw) = full_screen();
    let cw: Vec<[u32; 3]> = ccw.iter().map(|t| [t[0], t[2], t[1]]).collect();
    for (tris, cull, visible) in [
        (&ccw, CullMode::Back, true),
        (&cw, CullMode::Back, false),
        (&ccw, CullMode::Front, false),
        (&cw, CullMode::Front, true),
        (&cw, CullMode::None, true),
    ] {
        let mut fb = Framebuffer::new(W, H, ColorFormat::F32).unwrap();
        let state = RenderState { cull, ..RenderState::default() };
        let stats =
            draw(&mut fb, &Pass { triangles: tris, vertex: &v, fragment: &Constant([1.0; 4]), state })
                .unwrap();
        let lit = count(&fb, |c| c[0] == 1.0);
        assert_eq!(lit, if visible { (W * H) as usize } else { 0 }, "{cull:?}");
        assert_eq!(stats.culled, if visible { 0 } else { 2 });
    }
}

#[test]
fn front_facing_flag_reaches_the_fragment_stage() {
    struct Facing;
    impl FragmentStage for Facing {
        fn shade(&self, f: &Fragment, _: &[f32], out: &mut [f32; 4]) -> FragmentResult {
            *out = if f.front_facing { [1.0, 0.0, 0.0, 1.0] } else { [0.0, 1.0, 0.0, 1.0] };
            FragmentResult::Keep
        }
    }
    let (v, ccw) = full_screen();
    let mut fb = Framebuffer::new(W, H, ColorFormat::F32).unwrap();
    let state = RenderState { cull: CullMode::None, ..RenderState::default() };
    draw(&mut fb, &Pass { triangles: &ccw[..1], vertex: &v, fragment: &Facing, state }).unwrap();
    let cw = [[ccw[1][0], ccw[1][2], ccw[1][1]]];
    draw(&mut fb, &Pass { triangles: &cw, vertex: &v, fragment: &Facing, state }).unwrap();
    assert!(count(&fb, |c| c[0] == 1.0) > 100 && count(&fb, |c| c[1] == 1.0) > 100);
}

#[test]
fn stencil_masks_a_second_pass() {
    let (v, quad) = full_screen();
    // Pass 1: a triangle writes stencil 1, no colour.
    let tri = ClipVertices::from_pixels(&[[4.0, 28.0], [28.0, 28.0], [16.0, 4.0]], W, H);
    let mut fb = Framebuffer::new(W, H, ColorFormat::Rgba8).unwrap();
    let mark = RenderState {
        cull: CullMode::None,
        depth: DepthState::DISABLED,
        stencil: StencilState {
            enabled: true,
            func: CompareFunc::Always,
            reference: 1,
            pass: StencilOp::Replace,
            ..StencilState::DISABLED
        },
        blend: BlendState::REPLACE.with_write_mask([false; 4]),
        ..RenderState::default()
    };
    let s1 = draw(
        &mut fb,
        &Pass { triangles: &[[0, 1, 2]], vertex: &tri, fragment: &Constant([1.0; 4]), state: mark },
    )
    .unwrap();
    assert_eq!(count(&fb, |c| c != [0.0; 4]), 0, "write mask off: no colour");
    // Pass 2: full screen where stencil == 1, incrementing it.
    let masked = RenderState {
        stencil: StencilState {
            enabled: true,
            func: CompareFunc::Equal,
            reference: 1,
            pass: StencilOp::Incr,
            ..StencilState::DISABLED
        },
        blend: BlendState::REPLACE,
        ..mark
    };
    draw(
        &mut fb,
        &Pass { triangles: &quad, vertex: &v, fragment: &Constant([1.0, 0.0, 0.0, 1.0]), state: masked },
    )
    .unwrap();
    let red = count(&fb, |c| c[0] == 1.0);
    assert_eq!(red as u64, s1.written);
    let mut twos = 0;
    for y in 0..H {
        for x in 0..W {
            let s = fb.stencil(x, y).unwrap();
            assert_eq!(s == 2, fb.color(x, y).unwrap()[0] == 1.0);
            assert!(s == 0 || s == 2);
            twos += (s == 2) as usize;
        }
    }
    assert_eq!(twos, red);
}

#[test]
fn blend_modes_through_draws() {
    let (v, quad) = full_screen();
    let dst = [0.5, 0.25, 1.0, 0.5];
    let src = [0.5, 0.5, 0.5, 0.25];
    for (blend, expected) in [
        (BlendState::REPLACE, src),
        (BlendState::ADD, [1.0, 0.75, 1.5, 0.75]),
        (BlendState::MODULATE, [0.25, 0.125, 0.5, 0.125]),
        (BlendState::ALPHA_BLEND, [0.5, 0.3125, 0.875, 0.4375]),
        (BlendState::DEST_ALPHA_MODULATE, [0.25, 0.25, 0.25, 0.125]),
        (BlendState::DEST_ALPHA_ADD, [0.75, 0.5, 1.25, 0.625]),
    ] {
        for format in [ColorFormat::F32, ColorFormat::Rgba8] {
            let mut fb = Framebuffer::new(W, H, format).unwrap();
            fb.clear_color(dst);
            let state = RenderState {
                cull: CullMode::None,
                depth: DepthState::DISABLED,
                blend,
                ..RenderState::default()
            };
            draw(&mut fb, &Pass { triangles: &quad, vertex: &v, fragment: &Constant(src), state }).unwrap();
            let tol = if format == ColorFormat::Rgba8 { 1.0 / 255.0 } else { 1e-6 };
            // Fixed-point targets saturate at 1.
            let expected =
                if format == ColorFormat::Rgba8 { expected.map(|e: f32| e.min(1.0)) } else { expected };
            for c in fb.to_rgba_f32() {
                for k in 0..4 {
                    assert!((c[k] - expected[k]).abs() <= tol, "{blend:?} {format:?}: {c:?} vs {expected:?}");
                }
            }
        }
    }
    // RGBA8 saturates additive blending; f32 does not.
    let mut f = Framebuffer::new(W, H, ColorFormat::F32).unwrap();
    let mut b = Framebuffer::new(W, H, ColorFormat::Rgba8).unwrap();
    let state = RenderState {
        cull: CullMode::None,
        depth: DepthState::DISABLED,
        blend: BlendState::ADD,
        ..RenderState::default()
    };
    for fb in [&mut f, &mut b] {
        for _ in 0..3 {
            draw(fb, &Pass { triangles: &quad, vertex: &v, fragment: &Constant([0.5; 4]), state }).unwrap();
        }
    }
    assert_eq!(f.color(3, 3).unwrap()[0], 1.5);
    assert_eq!(b.color(3, 3).unwrap()[0], 1.0);
}

#[test]
fn discarded_fragments_touch_nothing() {
    struct Checker;
    impl FragmentStage for Checker {
        fn shade(&self, f: &Fragment, _: &[f32], out: &mut [f32; 4]) -> FragmentResult {
            *out = [1.0; 4];
            if (f.x + f.y) % 2 == 0 {
                FragmentResult::Keep
            } else {
                FragmentResult::Discard
            }
        }
    }
    let (v, quad) = full_screen();
    let mut fb = Framebuffer::new(W, H, ColorFormat::F32).unwrap();
    let state = RenderState {
        cull: CullMode::None,
        depth: DepthState::LESS_WRITE,
        stencil: StencilState { enabled: true, pass: StencilOp::Incr, ..StencilState::DISABLED },
        ..RenderState::default()
    };
    let stats = draw(&mut fb, &Pass { triangles: &quad, vertex: &v, fragment: &Checker, state }).unwrap();
    assert_eq!(stats.written, (W * H / 2) as u64);
    for y in 0..H {
        for x in 0..W {
            let kept = (x + y) % 2 == 0;
            assert_eq!(fb.stencil(x, y).unwrap(), kept as u8);
            assert_eq!(fb.depth(x, y).unwrap() < 1.0, kept);
        }
    }
}
