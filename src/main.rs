//! The `stratasweep` command line: info, slice, generate, bench, render, view.

mod cli;

fn main() {
    cli::main()
}
