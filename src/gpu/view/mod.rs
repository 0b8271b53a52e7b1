//! The viewer without a window, on top of the renderer: the headless
//! [`scene`] (camera, cached slices, the worker that rebuilds them), the
//! [`present`] pass into a window surface and the [`outline`] box. The
//! window itself (egui, winit) is the CLI's.

pub mod outline;
pub mod present;
pub mod scene;
