//! The WGSL translation run by wgpu (lavapipe on CI) against the CPU
//! interpreter, on generated programs: the translation's
//! `vertex_program` function (the one its `@vertex` entry point calls) is
//! called from a compute shader that stores every result register, so all
//! fifteen can be read back.

use shadec::backends::vertex_program::program::*;
use shadec::backends::vertex_program::{self as vp, emulate};

/// Tolerance of the comparison: the GPU's `1/x`, `inverseSqrt`, `log2`,
/// `exp2` (a few ulps each) and a multiply-add it may fuse, carried through
/// at most a dozen instructions on values of magnitude about 1.
const TOLERANCE: f32 = 1.0e-4;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn float(&mut self) -> f32 {
        let m = 0.25 + 1.75 * (self.below(1 << 20) as f32 / (1 << 20) as f32);
        if self.below(2) == 0 {
            m
        } else {
            -m
        }
    }
}

fn source(rng: &mut Rng, temps: usize, scalar: bool, allow_temps: bool) -> Source {
    let reg = match rng.below(if allow_temps && temps > 0 { 3 } else { 2 }) {
        0 => SrcReg::Attribute(rng.below(4) as u8),
        1 => SrcReg::Parameter(rng.below(8) as u8),
        _ => SrcReg::Temporary(rng.below(temps) as u8),
    };
    let swizzle = if scalar || rng.below(3) == 0 {
        [rng.below(4) as u8; 4]
    } else {
        [0, 1, 2, 3].map(|_| rng.below(4) as u8)
    };
    Source { negate: rng.below(3) == 0, reg, swizzle }
}

/// Sources reading at most one attribute and one parameter register.
fn sources(rng: &mut Rng, n: usize, temps: usize, scalar: bool, allow_temps: bool) -> Vec<Source> {
    let mut out: Vec<Source> = Vec::new();
    while out.len() < n {
        let s = source(rng, temps, scalar, allow_temps);
        let clash = out.iter().any(|o| {
            std::mem::discriminant(&o.reg) == std::mem::discriminant(&s.reg)
                && o.reg != s.reg
                && !matches!(s.reg, SrcReg::Temporary(_))
        });
        if !clash {
            out.push(s);
        }
    }
    out
}

/// Smooth instructions into R0..R5, then every result register from the
/// attributes and parameters, with the discontinuous instructions (SLT,
/// SGE, EXP's floor, LOG's exponent, ARL) reading only inputs, which both
/// sides hold bit for bit.
fn program(rng: &mut Rng) -> VertexProgram {
    use Opcode::*;
    let smooth = [Mov, Mul, Add, Mad, Dst, Min, Max, Dp3, Dp4, Rcp, Rsq];
    let mut instructions = Vec::new();
    for t in 0..6 {
        let op = smooth[rng.below(smooth.len())];
        let src = sources(rng, op.sources(), t, op.shape() == Shape::Scalar, true);
        instructions.push(Instruction { op, dst: Dest { reg: DstReg::Temporary(t as u8), mask: 15 }, src });
    }
    // Every other program is `!!VP1.1`, with its four instructions too.
    let v11 = rng.below(2) == 0;
    let all = [
        Mov, Mul, Add, Mad, Dst, Min, Max, Slt, Sge, Rcp, Rsq, Dp3, Dp4, Log, Exp, Lit, Arl, Dph, Rcc, Sub,
        Abs,
    ];
    let n = if v11 { all.len() } else { 17 };
    for out in 0..OUTPUTS as u8 {
        let op = all[rng.below(n)];
        if op == Arl {
            let src = sources(rng, 1, 0, true, false);
            instructions.push(Instruction { op, dst: Dest { reg: DstReg::Address, mask: 1 }, src });
            let offset = rng.below(8) as i8 - 2;
            let read = Source { negate: false, reg: SrcReg::Relative(offset), swizzle: [0, 1, 2, 3] };
            instructions.push(Instruction {
                op: Mov,
                dst: Dest { reg: DstReg::Output(Output(out)), mask: 15 },
                src: vec![read],
            });
            continue;
        }
        let temps_ok = !matches!(op, Slt | Sge | Exp | Log | Lit);
        let src = sources(rng, op.sources(), 6, op.shape() == Shape::Scalar, temps_ok);
        let mask = 1 + rng.below(15) as u8;
        instructions.push(Instruction { op, dst: Dest { reg: DstReg::Output(Output(out)), mask }, src });
    }
    let version = if v11 { Version::V11 } else { Version::V10 };
    VertexProgram { version, position_invariant: false, instructions }
}

