//! The GPU path, in rooms that import only downwards: [`view`] →
//! [`render`] → [`compute`] → the device.
//!
//! This folder keeps the device and what every pass shares: [`context`]
//! (adapter, limits, read-back), [`shaders`] (WGSL composition and naga
//! validation) and [`shared`] (every struct shared with WGSL). Nothing
//! outside `gpu` imports wgpu.

pub mod compute;
pub mod context;
pub mod render;
pub mod shaders;
pub mod shared;
pub mod view;
