//! Programs in the shapes that public `!!VP1.0` / `!!VP1.1` / `!!RC1.0` /
//! `!!TS1.0` sources write them, one per class of failure that running
//! real public programs through shadec found (docs/vertex-programs.md,
//! "Public programs", lists the sources and the counts). The programs in
//! `tests/data/public_shapes/` are written for shadec, not copied. Each
//! accepted one goes through all four steps a public program must pass:
//! read, validate, emulate, translate to WGSL that naga validates; each
//! refused one is refused with the spec's reason, located.
//!
//! `public_corpus_report` (ignored: it needs a folder that is not in the
//! repository) runs the same four steps over every file of
//! `$SHADEC_PUBLIC_CORPUS` and prints one line per file.

use shadec::backends::combiners::emulator::{self, Inputs, Precision};
use shadec::backends::combiners::ts1::emulate::{shade, Image, TextureInputs};
use shadec::backends::combiners::{rc1, ts1, CombinerLimits};
use shadec::backends::vertex_program::{self as vp, emulate, Output, VertexProgram};
use shadec::diag::{Diagnostic, SourceFile};

type Vec4 = [f32; 4];

fn shape(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/public_shapes").join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Some vertex: every attribute a different, non-trivial value.
fn some_attributes() -> [Vec4; 16] {
    std::array::from_fn(|k| {
        let k = k as f32;
        [0.25 + 0.1 * k, -0.5 + 0.05 * k, 0.75 - 0.03 * k, 1.0]
    })
}

/// Some parameters: `c[0..4]` the identity, the rest different values.
fn some_parameters() -> [Vec4; 96] {
    std::array::from_fn(|k| {
        if k < 4 {
            let mut row = [0.0; 4];
            row[k] = 1.0;
            return row;
        }
        let k = k as f32;
        [0.5 + 0.01 * k, 0.25 - 0.02 * k, 1.0 + 0.03 * k, 0.5]
    })
}

/// The four steps on a vertex program: the program, or the first step that
/// refused it with its rendered diagnostics.
fn vertex_program(name: &str, text: &str) -> Result<VertexProgram, (&'static str, String)> {
    let render = |ds: &[Diagnostic]| SourceFile::new(name.to_string(), text.to_string()).render(ds, false);
    let parsed = vp::read(text).map_err(|d| ("read", render(&[d])))?;
    let errors = vp::validate(&parsed.program);
    if !errors.is_empty() {
        let ds: Vec<Diagnostic> =
            errors.iter().map(|e| e.to_diagnostic(&parsed.spans, parsed.header)).collect();
        return Err(("validate", render(&ds)));
    }
    let program = parsed.program;
    if program.version.is_state_program() {
        let mut c = some_parameters();
        emulate::run_state(&program, [1.0, 2.0, 3.0, 4.0], &mut c);
        if c == some_parameters() {
            return Err(("emulate", "the state program changed no parameter".into()));
        }
    } else {
        let r = emulate::run(&program, &some_attributes(), &some_parameters());
        if !program.position_invariant && r.get(Output::HPOS).iter().any(|x| x.is_nan()) {
            return Err(("emulate", "o[HPOS] is NaN".into()));
        }
    }
    let printed = vp::print(&program);
    match vp::parse_file(&printed) {
        Ok(p) if p == program => {}
        other => return Err(("print", format!("{other:?}\n{printed}"))),
    }
    let wgsl = vp::wgsl::translate(&program, name);
    let module = naga::front::wgsl::parse_str(&wgsl).map_err(|e| ("translate", e.emit_to_string(&wgsl)))?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| ("translate", format!("{e:?}")))?;
    Ok(program)
}

/// Read, validate and print back a `!!RC1.0` setup (with its `!!TS1.0`
/// part, if any), and translate it to WGSL that naga validates.
fn combiners(name: &str, text: &str) -> Result<(), (&'static str, String)> {
    let limits = CombinerLimits::GEFORCE3;
    let render = |ds: &[Diagnostic]| SourceFile::new(name.to_string(), text.to_string()).render(ds, false);
    let config = rc1::parse_and_validate(text, &limits).map_err(|ds| ("read", render(&ds)))?;
    let texels = some_texels();
    let inputs = Inputs {
        width: 2,
        height: 2,
        textures: [Some(&texels); 4],
        primary: Some(&texels),
        secondary: Some(&texels),
        ..Inputs::default()
    };
    emulator::emulate(&config, &inputs, Precision::Fixed9).map_err(|e| ("emulate", e.to_string()))?;
    let printed = rc1::print(&config);
    rc1::parse_and_validate(&printed, &limits).map_err(|ds| ("print", format!("{ds:?}\n{printed}")))?;
    let wgsl =
        shadec::backends::wgsl::rc1::translate(&config, name).map_err(|e| ("translate", e.to_string()))?;
    let module = naga::front::wgsl::parse_str(&wgsl).map_err(|e| ("translate", e.emit_to_string(&wgsl)))?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| ("translate", format!("{e:?}")))?;
    Ok(())
}

