//! Shared by the GPU test files: one device per test binary, skipping loudly
//! without an adapter unless `STRATASWEEP_REQUIRE_GPU=1` (CI), where a
//! missing adapter fails the test.

use std::sync::OnceLock;
use stratasweep::gpu::context::{ContextOptions, GpuContext};

static CTX: OnceLock<Option<GpuContext>> = OnceLock::new();

/// The shared device, or `None` (after printing SKIP) when there is none.
pub fn gpu(test: &str) -> Option<&'static GpuContext> {
    let c = CTX.get_or_init(|| match GpuContext::new(&ContextOptions::default()) {
        Ok(c) => {
            eprintln!("GPU adapter: {}", c.name);
            Some(c)
        }
        Err(e) => {
            if std::env::var("STRATASWEEP_REQUIRE_GPU").as_deref() == Ok("1") {
                panic!("STRATASWEEP_REQUIRE_GPU=1 but there is no usable adapter: {e}");
            }
            eprintln!("SKIP GPU tests (set STRATASWEEP_REQUIRE_GPU=1 to fail instead): {e}");
            None
        }
    });
    if c.is_none() {
        eprintln!("SKIP {test}: no GPU adapter");
    }
    c.as_ref()
}