fn close(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits()
        || (a.is_nan() && b.is_nan())
        || (a - b).abs() <= TOLERANCE * (1.0 + a.abs().max(b.abs()))
}

const VERTICES: usize = 64;

fn harness(program: &VertexProgram) -> String {
    format!(
        "{}
@group(0) @binding(1) var<storage, read> attrs: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> outs: array<vec4<f32>>;

@compute @workgroup_size(64)
fn cs(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if (i >= {VERTICES}u) {{ return; }}
    var v: array<vec4<f32>, 16>;
    for (var k = 0u; k < 16u; k++) {{ v[k] = attrs[i * 16u + k]; }}
    let o = vertex_program(v);
    for (var k = 0u; k < 15u; k++) {{ outs[i * 15u + k] = o[k]; }}
}}
",
        vp::wgsl::function(program)
    )
}

fn run_gpu(
    gpu: &shadec::gpu::runner::Gpu,
    program: &VertexProgram,
    attrs: &[[f32; 4]],
    params: &[[f32; 4]; 96],
) -> Vec<[f32; 4]> {
    use wgpu::util::DeviceExt;
    let device = gpu.device();
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("vp"),
        source: wgpu::ShaderSource::Wgsl(harness(program).into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("vp"),
        layout: None,
        module: &module,
        entry_point: Some("cs"),
        compilation_options: Default::default(),
        cache: None,
    });
    let c = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(params.as_slice()),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let a = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(attrs),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (VERTICES * OUTPUTS * 16) as u64;
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let read = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: c.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: a.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: out.as_entire_binding() },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    encoder.copy_buffer_to_buffer(&out, 0, &read, 0, size);
    gpu.queue().submit([encoder.finish()]);
    let slice = read.slice(..);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let data = slice.get_mapped_range().unwrap();
    bytemuck::cast_slice::<u8, [f32; 4]>(&data).to_vec()
}

#[test]
fn generated_programs_agree_between_the_interpreter_and_wgpu() {
    let Some(gpu) = crate::common::gpu::gpu() else { return };
    let mut rng = Rng(0x5eed_1cad_0000_0001);
    let mut worst = 0.0f32;
    for case in 0..24 {
        let p = program(&mut rng);
        let text = vp::print(&p);
        let again = vp::parse_file(&text)
            .unwrap_or_else(|e| panic!("generated program {case} does not validate: {e:?}\n{text}"));
        assert_eq!(again, p);
        let attrs: Vec<[f32; 4]> = (0..VERTICES * 16).map(|_| [0; 4].map(|_| rng.float())).collect();
        let mut params = [[0.0; 4]; 96];
        for c in params.iter_mut() {
            *c = [0; 4].map(|_| rng.float());
        }
        let got = run_gpu(&gpu, &p, &attrs, &params);
        for v in 0..VERTICES {
            let a: [[f32; 4]; 16] = attrs[v * 16..v * 16 + 16].try_into().unwrap();
            let want = emulate::run(&p, &a, &params);
            for (o, w) in want.outputs.iter().enumerate() {
                let g = got[v * OUTPUTS + o];
                for k in 0..4 {
                    if w[k].is_finite() && g[k].is_finite() {
                        worst = worst.max((w[k] - g[k]).abs() / (1.0 + w[k].abs()));
                    }
                    assert!(
                        close(w[k], g[k]),
                        "case {case}, vertex {v}, o[{}].{k}: interpreter {} wgpu {}\n{text}",
                        OUTPUT_NAMES[o],
                        w[k],
                        g[k]
                    );
                }
            }
        }
    }
    eprintln!("vertex programs: worst relative difference interpreter vs wgpu {worst:e}");
}