fn texture_shader(name: &str, text: &str) -> Result<(), (&'static str, String)> {
    let render = |ds: &[Diagnostic]| SourceFile::new(name.to_string(), text.to_string()).render(ds, false);
    let program = ts1::parse_file(text).map_err(|ds| ("read", render(&ds)))?;
    let texels = some_texels();
    let image = Image { width: 2, height: 2, rgba: &texels };
    let inputs = TextureInputs { width: 2, height: 2, textures: [Some(image); 4], coords: [None; 4] };
    shade(&program, &inputs).map_err(|e| ("emulate", e.to_string()))?;
    let printed = ts1::print(&program);
    match ts1::parse_file(&printed) {
        Ok(p) if p == program => Ok(()),
        other => Err(("print", format!("{other:?}\n{printed}"))),
    }
}

/// A 2×2 RGBA8 image of different texels.
fn some_texels() -> Vec<u8> {
    vec![10, 200, 30, 255, 128, 64, 250, 0, 0, 255, 128, 77, 255, 255, 0, 128]
}

/// Any of the formats, by its header (a `!!TS1.0` part in front of an
/// `!!RC1.0` one goes with the combiners).
fn any(name: &str, text: &str) -> Result<(), (&'static str, String)> {
    let head = text.trim_start();
    if head.starts_with("!!RC1.0") || text.contains("!!RC1.0") {
        combiners(name, text)
    } else if head.starts_with("!!TS1.0") {
        texture_shader(name, text)
    } else {
        vertex_program(name, text).map(|_| ())
    }
}

#[test]
#[ignore = "a tool, not a test: runs the folder $SHADEC_PUBLIC_CORPUS, which is not in the repository"]
fn public_corpus_report() {
    let Ok(dir) = std::env::var("SHADEC_PUBLIC_CORPUS") else { return };
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    entries.sort();
    for path in entries {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).into_owned();
        match std::panic::catch_unwind(|| any(&name, &text)) {
            Ok(Ok(())) => println!("OK\t{name}"),
            Ok(Err((step, why))) => {
                println!("REFUSED\t{name}\t{step}\t{}", why.lines().next().unwrap_or(""));
                eprintln!("----- {name} ({step})\n{why}");
            }
            Err(_) => println!("PANIC\t{name}"),
        }
    }
}

/// The first error of `name` (which must be refused by one of the four
/// steps' readers): its code, `file:line:col`, message and help.
fn refused(name: &str) -> (&'static str, String, String, String) {
    let text = shape(name);
    let ds = if name.ends_with(".rc") {
        rc1::parse_and_validate(&text, &CombinerLimits::GEFORCE3).err()
    } else {
        vp::parse_file(&text).err()
    };
    let ds = ds.unwrap_or_else(|| panic!("{name} was accepted"));
    let d = &ds[0];
    let file = SourceFile::new(name, text.clone());
    let help = d.help.clone().unwrap_or_else(|| panic!("{name}: no help: {d:?}"));
    (d.code, file.location(d.primary.span.start), d.message.clone(), help)
}

fn accepted(name: &str) -> VertexProgram {
    vertex_program(name, &shape(name)).unwrap_or_else(|(step, why)| panic!("{name}: {step}: {why}"))
}

#[test]
fn a_vertex_state_program_runs_once_and_updates_the_parameters_it_writes() {
    let p = accepted("state_program_normalize.vsp");
    assert!(p.version.is_state_program());
    let mut c = [[0.0f32; 4]; 96];
    c[20] = [3.0, 0.0, 4.0, 7.0];
    emulate::run_state(&p, [2.0, 0.5, 0.0, 0.0], &mut c);
    // |(3, 0, 4)| = 5: the unit direction (0.6, 0, 0.8), w scaled too.
    let unit = [0.6, 0.0, 0.8, 1.4];
    for k in 0..4 {
        assert!((c[21][k] - unit[k]).abs() < 1e-6, "{:?}", c[21]);
    }
    // c[22].xyz = unit * 2 + 0.5; c[22].w = c[21].x, written two lines up.
    let want = [1.7, 0.5, 2.1, 0.6];
    for k in 0..4 {
        assert!((c[22][k] - want[k]).abs() < 1e-6, "{:?}", c[22]);
    }
    assert_eq!(c[20], [3.0, 0.0, 4.0, 7.0], "a parameter it only reads is left as it was");
}

