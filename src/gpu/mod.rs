//! The wgpu executor (feature `gpu`): runs the WGSL backend's modules
//! offscreen on whatever adapter there is — a real GPU, or Mesa's lavapipe
//! on the CPU.
//!
//! - `runner`: render a list of passes — WGSL or a `naga::Module`,
//!   vertices, textures, uniforms and the GL-style fixed-function state of
//!   `pipeline::RenderState` — into one target and read it back;
//! - `scene_run`: a whole plan on a scene, bound by the same scene binder
//!   as the CPU renderer (`scene::bind`), rendered textures included;
//! - `timer`: a frame's GPU time from timestamp queries;
//! - `vertex_stage`: a pass's vertex program (NV_vertex_program) as its
//!   WGSL vertex stage, on targets that have them;
//! - `adaptive`: adaptive sample shading as a sparse pass and an
//!   interpolating full pass (Adaptive Sample Shading, Section 2.1);
//! - `runtime_dir`: a private `XDG_RUNTIME_DIR` where the environment has
//!   none, so Mesa's drivers do not print an error that is not shadec's.

pub mod adaptive;
pub mod runner;
pub mod runtime_dir;
pub mod scene_run;
pub mod timer;
pub mod vertex_stage;
