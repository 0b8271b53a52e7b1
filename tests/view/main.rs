//! The viewer in a real window and headless (`stratasweep view`).
//! One test binary.

#[path = "../support/mod.rs"]
mod support;

mod window;