#[test]
fn a_vertex_state_program_translates_to_a_compute_shader_over_the_parameters() {
    let p = accepted("state_program_normalize.vsp");
    let wgsl = vp::wgsl::translate(&p, "state_program_normalize.vsp");
    assert!(wgsl.contains("@compute"), "{wgsl}");
    assert!(wgsl.contains("var<storage, read_write> c: array<vec4<f32>, 96>"), "{wgsl}");
    assert!(wgsl.contains("c[21] = "), "{wgsl}");
}

#[test]
fn a_vertex_state_program_reading_another_attribute_is_refused() {
    let (code, at, message, _) = refused("state_program_reads_v1.vsp");
    assert_eq!((code, at.as_str()), ("state-program-attribute", "state_program_reads_v1.vsp:3:15"));
    assert!(message.contains("only `v[0]`"), "{message}");
}

#[test]
fn a_vertex_state_program_writing_a_result_is_refused() {
    let (code, at, _, help) = refused("state_program_writes_result.vsp");
    assert_eq!((code, at.as_str()), ("state-program-result", "state_program_writes_result.vsp:3:5"));
    assert!(help.contains("c[0]"), "{help}");
}

#[test]
fn a_vertex_state_program_writing_no_parameter_is_refused() {
    let (code, at, _, _) = refused("state_program_no_parameter.vsp");
    assert_eq!((code, at.as_str()), ("state-program-no-parameter", "state_program_no_parameter.vsp:1:1"));
}

#[test]
fn text_after_end_is_refused_at_its_first_token() {
    let (code, at, message, _) = refused("text_after_end.vp");
    assert_eq!((code, at.as_str()), ("syntax", "text_after_end.vp:7:1"));
    assert!(message.contains("after `END`"), "{message}");
}

#[test]
fn a_comment_after_end_is_blank() {
    let p = accepted("comment_after_end.vp");
    assert_eq!(p.instructions.len(), 8);
    let mut v = some_attributes();
    v[0] = [1.0, 2.0, 3.0, 1.0];
    let mut c = some_parameters();
    c[3] = [0.0, 0.0, 0.0, 2.0];
    // R0 = (1, 2, 3, 2): the position divided by its w, w kept.
    let r = emulate::run(&p, &v, &c);
    assert_eq!(r.get(Output::HPOS), [0.5, 1.0, 1.5, 2.0]);
}

#[test]
fn an_option_in_a_vp10_program_names_nv_vertex_program1_1() {
    let (code, at, message, help) = refused("option_in_vp10.vp");
    assert_eq!((code, at.as_str()), ("syntax", "option_in_vp10.vp:2:1"));
    assert!(message.contains("!!VP1.0"), "{message}");
    assert!(help.contains("NV_vertex_program1_1"), "{help}");
}

#[test]
fn an_option_after_an_instruction_is_refused() {
    let (code, at, _, help) = refused("option_after_instruction.vp");
    assert_eq!((code, at.as_str()), ("syntax", "option_after_instruction.vp:3:1"));
    assert!(help.contains("before the first instruction"), "{help}");
}

#[test]
fn the_xboxs_r12_is_refused_with_its_reason() {
    let (code, at, _, help) = refused("xbox_r12.vp");
    assert_eq!((code, at.as_str()), ("register-range", "xbox_r12.vp:6:13"));
    assert!(help.contains("R0`..`R11") && help.contains("Xbox"), "{help}");
}

#[test]
fn tabs_trailing_blanks_and_end_with_a_space_read() {
    let p = accepted("tabs_and_trailing_blanks.vp");
    assert_eq!(p.instructions.len(), 5);
    let mut c = some_parameters();
    c[8] = [0.1, 0.2, 0.3, 0.4];
    let r = emulate::run(&p, &some_attributes(), &c);
    assert_eq!(r.get(Output::COL0), [0.1, 0.2, 0.3, 0.4]);
}

