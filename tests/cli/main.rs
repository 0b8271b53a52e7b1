//! The command line end to end: commands and their outputs, bad input,
//! outputs that must not be lost, out of memory, fuzzed arguments, and the
//! GPU devices through the CLI. One test binary; each module is one concern.

#[path = "../support/mod.rs"]
mod support;

mod bad_input;
mod commands;
mod fuzz_cli;
mod gpu;
mod oom;
mod outputs;
