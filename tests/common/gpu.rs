//! The one place GPU tests get a device (issue 5): with no adapter they
//! fail with the fix, unless `SHADEC_ALLOW_NO_GPU=1` outside CI — the only
//! allowed skip, and it says so.

use shadec::gpu::runner::Gpu;

/// A device, or `None` only for the documented skip.
pub fn gpu() -> Option<Gpu> {
    match Gpu::new() {
        Ok(gpu) => {
            eprintln!("adapter: {gpu}");
            Some(gpu)
        }
        Err(err) => {
            let allowed = std::env::var("SHADEC_ALLOW_NO_GPU").is_ok_and(|v| v == "1");
            let in_ci = std::env::var("CI").is_ok_and(|v| v == "true");
            if allowed && !in_ci {
                eprintln!("SKIPPED: no GPU adapter (SHADEC_ALLOW_NO_GPU=1): {err}");
                None
            } else {
                panic!("{err}\nGPU tests need an adapter; set SHADEC_ALLOW_NO_GPU=1 to skip them outside CI (never allowed with CI=true)");
            }
        }
    }
}