#[test]
fn statements_glued_on_one_line_after_a_header_comment_read() {
    let p = accepted("glued_statements.vp");
    assert!(p.position_invariant);
    assert_eq!(p.instructions.len(), 5);
}

#[test]
fn an_rgb_portion_reading_blue_is_refused_with_the_specs_reason() {
    let (code, at, message, _) = refused("rgb_reads_blue.rc");
    assert_eq!((code, at.as_str()), ("component-usage", "rgb_reads_blue.rc:4:14"));
    assert!(message.contains("blue"), "{message}");
}

#[test]
fn a_setup_with_only_out_rgb_runs_and_translates() {
    combiners("rgb_only.rc", &shape("rgb_only.rc")).unwrap_or_else(|(s, w)| panic!("{s}: {w}"));
}

#[test]
fn a_culling_texture_shader_with_nops_runs() {
    texture_shader("cull_only.ts", &shape("cull_only.ts")).unwrap_or_else(|(s, w)| panic!("{s}: {w}"));
}

#[test]
fn the_cli_translates_a_state_program_and_names_an_arb_program() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/public_shapes");
    let run = |name: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_shadec"))
            .arg("translate")
            .arg(dir.join(name))
            .output()
            .unwrap()
    };
    let out = run("state_program_normalize.vsp");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("@compute"));
    let tmp = std::env::temp_dir().join(format!("shadec-arb-{}.vp", std::process::id()));
    std::fs::write(&tmp, "!!ARBvp1.0\nMOV result.position, vertex.position;\nEND\n").unwrap();
    let out =
        std::process::Command::new(env!("CARGO_BIN_EXE_shadec")).arg("translate").arg(&tmp).output().unwrap();
    let _ = std::fs::remove_file(&tmp);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("ARB_vertex_program") && !stderr.contains("RC1.0"), "{stderr}");
}

#[test]
fn a_comment_before_the_header_is_refused_with_where_to_move_it() {
    let (code, at, _, help) = refused("comment_before_header.rc");
    assert_eq!((code, at.as_str()), ("syntax", "comment_before_header.rc:1:1"));
    assert!(help.contains("move the comment below `!!TS1.0`"), "{help}");
    let text = "# a program\n!!VP1.0\nMOV o[HPOS], v[0];\nEND\n";
    let ds = vp::parse_file(text).unwrap_err();
    let help = ds[0].help.clone().unwrap_or_default();
    assert!(help.contains("move the comment below `!!VP1.0`"), "{help}");
}

/// Runs the WGSL translation of a vertex state program once on wgpu and
/// reads its parameter buffer back.
fn run_state_on_gpu(gpu: &shadec::gpu::runner::Gpu, wgsl: &str, v0: Vec4, c: &[Vec4; 96]) -> Vec<Vec4> {
    use wgpu::util::DeviceExt;
    let device = gpu.device();
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("vsp"),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("vsp"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(c.as_slice()),
        usage: storage,
    });
    let v = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: bytemuck::cast_slice(&[v0]),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let size = (96 * 16) as u64;
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
            wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: v.as_entire_binding() },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    encoder.copy_buffer_to_buffer(&params, 0, &read, 0, size);
    gpu.queue().submit([encoder.finish()]);
    let slice = read.slice(..);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let data = slice.get_mapped_range().unwrap();
    bytemuck::cast_slice::<u8, Vec4>(&data).to_vec()
}

#[test]
fn a_vertex_state_program_on_wgpu_updates_the_parameters_as_the_interpreter_does() {
    let Some(gpu) = crate::common::gpu::gpu() else { return };
    let p = accepted("state_program_normalize.vsp");
    let wgsl = vp::wgsl::translate(&p, "state_program_normalize.vsp");
    let mut c = some_parameters();
    c[20] = [3.0, 0.0, 4.0, 7.0];
    let v0 = [2.0, 0.5, 0.0, 0.0];
    let got = run_state_on_gpu(&gpu, &wgsl, v0, &c);
    emulate::run_state(&p, v0, &mut c);
    assert_ne!(c[22], some_parameters()[22], "the interpreter wrote c[22]");
    for (k, (g, w)) in got.iter().zip(c.iter()).enumerate() {
        for i in 0..4 {
            assert!(
                (g[i] - w[i]).abs() <= 1e-5 * (1.0 + w[i].abs()),
                "c[{k}]: wgpu {g:?}, interpreter {w:?}"
            );
        }
    }
}
